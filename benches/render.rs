//! Rasterisers at real scale (issue #5 targets: 1M Gaussians at 1280×720,
//! forward ≤ 1 s and forward+backward ≤ 3× forward on the 2-core machine;
//! 1M triangles measured).
//!
//! Scene, generated here: N Gaussians (default 1M; `SPLATKIT_BENCH_SCALE`
//! scales it) with means uniform in a 4×4×4 box in front of the camera,
//! log-uniform scales 0.005–0.05, random rotations, opacities 0.1–1, SH
//! degree 3 with random coefficients; a 1280×720 pinhole camera, f = 1000.
//! Reports the wall time of the forward pass, of forward + backward (with a
//! random per-pixel RGB gradient, as a loss would give), best of 3, and the
//! mean number of contributions per pixel. Then the same scene as 1M 2DGS
//! surfels (the first two scales), forward and forward + backward. Then 1M triangles (centres as the
//! Gaussians, circumradius 0.01–0.1, σ 0.3–2, opacity 0.1–1), forward and
//! forward + backward. Then, when `../shared/data` is present, the real
//! 152,746-Gaussian biker scene (SH 0) from an orbit camera at 1280×720.
//! Run: `cargo bench --bench render`.

use std::time::Instant;

use glam::{DMat3, DVec3};
use rand::{RngExt, SeedableRng};
use splatkit_render::Camera;
use splatkit_render::gaussian::{Gaussians3, RasterSettings, rasterize};
use splatkit_render::surfel::{self, SurfelSettings, Surfels2};
use splatkit_render::triangle::{self, Triangles3};
use splatkit_render::{gaussian_grad, surfel_grad, triangle_grad};

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
    let d_rgb: Vec<[f32; 3]> = (0..1280 * 720)
        .map(|_| std::array::from_fn(|_| rng.random_range(-1e-6..1e-6)))
        .collect();
    let threads = rayon::current_num_threads();
    let (mut fwd, mut both, mut contributions) = (f64::INFINITY, f64::INFINITY, 0.0);
    for _ in 0..3 {
        let t = Instant::now();
        let (img, st) = rasterize(&g, &cam, &s);
        fwd = fwd.min(t.elapsed().as_secs_f64());
        let grads = gaussian_grad::backward(&g, &cam, &s, &st, &d_rgb, None);
        both = both.min(t.elapsed().as_secs_f64());
        std::hint::black_box(grads);
        contributions = img.count.iter().map(|&c| c as f64).sum::<f64>() / img.count.len() as f64;
    }
    println!(
        "{n} Gaussians, 1280x720, {threads} threads: forward {fwd:.3} s, forward+backward {both:.3} s ({:.2}x), {contributions:.1} contributions per pixel",
        both / fwd
    );
    // the same scene as 2DGS surfels: the first two scales, same rotations
    let sf = Surfels2 {
        means: g.means.clone(),
        scales: g.scales.iter().map(|s| [s[0], s[1]]).collect(),
        rotations: g.rotations.clone(),
        opacities: g.opacities.clone(),
        sh: g.sh.clone(),
        sh_degree: 3,
    };
    let ss = SurfelSettings::default();
    let (mut fwd, mut both, mut contributions) = (f64::INFINITY, f64::INFINITY, 0.0);
    for _ in 0..3 {
        let t = Instant::now();
        let (img, st) = surfel::rasterize(&sf, &cam, &ss);
        fwd = fwd.min(t.elapsed().as_secs_f64());
        let grads = surfel_grad::backward_state(&sf, &cam, &ss, &st, &d_rgb, &Default::default());
        both = both.min(t.elapsed().as_secs_f64());
        std::hint::black_box(grads);
        contributions = img.count.iter().map(|&c| c as f64).sum::<f64>() / img.count.len() as f64;
    }
    drop(sf);
    println!(
        "{n} surfels, 1280x720, {threads} threads: forward {fwd:.3} s, forward+backward {both:.3} s ({:.2}x), {contributions:.1} contributions per pixel",
        both / fwd
    );
    let mut t3 = Triangles3 {
        sh_degree: 3,
        sh: g.sh,
        ..Default::default()
    };
    for i in 0..n {
        let c = g.means[i];
        let r = 0.01 * 10f32.powf(rng.random::<f32>());
        let a0: f32 = rng.random_range(0.0..std::f32::consts::TAU);
        let tilt: f32 = rng.random_range(-0.5..0.5);
        t3.vertices.push(std::array::from_fn(|k| {
            let a = a0 + k as f32 * 2.1;
            [
                c[0] + r * a.cos(),
                c[1] + r * a.sin(),
                c[2] + tilt * r * a.sin(),
            ]
        }));
        t3.sigmas.push(rng.random_range(0.3..2.0));
        t3.opacities.push(rng.random_range(0.1..1.0));
    }
    let (mut fwd, mut both, mut contributions) = (f64::INFINITY, f64::INFINITY, 0.0);
    for _ in 0..3 {
        let t = Instant::now();
        let (img, st) = triangle::rasterize(&t3, &cam, &s);
        fwd = fwd.min(t.elapsed().as_secs_f64());
        let grads = triangle_grad::backward(&t3, &cam, &s, &st, &d_rgb, None);
        both = both.min(t.elapsed().as_secs_f64());
        std::hint::black_box(grads);
        contributions = img.count.iter().map(|&c| c as f64).sum::<f64>() / img.count.len() as f64;
    }
    println!(
        "{n} triangles, 1280x720, {threads} threads: forward {fwd:.3} s, forward+backward {both:.3} s ({:.2}x), {contributions:.1} contributions per pixel",
        both / fwd
    );
    // the real biker scene
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    let path = root.join("3dgs-playcanvas-biker/biker.decoded_sh0.ply");
    let Ok(bytes) = std::fs::read(&path) else {
        println!("biker: skipped ({} is absent)", path.display());
        return;
    };
    let g = splatkit::io::ply::gaussians::parse_gaussians("biker", &bytes)
        .expect("biker parses")
        .to_raster();
    let cams = splatkit::geom::scenes::orbit::orbit_cameras(
        &g.means,
        &splatkit::geom::scenes::orbit::OrbitRing {
            views: 8,
            width: 1280,
            height: 720,
            fov_deg: 50.0,
            elevation_deg: 15.0,
            radius: None,
            up: DVec3::new(0.0, -1.0, 0.0),
        },
    )
    .expect("orbit");
    let (mut fwd, mut both, mut contributions) = (0.0, 0.0, 0.0);
    for cam in &cams {
        let t = Instant::now();
        let (img, st) = rasterize(&g, cam, &s);
        fwd += t.elapsed().as_secs_f64();
        let grads = gaussian_grad::backward(&g, cam, &s, &st, &d_rgb, None);
        both += t.elapsed().as_secs_f64();
        std::hint::black_box(grads);
        contributions += img.count.iter().map(|&c| c as f64).sum::<f64>() / img.count.len() as f64;
    }
    let k = cams.len() as f64;
    println!(
        "biker ({} Gaussians), 1280x720, {threads} threads, mean of {} orbit views: forward {:.3} s, forward+backward {:.3} s ({:.2}x), {:.1} contributions per pixel",
        g.len(),
        cams.len(),
        fwd / k,
        both / k,
        both / fwd,
        contributions / k
    );
}
