//! The acceptance case of `train` on the generated scene (docs/train.md):
//! a textured unit sphere rendered by the mesh rasteriser from 40 cameras at
//! 128×128 (every 8th held out), trained with the same commands as
//! `scripts/train_sphere.sh`, seed 0:
//! - triangles, 3,000 iterations (≤ 30,000 triangles) → `tsdf-fuse`;
//! - Gaussians, 3,000 iterations, without and with SuGaR's density
//!   regulariser → `splat2points | poisson`.
//!
//! Both models must pass 30 dB held-out PSNR; the meshes are measured
//! against the exact sphere ([`splatkit::testing::sphere_mesh_distance`]).
//! Measured when written (2 threads): triangles 9.44 → 36.93 dB, TSDF mesh
//! Chamfer 0.0069; 3DGS 13.20 → 43.43 dB, Poisson mesh Chamfer 0.0960;
//! SuGaR density 13.20 → 34.94 dB, Chamfer 0.0076. Re-run on 2026-11-27
//! after the Gaussian rasteriser's exponential became `exp_approx` (within
//! 1 ulp of libm's): 3DGS 13.20 → 43.22 dB, Chamfer 0.0986; SuGaR → 35.25 dB,
//! Chamfer 0.0079; triangles 9.44 → 36.93 dB, Chamfer 0.0068. After `poisson`
//! took Open3D's density normaliser and extraction tree (same day): 3DGS
//! Chamfer 0.0983, SuGaR 0.0079, the rest unchanged. The bounds below leave
//! room for other CPUs' rounding (the runs are deterministic for a given
//! machine): 30 dB as the issue asks; Chamfer < 0.02 (2 % of the radius,
//! about 1.3 px at this resolution) for the triangle and regularised
//! meshes; and the regularised mesh at least 3× closer than the
//! unregularised one.
//!
//! A long acceptance run: `#[ignore]`d, so the README's `cargo test
//! --workspace` stays fast; `cargo test --workspace -- --ignored` runs it,
//! and `.ci/run` does so on every change (docs/ARCHITECTURE.md, "Tests").

mod common;

use std::path::Path;

use splatkit::io::any::load_mesh;
use splatkit::testing::{sphere_mesh_distance, write_sphere_dataset};

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn psnr(run_dir: &Path) -> (f64, f64) {
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run_dir.join("metrics.json")).unwrap()).unwrap();
    let e = m["evals"].as_array().unwrap();
    (
        e[0]["psnr"].as_f64().unwrap(),
        e[e.len() - 1]["psnr"].as_f64().unwrap(),
    )
}

fn chamfer(mesh: &Path) -> f64 {
    let (a, c) = sphere_mesh_distance(&load_mesh(mesh, "test").unwrap()).unwrap();
    0.5 * (a + c)
}

#[test]
#[ignore = "long acceptance run (about 9 minutes on 2 cores): cargo test --workspace -- --ignored, as .ci/run does"]
fn both_models_reach_30_db_and_the_regularised_meshes_fit_the_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("data");
    write_sphere_dataset(&d, 40, 128, 2000).unwrap();
    let o = |s: &str| dir.path().join(s);
    let common = ["--iterations", "3000", "--eval-every", "0", "-q"];
    // triangles → tsdf-fuse
    let tri = o("tri");
    let mut a = vec!["triangles", p(&d), "-o", p(&tri), "--max-shapes", "30000"];
    a.extend(common);
    common::run_ok("train", &a);
    let pt = o("tri/point_cloud/iteration_3000/point_cloud_state_dict.pt");
    let cams = o("tri/cameras.json");
    let tri_mesh = o("tri.ply");
    common::run_ok(
        "tsdf-fuse",
        &[p(&pt), "--cameras", p(&cams), "-q", "-o", p(&tri_mesh)],
    );
    // Gaussians, without and with SuGaR's density regulariser
    for (name, reg) in [("gs", None), ("sugar", Some("density"))] {
        let mut a = vec!["gaussians", p(&d)];
        let out = o(name);
        a.extend(["-o", p(&out)]);
        a.extend(common);
        if let Some(r) = reg {
            a.extend(["--regularize", r]);
        }
        common::run_ok("train", &a);
        let pts = o(&format!("{name}_points.ply"));
        common::run_ok(
            "splat2points",
            &[p(&out), "--all-views", "-q", "-o", p(&pts)],
        );
        let mesh = o(&format!("{name}.ply"));
        common::run_ok("poisson", &[p(&pts), "--depth", "8", "-q", "-o", p(&mesh)]);
    }
    let (t0, t1) = psnr(&o("tri"));
    let (g0, g1) = psnr(&o("gs"));
    let (s0, s1) = psnr(&o("sugar"));
    let (ct, cg, cs) = (
        chamfer(&o("tri.ply")),
        chamfer(&o("gs.ply")),
        chamfer(&o("sugar.ply")),
    );
    eprintln!(
        "triangles {t0:.2} -> {t1:.2} dB, Chamfer {ct:.4}; 3DGS {g0:.2} -> {g1:.2} dB, Chamfer {cg:.4}; \
         SuGaR {s0:.2} -> {s1:.2} dB, Chamfer {cs:.4}"
    );
    assert!(t1 >= 30.0 && g1 >= 30.0 && s1 >= 30.0, "{t1} {g1} {s1}");
    assert!(ct < 0.02, "triangle TSDF mesh Chamfer {ct}");
    assert!(cs < 0.02, "SuGaR Poisson mesh Chamfer {cs}");
    assert!(cs * 3.0 < cg, "regularised {cs} vs unregularised {cg}");
}
