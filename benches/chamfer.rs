//! `chamfer` benchmarks at real scale, single process (rayon uses every core).
//!
//! 1. DTU-sized, end to end (files read, up-sampling, downsampling, filters,
//!    both distance directions): a 1.5M-triangle sphere mesh of radius 150 mm
//!    (edges ≈ 1 mm, as a DTU TSDF mesh) against 3M STL points, with an
//!    ObsMask and a plane, through `dtu_from_files`.
//! 2. Generic Chamfer 10M vs 10M points (two noisy spheres), index build and
//!    both directions.
//!
//! Run: `cargo bench --bench chamfer`. Environment: `SPLATKIT_BENCH_SCALE`
//! (default 1.0) scales every size, for quick runs.

use std::time::Instant;

use rand::{RngExt, SeedableRng};
use splatkit::eval::chamfer::{Cloud, GenericParams, SampleMode, chamfer_generic};
use splatkit::eval::dtu::DtuParams;
use splatkit::io::dtu::{ObsMask, write_obs_mask, write_plane};
use splatkit::io::ply::{Format, mesh::write_mesh, points::write_points};
use splatkit::model::{Mesh, PointCloud};
use splatkit::ops::chamfer::{DtuFiles, dtu_from_files};

fn fibonacci(n: usize, r: f64, c: [f64; 3], noise: f64, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let s = (1.0 - z * z).sqrt();
            let t = golden * i as f64;
            let rr = r + if noise > 0.0 {
                rng.random_range(-noise..noise)
            } else {
                0.0
            };
            [
                c[0] + rr * s * t.cos(),
                c[1] + rr * s * t.sin(),
                c[2] + rr * z,
            ]
        })
        .collect()
}

/// UV sphere with `rings × segments × 2` triangles (poles as fans).
fn uv_sphere(rings: usize, segments: usize, r: f64, c: [f64; 3]) -> Mesh {
    let mut v = vec![[c[0] as f32, c[1] as f32, (c[2] + r) as f32]];
    for i in 1..rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let ph = std::f64::consts::TAU * j as f64 / segments as f64;
            v.push([
                (c[0] + r * th.sin() * ph.cos()) as f32,
                (c[1] + r * th.sin() * ph.sin()) as f32,
                (c[2] + r * th.cos()) as f32,
            ]);
        }
    }
    v.push([c[0] as f32, c[1] as f32, (c[2] - r) as f32]);
    let south = (v.len() - 1) as u32;
    let idx = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
    let mut f = Vec::new();
    for j in 0..segments {
        f.push([0, idx(1, j), idx(1, j + 1)]);
        f.push([south, idx(rings - 1, j + 1), idx(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            f.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            f.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    Mesh::new(v, f)
}

fn main() {
    let scale: f64 = std::env::var("SPLATKIT_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    println!(
        "chamfer bench: {} threads, scale {scale}",
        rayon::current_num_threads()
    );
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("DTU");
    std::fs::create_dir_all(root.join("Points/stl")).unwrap();
    std::fs::create_dir_all(root.join("ObsMask")).unwrap();
    let c = [0.0, 0.0, 600.0];
    // 1.5M triangles: rings × segments × 2 with segments = 2·rings.
    let rings = ((1_500_000.0 * scale / 4.0).sqrt()) as usize;
    let mesh = uv_sphere(rings, 2 * rings, 150.0, c);
    let stl = fibonacci((3_000_000.0 * scale) as usize, 150.3, c, 0.05, 1);
    let pred_path = dir.path().join("mesh.ply");
    splatkit::io::write_output(&pred_path, |w| {
        write_mesh(w, &mesh, Format::BinaryLittleEndian)
    })
    .unwrap();
    let pc = PointCloud {
        positions: stl.iter().map(|p| p.map(|x| x as f32)).collect(),
        ..Default::default()
    };
    splatkit::io::write_output(&root.join("Points/stl/stl024_total.ply"), |w| {
        write_points(w, &pc, Format::BinaryLittleEndian)
    })
    .unwrap();
    // ObsMask at 1 mm over the object's box (with the 10 mm margin), upper
    // three quarters set; the plane keeps z > 480 mm.
    let bb = [[-160.0, -160.0, 440.0], [160.0, 160.0, 760.0]];
    let dims = [321usize, 321, 321];
    let mut mask = vec![0u8; dims[0] * dims[1] * dims[2]];
    for z in 80..dims[2] {
        mask[z * dims[0] * dims[1]..(z + 1) * dims[0] * dims[1]].fill(1);
    }
    write_obs_mask(
        &root.join("ObsMask/ObsMask24_10.mat"),
        &ObsMask {
            mask,
            dims,
            bb,
            res: 1.0,
        },
    )
    .unwrap();
    write_plane(&root.join("ObsMask/Plane24.mat"), [0.0, 0.0, 1.0, -480.0]).unwrap();

    let t = Instant::now();
    let run = dtu_from_files(
        &DtuFiles {
            pred: &pred_path,
            dataset_dir: &root,
            scan: 24,
            pcd: false,
            cull: None,
            max_samples: u64::MAX,
        },
        &DtuParams::default(),
    )
    .unwrap();
    let secs = t.elapsed().as_secs_f64();
    let r = &run.report;
    println!(
        "dtu end to end: {} triangles vs {} STL points: {secs:.2} s  (sampled {} -> down {} -> obs {}; mean_d2s {:.4} mean_s2d {:.4})",
        mesh.faces.len(),
        stl.len(),
        r.points_sampled,
        r.points_down,
        r.points_in_obs,
        r.mean_d2s,
        r.mean_s2d
    );

    // Seed spread: the shuffle before downsampling is the only randomness.
    let overall: Vec<f64> = (1..=4u64)
        .map(|seed| {
            dtu_from_files(
                &DtuFiles {
                    pred: &pred_path,
                    dataset_dir: &root,
                    scan: 24,
                    pcd: false,
                    cull: None,
                    max_samples: u64::MAX,
                },
                &DtuParams {
                    seed,
                    ..DtuParams::default()
                },
            )
            .unwrap()
            .report
            .overall
        })
        .chain([r.overall])
        .collect();
    let mean = overall.iter().sum::<f64>() / overall.len() as f64;
    let (lo, hi) = overall
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    println!(
        "dtu seeds 0..4: overall mean {mean:.6}, range {:.6}..{:.6} ({:.4} % of the mean)",
        lo,
        hi,
        (hi - lo) / mean * 100.0
    );

    let n = (10_000_000.0 * scale) as usize;
    let a = Cloud {
        points: fibonacci(n, 1.0, [0.0; 3], 0.001, 2),
        normals: None,
    };
    let b = Cloud {
        points: fibonacci(n, 1.0005, [0.0; 3], 0.001, 3),
        normals: None,
    };
    let p = GenericParams {
        sample: SampleMode::Vertices,
        count: 0,
        spacing: 0.0,
        thresholds: vec![0.001],
        max_dist: None,
        seed: 0,
    };
    let t = Instant::now();
    let g = chamfer_generic(&a, &b, &p).unwrap();
    println!(
        "generic {n} vs {n}: {:.2} s (chamfer-L1 {:.6}, F@0.001 {:.4})",
        t.elapsed().as_secs_f64(),
        g.chamfer_l1,
        g.fscores[0].fscore
    );
}
