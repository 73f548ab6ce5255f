//! Times the Gaussian forward and backward passes alone on a scene shaped
//! like the train bench's worst case (200,000 Gaussians of opacity 0.1 on a
//! unit sphere, SH degree 3, one camera at distance 3 with a 50° field of
//! view; isotropic scales of the mean point spacing instead of the bench's
//! 3-NN initialisation), so rasteriser changes can be measured without
//! building the whole tool. Best time of ITERS runs; the checksum of the last
//! run's image and mean gradients shows whether a change altered results.
//!
//! `RAYON_NUM_THREADS=2 cargo run --release -p splatkit-render --example blend_timing -- [W H ITERS]`
use std::time::Instant;

use glam::{DMat3, DVec3};
use splatkit_render::Camera;
use splatkit_render::gaussian::{Gaussians3, RasterSettings, rasterize};
use splatkit_render::gaussian_grad::{AuxGrads, backward_aux};

fn main() {
    let a: Vec<usize> = std::env::args()
        .skip(1)
        .map(|s| {
            s.parse()
                .unwrap_or_else(|_| panic!("usage: blend_timing [W H ITERS]; {s:?} is not a count"))
        })
        .collect();
    let (w, h, iters) = (
        *a.first().unwrap_or(&400),
        *a.get(1).unwrap_or(&300),
        *a.get(2).unwrap_or(&10),
    );
    assert!(
        w > 0 && h > 0 && iters > 0,
        "W, H and ITERS must be positive"
    );
    let n = 200_000;
    let mut g = Gaussians3 {
        sh_degree: 3,
        ..Default::default()
    };
    // Fibonacci sphere; spacing ~ sqrt(4π/n)
    let spacing = (4.0 * std::f64::consts::PI / n as f64).sqrt() as f32;
    let mut state = 0x9e3779b97f4a7c15u64;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32) / (1u64 << 24) as f32
    };
    for i in 0..n {
        let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - y * y).sqrt();
        let th = i as f64 * 2.399_963_229_728_653;
        g.means
            .push([(r * th.cos()) as f32, y as f32, (r * th.sin()) as f32]);
        g.scales.push([spacing; 3]);
        g.rotations.push([1.0, 0.0, 0.0, 0.0]);
        g.opacities.push(0.1);
        for k in 0..16 {
            let s = if k == 0 { 1.0 } else { 0.1 };
            g.sh.push([s * (rnd() - 0.5), s * (rnd() - 0.5), s * (rnd() - 0.5)]);
        }
    }
    let f = (w as f64 / 2.0) / (25f64.to_radians()).tan();
    let center = DVec3::new(0.3, -0.4, -3.0).normalize() * 3.0;
    let fwd = (-center).normalize();
    let right = fwd.cross(DVec3::Y).normalize();
    let down = fwd.cross(right);
    let (rot, t) = Camera::pose_from_c2w(DMat3::from_cols(right, down, fwd), center);
    let cam = Camera::pinhole(
        "bench",
        w as u32,
        h as u32,
        f,
        f,
        w as f64 / 2.0,
        h as f64 / 2.0,
        rot,
        t,
    );
    let s = RasterSettings::default();
    let d_rgb: Vec<[f32; 3]> = (0..w * h)
        .map(|_| [rnd() - 0.5, rnd() - 0.5, rnd() - 0.5])
        .collect();
    let (mut tf, mut tb) = (f64::MAX, f64::MAX);
    let mut check = 0.0f64;
    for _ in 0..iters {
        let t0 = Instant::now();
        let (out, st) = rasterize(&g, &cam, &s);
        let t1 = Instant::now();
        let gr = backward_aux(&g, &cam, &s, &st, &d_rgb, &AuxGrads::default());
        let t2 = Instant::now();
        tf = tf.min((t1 - t0).as_secs_f64());
        tb = tb.min((t2 - t1).as_secs_f64());
        check = out.rgb.iter().map(|c| c[0] as f64).sum::<f64>()
            + gr.means.iter().map(|m| m[0] as f64).sum::<f64>();
    }
    println!(
        "{w}x{h}: forward {:.1} ms, backward {:.1} ms (best of {iters}); checksum {check:.6e}",
        tf * 1e3,
        tb * 1e3
    );
}
