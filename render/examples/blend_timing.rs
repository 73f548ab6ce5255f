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

use splatkit_render::gaussian::{Gaussians3, RasterSettings, rasterize};
use splatkit_render::gaussian_grad::{AuxGrads, backward_aux};

#[path = "support/timing_scene.rs"]
mod timing_scene;

fn main() {
    let (w, h, iters) = timing_scene::sizes("blend_timing", 10);
    let n = 200_000;
    let mut g = Gaussians3 {
        sh_degree: 3,
        ..Default::default()
    };
    let mut rnd = timing_scene::Rng::new();
    let (points, spacing) = timing_scene::fibonacci_sphere(n);
    for p in points {
        g.means.push(p.as_vec3().to_array());
        g.scales.push([spacing; 3]);
        g.rotations.push([1.0, 0.0, 0.0, 0.0]);
        g.opacities.push(0.1);
        g.sh.extend(rnd.sh16());
    }
    let cam = timing_scene::camera(w, h);
    let s = RasterSettings::default();
    let d_rgb = rnd.rgb(w * h);
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
