//! `splat2points` (level-set sampling) at real scale on a generated scene:
//! a torus (R 1, r 0.35) covered with 1000 × 350 = 350,000 flat Gaussians
//! plus 10,000 floaters, 16 orbit views at 1280×720 (8 above, 8 below), level
//! 0.3, `--max-points` 4,000,000 (250,001 per view, so 500,002 rays per
//! view). Reports the total time, the points kept and the time per view.
//! `SPLATKIT_BENCH_SCALE` scales the Gaussian grid. Run:
//! `cargo bench --bench splat2points`.

use std::time::Instant;

use glam::DVec3;
use splatkit::geom::levelset::{LevelsetOptions, sample_levelset};
use splatkit::geom::synthetic::Torus;
use splatkit::ops::render::orbit_cameras;

fn main() {
    let scale: f64 = std::env::var("SPLATKIT_BENCH_SCALE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1.0);
    let t = Torus {
        major: 1.0,
        minor: 0.35,
    };
    let (nu, nv) = (
        (1000.0 * scale.sqrt()) as usize,
        (350.0 * scale.sqrt()) as usize,
    );
    let g = t.gaussians(nu, nv, 0.002, 10_000, 1).to_raster();
    let ring = |e: f64| {
        orbit_cameras(
            &t.mesh(64, 24).vertices,
            8,
            1280,
            720,
            50.0,
            e,
            Some(3.6),
            DVec3::Y,
        )
        .expect("cameras")
    };
    let mut cams = ring(35.0);
    cams.extend(ring(-35.0));
    let opts = LevelsetOptions {
        max_points: 4_000_000,
        ..Default::default()
    };
    let t0 = Instant::now();
    let pts = sample_levelset(&g, &cams, &opts, |_| ()).expect("sampling");
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "{} Gaussians, {} views 1280x720, {} threads: {} points in {secs:.2} s ({:.2} s per view, {:.0} k points/s)",
        g.len(),
        cams.len(),
        rayon::current_num_threads(),
        pts.positions.len(),
        secs / cams.len() as f64,
        pts.positions.len() as f64 / secs / 1e3
    );
}
