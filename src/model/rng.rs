//! The crate's one seeded random generator and how seeds are derived.
//!
//! Everything random in splatkit (RANSAC sampling, surface sampling,
//! shuffles, synthetic scenes) draws from [`Rng`], a `rand_pcg::Pcg64Mcg`
//! seeded with [`seeded`]. Work split into independently seeded pieces (so
//! that the result does not depend on the rayon thread count) takes piece `i`
//! from [`stream`]`(seed, i)`, whose seed is decorrelated from its neighbours'
//! by the [`splitmix64`] mixer; the per-camera samplers of `geom::surface_points::levelset`
//! and `geom::surface_points::splat_points` use the older [`golden_stream`].
//!
//! These are the formulas the results were produced with: changing any of
//! them changes every seeded output.

use rand::SeedableRng;

/// The crate's seeded generator type (PCG-64 with a multiplicative
/// congruential step, 128-bit state).
pub type Rng = rand_pcg::Pcg64Mcg;

/// A generator seeded with `seed` (`Pcg64Mcg::seed_from_u64`).
pub fn seeded(seed: u64) -> Rng {
    Rng::seed_from_u64(seed)
}

/// The generator of piece `index` of a job seeded with `seed`:
/// `seeded(splitmix64(seed ^ splitmix64(index)))`. Distinct indices give
/// unrelated streams, and equal `(seed, index)` the same one.
pub fn stream(seed: u64, index: u64) -> Rng {
    seeded(splitmix64(seed ^ splitmix64(index)))
}

/// The generator of piece `index` of a job seeded with `seed`, the way the
/// per-camera samplers derive it: `seeded(seed ^ index·γ)` (γ =
/// 0x9E37_79B9_7F4A_7C15, wrapping). Kept beside [`stream`] because their
/// seeded outputs were produced with it; new code should use [`stream`].
pub fn golden_stream(seed: u64, index: u64) -> Rng {
    seeded(seed ^ index.wrapping_mul(GOLDEN_GAMMA))
}

/// A standard normal draw (Box–Muller on two uniforms of `rng`, the cosine
/// branch): the sampler of every Gaussian draw in training (random
/// initialisation, 3DGS's split offsets).
pub fn normal(rng: &mut Rng) -> f64 {
    use rand::RngExt;
    let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// 2⁶⁴/φ rounded to odd: the Weyl increment of SplitMix64.
const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// The SplitMix64 mixer (Steele, Lea and Flood 2014; the output function of
/// Java's `SplittableRandom`): a bijection on `u64` under which nearby inputs
/// give unrelated outputs.
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(GOLDEN_GAMMA);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    /// The first three outputs of the SplitMix64 generator seeded with 0
    /// (Vigna's `splitmix64.c`: the state advances by γ = 0x9E37…7C15, then
    /// is mixed), i.e. splitmix64(k·γ) for k = 0, 1, 2.
    #[test]
    fn splitmix64_reference_values() {
        assert_eq!(splitmix64(0), 0xE220_A839_7B1D_CDAF);
        assert_eq!(splitmix64(0x9E37_79B9_7F4A_7C15), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(
            splitmix64(0x9E37_79B9_7F4A_7C15u64.wrapping_mul(2)),
            0x06C4_5D18_8009_454F
        );
    }

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let draw = |mut r: Rng| -> Vec<u64> { (0..4).map(|_| r.random::<u64>()).collect() };
        assert_eq!(draw(stream(7, 3)), draw(stream(7, 3)));
        assert_ne!(draw(stream(7, 3)), draw(stream(7, 4)));
        assert_ne!(draw(stream(7, 3)), draw(stream(8, 3)));
        assert_eq!(
            draw(stream(7, 3)),
            draw(seeded(splitmix64(7 ^ splitmix64(3))))
        );
        assert_eq!(draw(seeded(5)), draw(rand_pcg::Pcg64Mcg::seed_from_u64(5)));
        assert_eq!(
            draw(golden_stream(7, 3)),
            draw(seeded(7 ^ 3u64.wrapping_mul(0x9E37_79B9_7F4A_7C15)))
        );
    }
}
