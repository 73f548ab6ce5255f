//! The scene the timing examples share (`blend_timing`, `surfel_timing`):
//! command-line sizes, a seeded generator, N points on a Fibonacci sphere of
//! radius 1 with their mean spacing, random SH and one camera at distance 3
//! with a 50° horizontal field of view looking at the origin.

use glam::{DMat3, DVec3};
use splatkit_render::Camera;

/// `[W H ITERS]` from the command line (defaults 400, 300, `iters`).
pub fn sizes(example: &str, iters: usize) -> (usize, usize, usize) {
    let a: Vec<usize> = std::env::args()
        .skip(1)
        .map(|s| {
            s.parse()
                .unwrap_or_else(|_| panic!("usage: {example} [W H ITERS]; {s:?} is not a count"))
        })
        .collect();
    let (w, h, iters) = (
        *a.first().unwrap_or(&400),
        *a.get(1).unwrap_or(&300),
        *a.get(2).unwrap_or(&iters),
    );
    assert!(
        w > 0 && h > 0 && iters > 0,
        "W, H and ITERS must be positive"
    );
    (w, h, iters)
}

/// A 64-bit LCG; `next` gives [0, 1) with 24 bits.
pub struct Rng(u64);

impl Rng {
    pub fn new() -> Self {
        Rng(0x9e3779b97f4a7c15)
    }

    pub fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }

    /// 16 SH coefficients (degree 3): DC in ±0.5, the rest in ±0.05.
    pub fn sh16(&mut self) -> [[f32; 3]; 16] {
        std::array::from_fn(|k| {
            let s = if k == 0 { 1.0 } else { 0.1 };
            [
                s * (self.next() - 0.5),
                s * (self.next() - 0.5),
                s * (self.next() - 0.5),
            ]
        })
    }

    /// `n` RGB values in ±0.5 (a gradient image).
    pub fn rgb(&mut self, n: usize) -> Vec<[f32; 3]> {
        (0..n)
            .map(|_| [self.next() - 0.5, self.next() - 0.5, self.next() - 0.5])
            .collect()
    }
}

/// `n` points on the unit sphere (Fibonacci lattice) and their mean spacing
/// √(4π/n).
pub fn fibonacci_sphere(n: usize) -> (Vec<DVec3>, f32) {
    let points = (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - y * y).sqrt();
            let th = i as f64 * 2.399_963_229_728_653;
            DVec3::new(r * th.cos(), y, r * th.sin())
        })
        .collect();
    (
        points,
        (4.0 * std::f64::consts::PI / n as f64).sqrt() as f32,
    )
}

/// A W×H pinhole camera at distance 3 looking at the origin, 50° across.
pub fn camera(w: usize, h: usize) -> Camera {
    let f = (w as f64 / 2.0) / (25f64.to_radians()).tan();
    let center = DVec3::new(0.3, -0.4, -3.0).normalize() * 3.0;
    let fwd = (-center).normalize();
    let right = fwd.cross(DVec3::Y).normalize();
    let down = fwd.cross(right);
    let (rot, t) = Camera::pose_from_c2w(DMat3::from_cols(right, down, fwd), center);
    Camera::pinhole(
        "bench",
        w as u32,
        h as u32,
        f,
        f,
        w as f64 / 2.0,
        h as f64 / 2.0,
        rot,
        t,
    )
}
