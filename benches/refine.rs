//! One refinement iteration at real scale (issue #13 target: 1M bound
//! Gaussians at 1 MP on 2 threads in ≤ 3.5 s).
//!
//! Scene, generated here: a UV sphere of radius 1 with 500 rings (999,000
//! faces, 499,002 vertices), 1 Gaussian per face (SuGaR's high-poly
//! setting), coloured by a smooth pattern; SH degree 3 with small random
//! higher bands and the active degree 3 (past SuGaR's warm-up); 24 cameras
//! at distance 3 of 1024×1024 (1.05 MP), f = 900. The "photos" are renders
//! of the model with its colours shifted, so the loss has a gradient
//! everywhere the sphere is seen. One iteration = materialise the bound
//! Gaussians, render, 0.8·L1 + 0.2·D-SSIM, rasteriser backward, the chain
//! through the binding, normal consistency, six Adam steps (what
//! `Refiner::step` does). Reports the best of 3 iterations (after a warm-up
//! iteration at the same degree), the stage profile of one iteration, and
//! peak memory. `SPLATKIT_BENCH_SCALE` scales the face count.
//! Run: `cargo bench --bench refine`.

mod common;

use std::time::Instant;

use common::peak_mb;
use splatkit::geom::binding::grad::{NormalConsistency, backward};
use splatkit::geom::binding::{BindOptions, bind, to_raster};
use splatkit::model::View;
use splatkit::testing::{cameras_around, uv_sphere};
use splatkit::train::photometric::loss_and_grad;
use splatkit::train::refine::{LearningRates, RefineParams, Refiner, spatial_lr_scale};
use splatkit::train::trainer::Trainer;
use splatkit_render::gaussian::{RasterSettings, rasterize, render};
use splatkit_render::gaussian_grad;

fn main() {
    let scale: f64 = std::env::var("SPLATKIT_BENCH_SCALE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1.0);
    let rings = ((500.0 * scale.sqrt()) as usize).max(4);
    let mut mesh = uv_sphere(rings, 1.0);
    mesh.vertex_colors = Some(
        mesh.vertices
            .iter()
            .map(|v| {
                [
                    (127.0 * (1.0 + (3.0 * v[0]).sin())) as u8,
                    (127.0 * (1.0 + (2.0 * v[1]).cos())) as u8,
                    (127.0 * (1.0 + v[2])) as u8,
                    255,
                ]
            })
            .collect(),
    );
    let t = Instant::now();
    let mut b = bind(
        &mesh,
        &BindOptions {
            per_face: 1,
            thickness: 3.3e-6,
            sh_degree: 3,
        },
        None,
    )
    .expect("bind");
    for (i, x) in b.sh_rest.iter_mut().enumerate() {
        *x = 0.02 * ((i as f32) * 0.618).sin();
    }
    println!(
        "scene: {} faces, {} vertices, {} bound Gaussians (bind {:.2} s)",
        mesh.faces.len(),
        mesh.vertices.len(),
        b.len(),
        t.elapsed().as_secs_f64()
    );
    let cams = cameras_around(24, 3.0, 1024, 900.0);
    let mut target = b.clone();
    for dc in &mut target.sh_dc {
        dc[0] += 0.3;
    }
    let gt = to_raster(&target, 3);
    let views: Vec<View> = cams
        .iter()
        .take(4)
        .map(|c| View {
            camera: c.clone(),
            image: render(&gt, c, &RasterSettings::default()).rgb,
            mask: None,
            alpha: None,
            source: c.name.clone(),
        })
        .collect();
    drop(gt);
    let params = RefineParams {
        background: [0.0; 3],
        normal_consistency: 0.1,
        sh_warmup: 0,
        lr: LearningRates::default(),
        spatial_lr_scale: spatial_lr_scale(3.3, b.len()),
        seed: 0,
    };
    // stage profile of one iteration (the same calls as Refiner::step)
    let view = &views[0];
    let s = RasterSettings::default();
    let mut stage = Vec::new();
    let t = Instant::now();
    let g3 = to_raster(&b, 3);
    stage.push(("materialise", t.elapsed().as_secs_f64()));
    let t = Instant::now();
    let (img, state) = rasterize(&g3, &view.camera, &s);
    stage.push(("render", t.elapsed().as_secs_f64()));
    let t = Instant::now();
    let (_, d_rgb) = loss_and_grad(&img.rgb, view);
    stage.push(("loss (L1 + SSIM)", t.elapsed().as_secs_f64()));
    let t = Instant::now();
    let gg = gaussian_grad::backward(&g3, &view.camera, &s, &state, &d_rgb, None);
    stage.push(("rasteriser backward", t.elapsed().as_secs_f64()));
    let t = Instant::now();
    let mut bg = backward(&b, &gg, 3);
    stage.push(("binding chain", t.elapsed().as_secs_f64()));
    let t = Instant::now();
    let nc = NormalConsistency::new(&b.mesh.faces);
    let nc_build = t.elapsed().as_secs_f64();
    let t = Instant::now();
    nc.eval(&b.mesh.vertices, 0.1, Some(&mut bg.vertices));
    stage.push(("normal consistency", t.elapsed().as_secs_f64()));
    drop((g3, img, state, gg, bg));
    b.sh_dc.iter_mut().for_each(|d| d[1] += 0.0);
    let mut r = Refiner::new(b, params);
    let train: Vec<usize> = (0..views.len()).collect();
    r.step(&views, &train);
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        r.step(&views, &train);
        best = best.min(t.elapsed().as_secs_f64());
    }
    let listed: f64 = stage.iter().map(|s| s.1).sum();
    println!(
        "one refinement iteration at {}x{} on {} threads: best of 3 {:.3} s",
        cams[0].width,
        cams[0].height,
        rayon::current_num_threads(),
        best
    );
    for (name, t) in &stage {
        println!("  {name:<22} {t:.3} s");
    }
    println!(
        "  {:<22} {:.3} s (Adam: the rest of the iteration)",
        "listed stages", listed
    );
    println!("  normal-consistency pairs built once in {nc_build:.3} s");
    println!("peak memory {:.0} MB", peak_mb());
}
