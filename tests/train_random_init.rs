//! The acceptance case of `train` from random initial points (issue 27):
//! the generated textured sphere (40 cameras at 128×128, every 8th held
//! out) written WITHOUT `input.ply`, so both models start from random
//! points (`--init-points 20000`, see below); triangles and Gaussians at
//! 3,000 iterations each, seed 0, held-out evaluation every 1,000.
//!
//! Asserted: the triangles' final held-out PSNR is at least the Gaussians'
//! minus 2.5 dB, and no evaluation of the triangle run
//! falls more than 0.5 dB below the one before (the issue saw 16.0 → 14.1
//! dB after a densification step; 0.5 dB leaves room for the few-view
//! noise of a 5-view evaluation without letting such a collapse pass).
//! Measured when written (2 threads, shared host): triangles 8.11 → 34.51
//! → 35.61 → 35.67 dB (10,603 triangles, 3.36 it/s), Gaussians 7.67 →
//! 35.30 → 37.91 → 37.58 dB (52,823 Gaussians, 10.4 it/s): a 1.91 dB gap.
//! The issue's goal is 1.5 dB and is NOT met yet (docs/train.md, "Random
//! initial points"); the 2.5 dB bound is the measured gap plus 0.6 dB for
//! other CPUs' rounding, so a regression fails; tighten it to 1.5 once the
//! gap is closed. Before issue 27's fixes the gap was 13.5 dB.
//!
//! A long acceptance run: `#[ignore]`d, so the README's `cargo test
//! --workspace` stays fast; `cargo test --workspace -- --ignored` runs it,
//! and `.ci/run` does so on every change (docs/ARCHITECTURE.md, "Tests").

use std::path::Path;

use splatkit::testing::write_sphere_dataset;

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Held-out PSNR at each evaluation of a run, in order, and the run's
/// summary (primitives, it/s) for the message.
fn evals(run_dir: &Path) -> (Vec<f64>, String) {
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run_dir.join("metrics.json")).unwrap()).unwrap();
    assert_eq!(m["random_init"], serde_json::Value::Bool(true));
    let e = m["evals"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["psnr"].as_f64().unwrap())
        .collect();
    let summary = format!(
        "{} primitives, {:.2} it/s",
        m["primitives"], m["iterations_per_second"]
    );
    (e, summary)
}

/// Runs `train` without the CLI tests' address-space limit.
fn train(args: &[&str]) {
    let exe = assert_cmd::cargo::cargo_bin("train");
    let out = std::process::Command::new(exe).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "train: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
#[ignore = "long acceptance run (several minutes on 2 cores): cargo test --workspace -- --ignored, as .ci/run does"]
fn triangles_from_random_points_keep_up_with_gaussians() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("data");
    write_sphere_dataset(&d, 40, 128, 0).unwrap();
    assert!(!d.join("input.ply").exists());
    // 20,000 random points instead of the default 100,000: the triangle run
    // starts at one triangle per point and its first ~600 iterations (the
    // fog before the dead are relocated) dominate the time, ~15 minutes on
    // 2 cores at 100,000; docs/train.md gives the 100,000-point numbers
    let common = [
        "--iterations",
        "3000",
        "--eval-every",
        "1000",
        "--init-points",
        "20000",
        "-q",
    ];
    let tri = dir.path().join("tri");
    let gs = dir.path().join("gs");
    for (model, out) in [("triangles", &tri), ("gaussians", &gs)] {
        let mut a = vec![model, p(&d), "-o", p(out)];
        a.extend(common);
        train(&a);
    }
    let ((t, ts), (g, gs)) = (evals(&tri), evals(&gs));
    eprintln!("held-out PSNR: triangles {t:.2?} ({ts}), Gaussians {g:.2?} ({gs})");
    assert_eq!(t.len(), 4, "evaluations at 0, 1000, 2000, 3000: {t:?}");
    let (t_end, g_end) = (t[t.len() - 1], g[g.len() - 1]);
    assert!(
        t_end >= g_end - 2.5,
        "triangles {t_end:.2} dB vs Gaussians {g_end:.2} dB"
    );
    for w in t.windows(2) {
        assert!(
            w[1] >= w[0] - 0.5,
            "held-out PSNR fell between evaluations: {t:?}"
        );
    }
}
