//! Real spherical harmonics in the 3DGS convention (degree 0–3).
//!
//! Coefficients are stored per channel as `coeffs[k]` for k = 0..(D+1)², where
//! k = 0 is the DC term. Colour = Σ_k Y_k(dir) · coeffs[k] + 0.5 (the caller
//! clamps). `dir` is the unit vector from the camera centre to the point.
//! Band-1 signs follow 3DGS: −C1·y, +C1·z, −C1·x.

/// Band-0 constant, 1 / (2√π).
pub const C0: f32 = 0.282_094_8;
/// Band-1 constant.
pub const C1: f32 = 0.488_602_5;
/// Band-2 constants.
pub const C2: [f32; 5] = [
    1.092_548_4,
    -1.092_548_4,
    0.315_391_57,
    -1.092_548_4,
    0.546_274_2,
];
/// Band-3 constants.
pub const C3: [f32; 7] = [
    -0.590_043_6,
    2.890_611_4,
    -0.457_045_8,
    0.373_176_33,
    -0.457_045_8,
    1.445_305_7,
    -0.590_043_6,
];

/// Number of coefficients per channel for SH degree `d` ((d+1)²).
pub const fn coeff_count(degree: usize) -> usize {
    (degree + 1) * (degree + 1)
}

/// SH degree for a per-channel coefficient count, if it is a valid square ≤ 16.
pub fn degree_for_count(count: usize) -> Option<usize> {
    (0..=3).find(|&d| coeff_count(d) == count)
}

/// The basis values Y_k(dir) for k < (degree+1)², written into `out`.
/// `dir` need not be normalised (it is normalised here; a zero vector gives DC only).
pub fn basis(degree: usize, dir: [f32; 3], out: &mut [f32; 16]) {
    *out = [0.0; 16];
    out[0] = C0;
    if degree == 0 {
        return;
    }
    let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let (x, y, z) = if n > 0.0 && n.is_finite() {
        (dir[0] / n, dir[1] / n, dir[2] / n)
    } else {
        (0.0, 0.0, 0.0)
    };
    out[1] = -C1 * y;
    out[2] = C1 * z;
    out[3] = -C1 * x;
    if degree == 1 {
        return;
    }
    let (xx, yy, zz) = (x * x, y * y, z * z);
    let (xy, yz, xz) = (x * y, y * z, x * z);
    out[4] = C2[0] * xy;
    out[5] = C2[1] * yz;
    out[6] = C2[2] * (2.0 * zz - xx - yy);
    out[7] = C2[3] * xz;
    out[8] = C2[4] * (xx - yy);
    if degree == 2 {
        return;
    }
    out[9] = C3[0] * y * (3.0 * xx - yy);
    out[10] = C3[1] * xy * z;
    out[11] = C3[2] * y * (4.0 * zz - xx - yy);
    out[12] = C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy);
    out[13] = C3[4] * x * (4.0 * zz - xx - yy);
    out[14] = C3[5] * z * (xx - yy);
    out[15] = C3[6] * x * (xx - 3.0 * yy);
}

/// Evaluates RGB = Σ_k Y_k(dir)·coeffs[k][c] + 0.5 (unclamped).
///
/// `coeffs` is coefficient-major: `coeffs[k] = [r, g, b]` for k < (degree+1)².
/// The sum is accumulated in f32 in the reference order (DC term first, then
/// each band's terms in index order, 0.5 added last), so colours truncated
/// to 8 bits match the reference exporters bit for bit in practice.
pub fn eval_rgb(degree: usize, coeffs: &[[f32; 3]], dir: [f32; 3]) -> [f32; 3] {
    let mut y = [0.0f32; 16];
    basis(degree, dir, &mut y);
    let n = coeff_count(degree).min(coeffs.len());
    let mut rgb = [0.0f32; 3];
    for c in 0..3 {
        let mut acc = y[0] * coeffs[0][c];
        for k in 1..n {
            acc += y[k] * coeffs[k][c];
        }
        rgb[c] = acc + 0.5;
    }
    rgb
}

/// RGB in [0,1] to the DC coefficient: (rgb − 0.5) / C0.
pub fn rgb_to_sh(rgb: f32) -> f32 {
    (rgb - 0.5) / C0
}

/// DC coefficient to RGB: C0·dc + 0.5 (unclamped).
pub fn sh_to_rgb(dc: f32) -> f32 {
    C0 * dc + 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Monte-Carlo check that the basis is orthonormal on the sphere, which
    /// pins every constant and polynomial (a wrong sign or constant breaks it).
    #[test]
    fn basis_is_orthonormal() {
        // Fibonacci sphere: near-uniform points; 20k points give ~1e-3 accuracy.
        let n = 20_000;
        let mut gram = [[0.0f64; 16]; 16];
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        for i in 0..n {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let th = golden * i as f64;
            let mut y = [0.0f32; 16];
            basis(
                3,
                [(r * th.cos()) as f32, (r * th.sin()) as f32, z as f32],
                &mut y,
            );
            for (row, &ya) in gram.iter_mut().zip(&y) {
                for (g, &yb) in row.iter_mut().zip(&y) {
                    *g += ya as f64 * yb as f64;
                }
            }
        }
        let area = 4.0 * std::f64::consts::PI / n as f64;
        for (a, row) in gram.iter().enumerate() {
            for (b, g) in row.iter().enumerate() {
                let v = g * area;
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 2e-3, "gram[{a}][{b}] = {v}");
            }
        }
    }

    #[test]
    fn band1_signs_follow_3dgs() {
        let mut y = [0.0; 16];
        basis(1, [0.0, 1.0, 0.0], &mut y);
        assert!((y[1] + C1).abs() < 1e-6);
        basis(1, [0.0, 0.0, 1.0], &mut y);
        assert!((y[2] - C1).abs() < 1e-6);
        basis(1, [1.0, 0.0, 0.0], &mut y);
        assert!((y[3] + C1).abs() < 1e-6);
    }

    #[test]
    fn dc_round_trip() {
        for v in [0.0f32, 0.25, 0.5, 1.0] {
            assert!((sh_to_rgb(rgb_to_sh(v)) - v).abs() < 1e-6);
        }
    }
}
