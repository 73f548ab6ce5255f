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

use glam::{DQuat, DVec3};
use splatkit_render::surfel::{SurfelSettings, Surfels2, rasterize};
use splatkit_render::surfel_grad::{SurfelAuxGrads, backward_state};

#[path = "support/timing_scene.rs"]
mod timing_scene;

fn main() {
    let (w, h, iters) = timing_scene::sizes("surfel_timing", 5);
    let n = 200_000;
    let mut sf = Surfels2 {
        sh_degree: 3,
        ..Default::default()
    };
    let mut rnd = timing_scene::Rng::new();
    let (points, spacing) = timing_scene::fibonacci_sphere(n);
    for p in points {
        sf.means.push(p.as_vec3().to_array());
        sf.scales.push([spacing; 2]);
        let q = DQuat::from_rotation_arc(DVec3::Z, p);
        sf.rotations
            .push([q.w as f32, q.x as f32, q.y as f32, q.z as f32]);
        sf.opacities.push(0.1);
        sf.sh.extend(rnd.sh16());
    }
    let cam = timing_scene::camera(w, h);
    let s = SurfelSettings::default();
    let d_rgb = rnd.rgb(w * h);
    let one: Vec<f32> = (0..w * h).map(|_| rnd.next() - 0.5).collect();
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
