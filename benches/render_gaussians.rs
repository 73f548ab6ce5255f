//! Forward Gaussian rasteriser at real scale (issue #5 targets: 1M Gaussians
//! at 1280×720 in ≤ 1 s on the 2-core machine).
//!
//! Scene, generated here: N Gaussians (default 1M; `SPLATKIT_BENCH_SCALE`
//! scales it) with means uniform in a 4×4×4 box in front of the camera,
//! log-uniform scales 0.005–0.05, random rotations, opacities 0.1–1, SH
//! degree 3 with random coefficients; a 1280×720 pinhole camera, f = 1000.
//! Reports the wall time of `render` (best of 3) and the mean number of
//! contributions per pixel. Run: `cargo bench --bench render_gaussians`.

use std::time::Instant;

use glam::{DMat3, DVec3};
use rand::{RngExt, SeedableRng};
use splatkit_render::Camera;
use splatkit_render::gaussian::{Gaussians3, RasterSettings, render};

fn main() {
    let scale: f64 = std::env::var("SPLATKIT_BENCH_SCALE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1.0);
    let n = (1_000_000.0 * scale) as usize;
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
    let mut g = Gaussians3 {
        sh_degree: 3,
        ..Default::default()
    };
    for _ in 0..n {
        g.means.push([
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(3.0..7.0),
        ]);
        let sc: [f32; 3] = std::array::from_fn(|_| 0.005 * 10f32.powf(rng.random::<f32>()));
        g.scales.push(sc);
        g.rotations.push([
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ]);
        g.opacities.push(rng.random_range(0.1..1.0));
        for _ in 0..16 {
            g.sh.push([
                rng.random_range(-0.5..0.5),
                rng.random_range(-0.5..0.5),
                rng.random_range(-0.5..0.5),
            ]);
        }
    }
    let cam = Camera::pinhole(
        "bench",
        1280,
        720,
        1000.0,
        1000.0,
        640.0,
        360.0,
        DMat3::IDENTITY,
        DVec3::ZERO,
    );
    let s = RasterSettings::default();
    let mut best = f64::INFINITY;
    let mut contributions = 0.0;
    for _ in 0..3 {
        let t = Instant::now();
        let img = render(&g, &cam, &s);
        best = best.min(t.elapsed().as_secs_f64());
        contributions = img.count.iter().map(|&c| c as f64).sum::<f64>() / img.count.len() as f64;
    }
    println!(
        "{n} Gaussians, 1280x720, {} threads: forward {best:.3} s (best of 3), {contributions:.1} contributions per pixel",
        rayon::current_num_threads()
    );
}
