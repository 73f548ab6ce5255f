//! The sRGB transfer functions (IEC 61966-2-1) between our 8-bit sRGB
//! colours and glTF's linear `COLOR_0`.
//!
//! glTF 2.0 (§3.7.2.1, "COLOR_n") defines vertex colours as linear RGB(A);
//! the meshes in this crate store 8-bit sRGB-encoded colours (as PLY, OBJ
//! and OFF files and their viewers do). The writer decodes with the exact
//! piecewise EOTF, the reader encodes back with the exact OETF; alpha is
//! linear in both and passes unchanged.

/// The sRGB EOTF: an sRGB-encoded value `c` in [0, 1] to linear light,
/// `c / 12.92` for `c ≤ 0.04045`, else `((c + 0.055) / 1.055)^2.4`.
pub(crate) fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB OETF, inverse of [`srgb_to_linear`]: linear `l` in [0, 1] to
/// the sRGB-encoded value, `12.92 l` for `l ≤ 0.0031308`, else
/// `1.055 l^(1/2.4) − 0.055`.
pub(crate) fn linear_to_srgb(l: f64) -> f64 {
    if l <= 0.003_130_8 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// The linear value of the 8-bit sRGB code `c`, as f32.
pub(crate) fn srgb8_to_linear(c: u8) -> f32 {
    srgb_to_linear(f64::from(c) / 255.0) as f32
}

/// The 8-bit sRGB code of linear `l` (clamped to [0, 1]; NaN gives 0):
/// `round(255 · OETF(l))`.
pub(crate) fn linear_to_srgb8(l: f64) -> u8 {
    let l = if l.is_nan() { 0.0 } else { l.clamp(0.0, 1.0) };
    (linear_to_srgb(l) * 255.0).round() as u8
}

/// [`linear_to_srgb8`] of every 8-bit linear code `k / 255`, for normalised
/// u8 `COLOR_0` accessors.
pub(crate) fn linear8_to_srgb8_table() -> [u8; 256] {
    std::array::from_fn(|k| linear_to_srgb8(k as f64 / 255.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values_and_continuity_at_the_knee() {
        // Reference points of IEC 61966-2-1: 0 and 1 are fixed, mid grey
        // 0.5 sRGB is 0.214041 linear, 0.04045 sits on both branches.
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-12);
        assert!((srgb_to_linear(0.5) - 0.214_041_140_5).abs() < 1e-9);
        let knee = 0.04045;
        assert!((knee / 12.92 - ((knee + 0.055) / 1.055f64).powf(2.4)).abs() < 1e-7);
        assert!((linear_to_srgb(0.214_041_140_5) - 0.5).abs() < 1e-9);
        // Not a 2.2 power: 184/255 sRGB is 0.479 linear (0.488 with 2.2).
        assert!((srgb_to_linear(184.0 / 255.0) - 0.479_320).abs() < 1e-5);
    }

    #[test]
    fn every_code_round_trips_through_f32_and_u16() {
        for c in 0..=255u8 {
            let l = srgb8_to_linear(c);
            assert_eq!(linear_to_srgb8(f64::from(l)), c, "f32, code {c}");
            let q = (f64::from(l) * 65535.0).round() / 65535.0;
            assert_eq!(linear_to_srgb8(q), c, "u16, code {c}");
        }
        // Out of range and NaN are clamped.
        assert_eq!(linear_to_srgb8(-1.0), 0);
        assert_eq!(linear_to_srgb8(2.0), 255);
        assert_eq!(linear_to_srgb8(f64::NAN), 0);
        // 8-bit linear codes brighten: linear 184/255 shows as sRGB 221.
        assert_eq!(linear8_to_srgb8_table()[184], 221);
        assert_eq!(linear8_to_srgb8_table()[0], 0);
        assert_eq!(linear8_to_srgb8_table()[255], 255);
    }
}
