//! `poisson` / `decimate` / `clean` benchmarks at real scale, one process.
//!
//! The scene, generated here: area-proportional oriented samples on a unit
//! sphere, a torus (R 2, r 0.5) and an open 9.5 × 8 plane patch, Gaussian
//! noise σ = 0.002 along the normal (`scripts/compare/gen_poisson_scene.py`
//! writes the same kind of scene for Open3D).
//!
//! Modes (first argument after `--`):
//! - `depths` (default): 1M points at depths 8, 9, 10, 11, then the SuGaR
//!   tail at depth 10 (trim 10 %, decimate to 1M faces, clean);
//! - `scaling`: depth 10 at 250k, 500k, 1M points;
//! - `tail`: the SuGaR tail only.
//!
//! Each line reports wall time, the process's peak RSS so far (runs go from
//! small to large, so it is the current run's peak) and the output size.
//! Threads: rayon's default (all cores); `RAYON_NUM_THREADS=1` for one.
//! Run: `cargo bench --bench poisson [-- scaling|tail]`.

mod common;
use common::peak_mb;
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use splatkit::geom::mesh_ops::clean::{merge_duplicate_vertices, remove_non_manifold_edges};
use splatkit::geom::mesh_ops::decimate::{Target, decimate};
use splatkit::geom::meshing::poisson::pipeline::{PipelineOptions, run_pipeline};
use splatkit::model::PointCloud;

fn scene(n: usize, seed: u64) -> PointCloud {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let (big, small) = (2.0f64, 0.5f64);
    let areas = [
        4.0 * std::f64::consts::PI,
        4.0 * std::f64::consts::PI.powi(2) * big * small,
        9.5 * 8.0,
    ];
    let total: f64 = areas.iter().sum();
    let mut pc = PointCloud::default();
    let mut nrm = Vec::with_capacity(n);
    let tau = std::f64::consts::TAU;
    while pc.positions.len() < n {
        let t: f64 = rng.random::<f64>() * total;
        let (p, d) = if t < areas[0] {
            let z: f64 = rng.random::<f64>() * 2.0 - 1.0;
            let ph: f64 = rng.random::<f64>() * tau;
            let s = (1.0 - z * z).sqrt();
            let d = [s * ph.cos(), s * ph.sin(), z];
            ([d[0], d[1], d[2] + 1.5], d)
        } else if t < areas[0] + areas[1] {
            let u: f64 = rng.random::<f64>() * tau;
            let v: f64 = rng.random::<f64>() * tau;
            if rng.random::<f64>() * (big + small) > big + small * v.cos() {
                continue;
            }
            let d = [v.cos() * u.cos(), v.cos() * u.sin(), v.sin()];
            (
                [
                    big * u.cos() + small * d[0],
                    big * u.sin() + small * d[1],
                    0.6 + small * d[2],
                ],
                d,
            )
        } else {
            let x: f64 = rng.random::<f64>() * 9.5 - 4.75;
            let y: f64 = rng.random::<f64>() * 8.0 - 4.0;
            ([x, y, 0.0], [0.0, 0.0, 1.0])
        };
        // Box–Muller noise along the normal
        let e = 0.002
            * (-2.0 * rng.random::<f64>().max(1e-300).ln()).sqrt()
            * (tau * rng.random::<f64>()).cos();
        pc.positions.push([
            (p[0] + e * d[0]) as f32,
            (p[1] + e * d[1]) as f32,
            (p[2] + e * d[2]) as f32,
        ]);
        nrm.push([d[0] as f32, d[1] as f32, d[2] as f32]);
    }
    pc.normals = Some(nrm);
    pc
}

fn options(depth: u32, trim: Option<f64>) -> PipelineOptions {
    PipelineOptions {
        params: splatkit::geom::meshing::poisson::PoissonParams {
            depth,
            ..Default::default()
        },
        trim_quantile: trim,
        ..Default::default()
    }
}

fn run(label: &str, pc: &PointCloud, depth: u32, trim: Option<f64>) -> splatkit::model::Mesh {
    let t = Instant::now();
    let out = run_pipeline(pc.clone(), &options(depth, trim)).expect("reconstruction");
    let s = &out.parts[0].poisson;
    println!(
        "{label:<28} depth {depth:>2}: {:>7.2} s  peak {:>6.0} MB  {:>8} samples  {:>9} vertices  {:>9} faces  [{}]",
        t.elapsed().as_secs_f64(),
        peak_mb(),
        s.samples,
        out.mesh.vertices.len(),
        out.mesh.faces.len(),
        s.seconds
            .iter()
            .map(|(k, v)| format!("{k} {v:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    out.mesh
}

fn main() {
    let mode = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .unwrap_or_else(|| "depths".into());
    println!("threads: {}", rayon::current_num_threads());
    match mode.as_str() {
        "scaling" => {
            for n in [250_000, 500_000, 1_000_000] {
                let pc = scene(n, 1);
                run(&format!("{n} points"), &pc, 10, None);
            }
        }
        _ => {
            let pc = scene(1_000_000, 1);
            if mode != "tail" {
                for d in [8, 9, 10, 11] {
                    run("1M points", &pc, d, None);
                }
            }
            let mesh = run("1M points, trim 0.1", &pc, 10, Some(0.1));
            let t = Instant::now();
            let (mut m, r) = decimate(&mesh, Target::Faces(1_000_000)).expect("decimate");
            println!(
                "decimate {} -> {} faces: {:.2} s",
                r.faces_before,
                r.faces_after,
                t.elapsed().as_secs_f64()
            );
            let t = Instant::now();
            let merged = merge_duplicate_vertices(&mut m);
            let nm = remove_non_manifold_edges(&mut m);
            println!(
                "clean (merge {merged}, non-manifold {nm}) of {} faces: {:.2} s",
                m.faces.len(),
                t.elapsed().as_secs_f64()
            );
        }
    }
}
