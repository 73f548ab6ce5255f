//! `splat2points` (level-set sampling) at the scale of issue 6 on a
//! generated scene: a torus (R 1, r 0.35) covered with 1690 × 592 =
//! 1,000,480 flat Gaussians plus 10,000 floaters, 100 orbit views of
//! 1000×1000 pixels (50 above at 35°, 50 below at −35°), level 0.3,
//! `--max-points` 1,000,000 (10,001 per view, so 20,002 rays per view).
//! Reports the total time, the points kept and the time per view.
//! Environment: `SPLATKIT_BENCH_SCALE` scales the Gaussian count,
//! `SPLATKIT_BENCH_VIEWS` sets the number of views (memory must not grow
//! with it), `SPLATKIT_BENCH_POINTS` the point budget. Run:
//! `cargo bench --bench splat2points` (peak memory: run the bench binary
//! under `/usr/bin/time -v`, see docs/BENCHMARKS.md).

use std::time::Instant;

use glam::DVec3;
use splatkit::geom::scenes::orbit::{OrbitRing, orbit_cameras};
use splatkit::geom::scenes::synthetic::Torus;
use splatkit::geom::surface_points::levelset::{LevelsetOptions, sample_levelset};

fn main() {
    let env = |k: &str, d: f64| -> f64 {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let scale = env("SPLATKIT_BENCH_SCALE", 1.0);
    let views = env("SPLATKIT_BENCH_VIEWS", 100.0) as usize;
    let budget = env("SPLATKIT_BENCH_POINTS", 1e6) as usize;
    let t = Torus {
        major: 1.0,
        minor: 0.35,
    };
    let (nu, nv) = (
        (1690.0 * scale.sqrt()) as usize,
        (592.0 * scale.sqrt()) as usize,
    );
    let g = t.gaussians(nu, nv, 0.002, 10_000, 1).to_raster();
    let ring = |n: usize, e: f64| {
        orbit_cameras(
            &t.mesh(64, 24).vertices,
            &OrbitRing {
                views: n,
                width: 1000,
                height: 1000,
                fov_deg: 50.0,
                elevation_deg: e,
                radius: Some(3.6),
                up: DVec3::Y,
            },
        )
        .expect("cameras")
    };
    let mut cams = ring(views.div_ceil(2), 35.0);
    cams.extend(ring(views / 2, -35.0));
    let opts = LevelsetOptions {
        max_points: budget,
        ..Default::default()
    };
    let t0 = Instant::now();
    let pts = sample_levelset(&g, &cams, &opts, |_| ()).expect("sampling");
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "{} Gaussians, {} views 1000x1000, {} threads: {} points in {secs:.2} s ({:.2} s per view, {:.0} k points/s)",
        g.len(),
        cams.len(),
        rayon::current_num_threads(),
        pts.positions.len(),
        secs / cams.len() as f64,
        pts.positions.len() as f64 / secs / 1e3
    );
}
