//! Times the surfel (2DGS) forward and backward passes alone, on the scene
//! of `blend_timing`: 200,000 surfels on a unit sphere, each tangent to it
//! (normal = the radial direction), both scales the mean point spacing,
//! opacity 0.1, SH degree 3; one camera at distance 3 with a 50° field of
//! view. The backward pass takes an RGB gradient and every auxiliary map's
//! (alpha, expected and median depth, normal, distortion), as 2DGS's
//! training loss does. Best time of ITERS runs; the checksum of the last
//! run's image and mean gradients shows whether a change altered results.
//!
//! `RAYON_NUM_THREADS=2 cargo run --release -p splatkit-render --example surfel_timing -- [W H ITERS]`
use std::time::Instant;

use glam::{DMat3, DQuat, DVec3};
use splatkit_render::Camera;
use splatkit_render::surfel::{SurfelSettings, Surfels2, rasterize};
use splatkit_render::surfel_grad::{SurfelAuxGrads, backward_state};

fn main() {
    let a: Vec<usize> = std::env::args()
        .skip(1)
        .map(|s| {
            s.parse().unwrap_or_else(|_| {
                panic!("usage: surfel_timing [W H ITERS]; {s:?} is not a count")
            })
        })
        .collect();
    let (w, h, iters) = (
        *a.first().unwrap_or(&400),
        *a.get(1).unwrap_or(&300),
        *a.get(2).unwrap_or(&5),
    );
    assert!(
        w > 0 && h > 0 && iters > 0,
        "W, H and ITERS must be positive"
    );
    let n = 200_000;
    let mut sf = Surfels2 {
        sh_degree: 3,
        ..Default::default()
    };
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
        let p = DVec3::new(r * th.cos(), y, r * th.sin());
        sf.means.push(p.as_vec3().to_array());
        sf.scales.push([spacing; 2]);
        let q = DQuat::from_rotation_arc(DVec3::Z, p);
        sf.rotations
            .push([q.w as f32, q.x as f32, q.y as f32, q.z as f32]);
        sf.opacities.push(0.1);
        for k in 0..16 {
            let s = if k == 0 { 1.0 } else { 0.1 };
            sf.sh
                .push([s * (rnd() - 0.5), s * (rnd() - 0.5), s * (rnd() - 0.5)]);
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
    let s = SurfelSettings::default();
    let d_rgb: Vec<[f32; 3]> = (0..w * h)
        .map(|_| [rnd() - 0.5, rnd() - 0.5, rnd() - 0.5])
        .collect();
    let one: Vec<f32> = (0..w * h).map(|_| rnd() - 0.5).collect();
    let aux = SurfelAuxGrads {
        alpha: Some(&one),
        depth: Some(&one),
        median_depth: Some(&one),
        normal: Some(&d_rgb),
        distortion: Some(&one),
    };
    let (mut tf, mut tb) = (f64::MAX, f64::MAX);
    let (mut check, mut contributions) = (0.0f64, 0.0f64);
    for _ in 0..iters {
        let t0 = Instant::now();
        let (out, st) = rasterize(&sf, &cam, &s);
        let t1 = Instant::now();
        let gr = backward_state(&sf, &cam, &s, &st, &d_rgb, &aux);
        let t2 = Instant::now();
        tf = tf.min((t1 - t0).as_secs_f64());
        tb = tb.min((t2 - t1).as_secs_f64());
        check = out.rgb.iter().map(|c| c[0] as f64).sum::<f64>()
            + gr.means.iter().map(|m| m[0] as f64).sum::<f64>();
        contributions = out.count.iter().map(|&c| c as f64).sum::<f64>() / out.count.len() as f64;
    }
    println!(
        "{w}x{h}, {n} surfels: forward {:.1} ms, backward {:.1} ms (best of {iters}), {contributions:.1} contributions per pixel; checksum {check:.6e}",
        tf * 1e3,
        tb * 1e3
    );
}
