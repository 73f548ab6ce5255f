//! Forward-mode automatic differentiation for the per-primitive projection
//! steps.
//!
//! The projection of a Gaussian (EWA covariance, conic, SH colour) or of a
//! triangle (edge lines, incenter, inradius) is written once, generic over
//! [`Real`]. The forward pass runs it with `f64`; the backward pass runs the
//! same code with [`Dual<N>`], whose N tangents are seeded with the primitive's
//! parameters, and gets the exact Jacobian of every projected quantity. The
//! per-pixel blending, where the time goes, is differentiated by hand.
//!
//! Branches (culls, clamps, the edge-orientation flip) compare the values
//! only, so a clamped quantity gets a zero derivative, as in the CUDA
//! reference.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// The operations the projection code needs.
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Mul<f64, Output = Self>
    + Add<f64, Output = Self>
{
    /// A constant (zero tangents).
    fn cst(v: f64) -> Self;
    /// The value.
    fn val(self) -> f64;
    fn sqrt(self) -> Self;
    fn ln(self) -> Self;
}

impl Real for f64 {
    #[inline]
    fn cst(v: f64) -> Self {
        v
    }
    #[inline]
    fn val(self) -> f64 {
        self
    }
    #[inline]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline]
    fn ln(self) -> Self {
        f64::ln(self)
    }
}

/// A value with N partial derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<const N: usize> {
    pub v: f64,
    pub d: [f64; N],
}

impl<const N: usize> Dual<N> {
    /// The k-th independent variable with value `v`.
    pub fn var(v: f64, k: usize) -> Self {
        let mut d = [0.0; N];
        d[k] = 1.0;
        Dual { v, d }
    }
}

impl<const N: usize> Add for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Dual {
            v: self.v + o.v,
            d: std::array::from_fn(|k| self.d[k] + o.d[k]),
        }
    }
}

impl<const N: usize> Sub for Dual<N> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Dual {
            v: self.v - o.v,
            d: std::array::from_fn(|k| self.d[k] - o.d[k]),
        }
    }
}

impl<const N: usize> Mul for Dual<N> {
    type Output = Self;
    #[inline]
    #[allow(clippy::suspicious_arithmetic_impl)] // the product rule
    fn mul(self, o: Self) -> Self {
        Dual {
            v: self.v * o.v,
            d: std::array::from_fn(|k| self.d[k] * o.v + o.d[k] * self.v),
        }
    }
}

impl<const N: usize> Div for Dual<N> {
    type Output = Self;
    #[inline]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.v;
        let q = self.v * inv;
        Dual {
            v: q,
            d: std::array::from_fn(|k| (self.d[k] - q * o.d[k]) * inv),
        }
    }
}

impl<const N: usize> Neg for Dual<N> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Dual {
            v: -self.v,
            d: self.d.map(|x| -x),
        }
    }
}

impl<const N: usize> Mul<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn mul(self, s: f64) -> Self {
        Dual {
            v: self.v * s,
            d: self.d.map(|x| x * s),
        }
    }
}

impl<const N: usize> Add<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(self, s: f64) -> Self {
        Dual {
            v: self.v + s,
            d: self.d,
        }
    }
}

impl<const N: usize> Real for Dual<N> {
    #[inline]
    fn cst(v: f64) -> Self {
        Dual { v, d: [0.0; N] }
    }
    #[inline]
    fn val(self) -> f64 {
        self.v
    }
    #[inline]
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        let s = if r > 0.0 { 0.5 / r } else { 0.0 };
        Dual {
            v: r,
            d: self.d.map(|x| x * s),
        }
    }
    #[inline]
    fn ln(self) -> Self {
        let inv = 1.0 / self.v;
        Dual {
            v: self.v.ln(),
            d: self.d.map(|x| x * inv),
        }
    }
}

/// 3-vector helpers over [`Real`].
pub fn dot3<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product.
pub fn cross3<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// SH basis values Y_k(dir) for k < (degree+1)², generic (same constants and
/// signs as [`crate::sh::basis`]); `dir` is normalised here.
pub fn sh_basis<T: Real>(degree: usize, dir: [T; 3]) -> [T; 16] {
    use crate::sh::{C0, C1, C2, C3};
    let z0 = T::cst(0.0);
    let mut out = [z0; 16];
    out[0] = T::cst(C0 as f64);
    if degree == 0 {
        return out;
    }
    let n2 = dot3(dir, dir).val();
    if !(n2 > 0.0 && n2.is_finite()) {
        return out;
    }
    let n = dot3(dir, dir).sqrt();
    let (x, y, z) = (dir[0] / n, dir[1] / n, dir[2] / n);
    let (c1, c2, c3) = (C1 as f64, C2.map(|c| c as f64), C3.map(|c| c as f64));
    out[1] = y * -c1;
    out[2] = z * c1;
    out[3] = x * -c1;
    if degree == 1 {
        return out;
    }
    let (xx, yy, zz) = (x * x, y * y, z * z);
    let (xy, yz, xz) = (x * y, y * z, x * z);
    out[4] = xy * c2[0];
    out[5] = yz * c2[1];
    out[6] = (zz * 2.0 - xx - yy) * c2[2];
    out[7] = xz * c2[3];
    out[8] = (xx - yy) * c2[4];
    if degree == 2 {
        return out;
    }
    out[9] = y * (xx * 3.0 - yy) * c3[0];
    out[10] = xy * z * c3[1];
    out[11] = y * (zz * 4.0 - xx - yy) * c3[2];
    out[12] = z * (zz * 2.0 - xx * 3.0 - yy * 3.0) * c3[3];
    out[13] = x * (zz * 4.0 - xx - yy) * c3[4];
    out[14] = z * (xx - yy) * c3[5];
    out[15] = x * (xx - yy * 3.0) * c3[6];
    out
}

/// SH colour + 0.5 (unclamped) of a primitive at `point`, seen from the
/// camera centre `eye` (direction point − eye).
pub fn sh_rgb<T: Real>(point: [T; 3], eye: [f64; 3], sh: &[[f32; 3]], sh_degree: usize) -> [T; 3] {
    let dir = [point[0] + -eye[0], point[1] + -eye[1], point[2] + -eye[2]];
    let basis = sh_basis(sh_degree, dir);
    let n = crate::sh::coeff_count(sh_degree).min(sh.len());
    std::array::from_fn(|ch| {
        let mut acc = basis[0] * sh[0][ch] as f64;
        for k in 1..n {
            acc = acc + basis[k] * sh[k][ch] as f64;
        }
        acc + 0.5
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// d/dx of x²·sqrt(x)/ln(x) at x = 2 against the closed form.
    #[test]
    fn dual_matches_closed_form() {
        let x = Dual::<1>::var(2.0, 0);
        let f = x * x * x.sqrt() / x.ln();
        let v = 2f64;
        let want = (2.5 * v.powf(1.5) * v.ln() - v.powf(1.5)) / (v.ln() * v.ln());
        assert!((f.d[0] - want).abs() < 1e-12);
    }

    /// The generic basis equals the f32 one.
    #[test]
    fn generic_basis_matches() {
        let dir = [0.3f64, -0.5, 0.8];
        let g = sh_basis(3, dir);
        let mut f = [0.0f32; 16];
        crate::sh::basis(3, dir.map(|v| v as f32), &mut f);
        for k in 0..16 {
            assert!((g[k] - f[k] as f64).abs() < 1e-6, "{k}");
        }
    }
}
