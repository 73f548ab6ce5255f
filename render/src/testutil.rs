//! Helpers shared by the rasteriser tests.

use glam::{DMat3, DVec3};

use crate::Camera;

/// A tiny deterministic generator (64-bit LCG, top bits), enough for test
/// scenes.
pub struct Lcg(pub u64);

impl Lcg {
    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [a, b), as f32.
    pub fn range(&mut self, a: f64, b: f64) -> f32 {
        (a + (b - a) * self.next_f64()) as f32
    }
}

/// `count` random SH coefficient triples: DC in ±0.8, higher bands in ±0.15.
pub fn random_sh(r: &mut Lcg, count: usize) -> Vec<[f32; 3]> {
    (0..count)
        .map(|k| {
            let a = if k == 0 { 0.8 } else { 0.15 };
            [r.range(-a, a), r.range(-a, a), r.range(-a, a)]
        })
        .collect()
}

/// Camera at the origin looking down +z, principal point at the centre.
pub fn test_camera(w: u32, h: u32, f: f64) -> Camera {
    Camera::pinhole(
        "test",
        w,
        h,
        f,
        f,
        w as f64 / 2.0,
        h as f64 / 2.0,
        DMat3::IDENTITY,
        DVec3::ZERO,
    )
}

/// Random weights in [−1, 1] for a linear loss over RGB and alpha.
pub fn linear_loss(pixels: usize, seed: u64) -> (Vec<[f32; 3]>, Vec<f32>) {
    let mut r = Lcg(seed);
    let wr = (0..pixels)
        .map(|_| [r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0)])
        .collect();
    let wa = (0..pixels).map(|_| r.range(-1.0, 1.0)).collect();
    (wr, wa)
}

/// Σ w·rgb + Σ v·alpha, accumulated in f64.
pub fn eval_linear(rgb: &[[f32; 3]], alpha: &[f32], wr: &[[f32; 3]], wa: &[f32]) -> f64 {
    let mut l = 0.0;
    for i in 0..rgb.len() {
        for k in 0..3 {
            l += rgb[i][k] as f64 * wr[i][k] as f64;
        }
        l += alpha[i] as f64 * wa[i] as f64;
    }
    l
}

/// Checks `analytic[k]` against the central difference
/// (f(k, +h) − f(k, −h)) / 2h for every k, on at least 99% of the entries
/// (every entry for groups under 100): relative error ≤ 2%, or, for entries
/// near zero, absolute error ≤ 3e-5 / h. The rasterisers blend in f32, so a
/// loss over a few thousand pixels carries a rounding noise of about 1e-5;
/// the difference quotient inherits 1e-5 / 2h of it, and the floor is three
/// times that with a margin.
pub fn check_gradient(name: &str, analytic: &[f64], h: f64, f: impl Fn(usize, f64) -> f64) {
    let scale = analytic.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0, "{name}: all-zero gradient");
    let mut bad = Vec::new();
    for (k, &a) in analytic.iter().enumerate() {
        let fd = (f(k, h) - f(k, -h)) / (2.0 * h);
        let err = (a - fd).abs();
        if err > 0.02 * fd.abs().max(a.abs()) && err > 3e-5 / h {
            bad.push((k, a, fd));
        }
    }
    let allowed = analytic.len() / 100;
    assert!(
        bad.len() <= allowed,
        "{name}: {} of {} entries off (scale {scale:.3e}): {:?}",
        bad.len(),
        analytic.len(),
        &bad[..bad.len().min(8)]
    );
}

/// Random weights in [−1, 1] for a linear loss over the expected depth and
/// the accumulated normal Σ w n.
pub fn aux_weights(pixels: usize, seed: u64) -> (Vec<f32>, Vec<[f32; 3]>) {
    let mut r = Lcg(seed);
    let wd = (0..pixels).map(|_| r.range(-1.0, 1.0)).collect();
    let wn = (0..pixels)
        .map(|_| [r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0)])
        .collect();
    (wd, wn)
}

/// Σ w·rgb + Σ v·alpha + Σ u·expected depth + Σ q·normal_sum, in f64.
pub fn eval_full(
    img: &crate::gaussian::RenderOutput,
    (wr, wa): (&[[f32; 3]], &[f32]),
    (wd, wn): (&[f32], &[[f32; 3]]),
) -> f64 {
    let mut l = eval_linear(&img.rgb, &img.alpha, wr, wa);
    for i in 0..img.rgb.len() {
        l += img.expected_depth[i] as f64 * wd[i] as f64;
        for (n, q) in img.normal_sum[i].iter().zip(wn[i]) {
            l += *n as f64 * q as f64;
        }
    }
    l
}
