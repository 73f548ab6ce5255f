//! The exponential the Gaussian rasteriser's α uses, in one scalar and one
//! 8-lane AVX2 form that give the same bits for every input.
//!
//! α = min(0.99, o·exp(power)) is evaluated for every (pixel, Gaussian) pair
//! the tile lists pair up, so the exponential is a large share of a render.
//! libm's `expf` has no 8-lane form, so the forward pass could not blend 8
//! pixels at once and still agree with the scalar paths (the backward pass,
//! [`crate::gaussian::render_pixels`]) bit for bit. Both forms here are the
//! same sequence of IEEE f32 operations, each rounded once (no fused
//! multiply-add, which Rust never introduces on its own), so they agree
//! exactly; the test checks it on a dense grid and on random inputs.
//!
//! Method (Cephes' `expf` scheme and coefficients): n = round(x·log₂e) (by
//! adding and subtracting 1.5·2²³, which needs no conversion instruction),
//! r = x − n·ln2 with ln2 split in two constants so n·C1 is exact, exp(r) by
//! a degree-7 polynomial 1 + r + r²·P(r) (P evaluated by Estrin's scheme, for
//! a short dependency chain), times 2ⁿ built in the exponent bits. Inputs are clamped
//! to [−87, 88] so 2ⁿ stays a normal number; the rasteriser only asks for
//! x in [ln(1/(255·o)) − 1e-4, 0]. Measured: relative error at most 8.0e-8 (under
//! 1 ulp) against f64 `exp` on [−87, 88] (test `matches_f64_exp`); CUDA's
//! `expf`, which the official kernels call, is specified to 2 ulp.

const LOG2E: f32 = std::f32::consts::LOG2_E;
/// ln 2 = C1 + C2 (C2 < 0): C1 has few significant bits, so n·C1 is exact.
const C1: f32 = 0.693_359_4;
const C2: f32 = -2.121_944_4e-4;
/// Coefficients of P(r), highest first.
const P: [f32; 6] = [
    1.987_569_1e-4,
    1.398_199_9e-3,
    8.333_452e-3,
    4.166_579_6e-2,
    1.666_666_5e-1,
    0.5,
];
const LO: f32 = -87.0;
const HI: f32 = 88.0;

/// 1.5·2²³: adding it rounds an f32 of magnitude < 2²² to an integer (to
/// nearest, ties to even) held in the low mantissa bits.
const ROUND: f32 = 12_582_912.0;

/// exp(x) for one f32 (NaN gives an unspecified value).
#[inline]
pub fn exp(x: f32) -> f32 {
    // max/min, not clamp: a NaN maps to LO as in the 8-lane form
    #[allow(clippy::manual_clamp)]
    let x = x.max(LO).min(HI);
    // n = round(x·log₂e) without a conversion instruction
    let k = x * LOG2E + ROUND;
    let n = k - ROUND;
    let r = x - n * C1;
    let r = r - n * C2;
    // P(r) by Estrin's scheme: (p0·r + p1)·r⁴ + (p2·r + p3)·r² + (p4·r + p5)
    let r2 = r * r;
    let r4 = r2 * r2;
    let a = P[0] * r + P[1];
    let b = P[2] * r + P[3];
    let c = P[4] * r + P[5];
    let y = a * r4 + b * r2 + c;
    let y = y * r2 + r + 1.0;
    // 2ⁿ: n sits in k's low mantissa bits
    let e = (k.to_bits().wrapping_sub(ROUND.to_bits()) as i32 + 127) << 23;
    y * f32::from_bits(e as u32)
}

/// exp of 8 lanes, bit for bit [`exp`] on each lane.
///
/// # Safety
/// The CPU must support AVX2 (check `is_x86_feature_detected!("avx2")`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn exp8(x: std::arch::x86_64::__m256) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    let f = _mm256_set1_ps;
    let (add, mul) = (|a, b| _mm256_add_ps(a, b), |a, b| _mm256_mul_ps(a, b));
    let x = _mm256_min_ps(_mm256_max_ps(x, f(LO)), f(HI));
    let k = add(mul(x, f(LOG2E)), f(ROUND));
    let n = _mm256_sub_ps(k, f(ROUND));
    let r = _mm256_sub_ps(x, mul(n, f(C1)));
    let r = _mm256_sub_ps(r, mul(n, f(C2)));
    let r2 = mul(r, r);
    let r4 = mul(r2, r2);
    let a = add(mul(f(P[0]), r), f(P[1]));
    let b = add(mul(f(P[2]), r), f(P[3]));
    let c = add(mul(f(P[4]), r), f(P[5]));
    let y = add(add(mul(a, r4), mul(b, r2)), c);
    let y = add(add(mul(y, r2), r), f(1.0));
    let e = _mm256_sub_epi32(
        _mm256_castps_si256(k),
        _mm256_set1_epi32(ROUND.to_bits() as i32),
    );
    let e = _mm256_slli_epi32::<23>(_mm256_add_epi32(e, _mm256_set1_epi32(127)));
    mul(y, _mm256_castsi256_ps(e))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative error against f64 `exp` on a dense grid of [−87, 0] (the
    /// rasteriser's domain) and a coarser one of (0, 88]: below 1.2e-7, i.e.
    /// within 1 ulp of f32 (measured 8.0e-8).
    #[test]
    fn matches_f64_exp() {
        let mut worst = 0.0f64;
        for i in 0..=870_000 {
            let x = -(i as f32) * 1e-4;
            let e = (x as f64).exp();
            worst = worst.max(((exp(x) as f64) - e).abs() / e);
        }
        for i in 1..=880 {
            let x = i as f32 * 0.1;
            let e = (x as f64).exp();
            worst = worst.max(((exp(x) as f64) - e).abs() / e);
        }
        assert!(worst <= 1.2e-7, "worst relative error {worst:e}");
        assert_eq!(exp(0.0), 1.0, "exp(0) is exact");
    }

    /// The 8-lane form gives exactly the scalar bits, on the grid and on
    /// random inputs (including out-of-range ones, which both clamp).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn eight_lanes_equal_scalar_bit_for_bit() {
        use std::arch::x86_64::*;
        if !is_x86_feature_detected!("avx2") {
            eprintln!("skipped: no AVX2 on this CPU");
            return;
        }
        let mut s = 0x1234_5678_u32;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s
        };
        for k in 0..200_000 {
            let xs: [f32; 8] = std::array::from_fn(|i| match k % 3 {
                0 => -((k * 8 + i) as f32) * 5e-5,
                1 => (next() as f32 / u32::MAX as f32) * -90.0,
                _ => (next() as f32 / u32::MAX as f32 - 0.5) * 400.0,
            });
            let mut out = [0.0f32; 8];
            // SAFETY: AVX2 checked above; loads and stores of 8 f32 arrays.
            unsafe {
                _mm256_storeu_ps(out.as_mut_ptr(), exp8(_mm256_loadu_ps(xs.as_ptr())));
            }
            for i in 0..8 {
                assert_eq!(out[i].to_bits(), exp(xs[i]).to_bits(), "x = {}", xs[i]);
            }
        }
    }
}
