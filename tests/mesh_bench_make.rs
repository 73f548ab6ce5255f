//! `scripts/mesh_bench.mk` end to end on a small sphere scene with the
//! binaries this test build made (no cargo call from the Makefile): every
//! stage runs, the table has a row per method with every score, and the
//! tetra-mesh row is on the sphere. A long run (`#[ignore]`d), as
//! `.ci/run` runs it.

use std::path::PathBuf;
use std::process::Command;

/// `target/<profile>/examples/mesh_bench_scene`, which `cargo test` builds
/// beside the test binaries.
fn scene_generator() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let profile_dir = exe.parent().unwrap().parent().unwrap();
    profile_dir.join("examples/mesh_bench_scene")
}

#[test]
#[ignore = "long run (about 5 minutes on 2 cores): cargo test --workspace -- --ignored, as .ci/run does"]
fn makefile_runs_every_extraction_and_scores_it() {
    let gen_path = scene_generator();
    assert!(
        gen_path.exists(),
        "{} missing: cargo test builds the examples",
        gen_path.display()
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mb");
    let repo = env!("CARGO_MANIFEST_DIR");
    let status = Command::new("make")
        .arg("-f")
        .arg(format!("{repo}/scripts/mesh_bench.mk"))
        .arg("-j2")
        .arg("SHAPES=sphere")
        .arg("ITERS=600")
        .arg("VIEWS=10")
        .arg("SIZE=48")
        .arg(format!("OUT={}", out.display()))
        .arg(format!("SPLATKIT={}", env!("CARGO_BIN_EXE_splatkit")))
        .arg(format!("SCENEGEN={}", gen_path.display()))
        .status()
        .expect("make runs (GNU make and python3 are needed)");
    assert!(status.success(), "make failed: {status}");
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    for row in [
        "train gaussians",
        "splat2points + poisson --sugar",
        "tsdf-fuse",
        "tetra-mesh",
    ] {
        assert!(table.contains(row), "no '{row}' row in\n{table}");
    }
    for m in ["sugar", "tsdf", "tetra", "truth"] {
        let png = out.join(format!("sphere/pictures/{m}.png"));
        assert!(png.exists(), "{} missing", png.display());
    }
    // The tetra-mesh row's exact scores. At 48² pixels, 10 views and 600
    // iterations the model has floaters. Measured: accuracy 0.139,
    // completeness 0.046. Bounds: 0.25 and 0.1 of the radius. A mesh
    // unrelated to the sphere, or a column mix-up in the table, scores far
    // above them (the sphere's own diameter is 2).
    let row = table.lines().find(|l| l.contains("tetra-mesh")).unwrap();
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    let accuracy: f64 = cells[7].parse().unwrap();
    let completeness: f64 = cells[8].parse().unwrap();
    assert!(
        accuracy < 0.25 && completeness < 0.1,
        "tetra-mesh accuracy {accuracy}, completeness {completeness}\n{table}"
    );
}
