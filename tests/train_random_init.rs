//! The acceptance case of `train` from random initial points (issue 27):
//! the generated textured sphere (40 cameras at 128×128, every 8th held
//! out) written WITHOUT `input.ply`, so both models start from random
//! (grey) points (`--init-points 20000`, see below); triangles (with the
//! kernel's 1-px size cull, and with `--min-inradius 0.5`) and Gaussians at
//! 3,000 iterations each, seed 0, held-out evaluation every 1,000.
//!
//! Measured when written (2 threads, shared host; the runs are
//! deterministic for any thread count):
//! - triangles 8.11 → 34.51 → 35.61 → 35.67 dB (10,603 triangles);
//! - triangles `--min-inradius 0.5` 8.10 → 34.83 → 36.35 → 36.68 dB
//!   (10,384);
//! - Gaussians 7.81 → 38.90 → 40.81 → 41.11 dB (32,379); 7.81 → 38.95 →
//!   40.73 → 41.11 dB (32,360) since the Gaussian rasteriser's `exp_approx`
//!   (2026-11-27; the triangle figures did not change).
//!
//! The official Triangle Splatting code, run on the same data and seeds,
//! ends at 35.62 dB (docs/train.md, "Against the official code").
//!
//! The goal (triangles within 1.5 dB of the Gaussians) is NOT met:
//! the gap is 5.44 dB (4.43 with `--min-inradius 0.5`). It was 1.91 dB
//! before `train gaussians` seeded its random points grey as 3DGS does
//! (docs/train.md, "Random initial points", which also measures a second
//! scene, the bunny mesh: 2.11 dB at the defaults, 1.39 dB with
//! `--lambda-opacity 0.00055`). Asserted, so that a
//! regression fails while the goal is open:
//! - no evaluation of a triangle run falls more than 0.5 dB below the one
//!   before (the issue saw 16.0 → 14.1 dB after a densification step;
//!   0.5 dB leaves room for the noise of a 5-view evaluation);
//! - triangles ≥ Gaussians − 6.0 dB, and with `--min-inradius 0.5` ≥
//!   Gaussians − 5.0 dB and ≥ the 1-px run + 0.5 dB (the measured figures
//!   with about 0.5 dB to spare; before issue 27 the gap was 13.5 dB);
//! - `render --min-inradius 0.5` of the written model gives the run's own
//!   final held-out PSNR.
//!
//! A long acceptance run: `#[ignore]`d, so the README's `cargo test
//! --workspace` stays fast; `cargo test --workspace -- --ignored` runs it,
//! and `.ci/run` does so on every change (docs/ARCHITECTURE.md, "Tests").

mod common;

use std::path::Path;

use splatkit::testing::write_sphere_dataset;

/// `--min-inradius` of the third run (pixels): sub-pixel triangles drawn.
const MIN_INRADIUS: &str = "0.5";

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

#[test]
#[ignore = "long acceptance run (several minutes on 2 cores): cargo test --workspace -- --ignored, as .ci/run does"]
fn triangles_and_gaussians_from_random_points() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("data");
    write_sphere_dataset(&d, 40, 128, 0).unwrap();
    assert!(!d.join("input.ply").exists());
    // 20,000 random points instead of the default 100,000: the triangle run
    // starts at one triangle per point and its first ~600 iterations (the
    // fog before the dead are relocated) dominate the time; docs/train.md
    // gives the 100,000-point numbers
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
    let sub = dir.path().join("tri_sub");
    let gs = dir.path().join("gs");
    for (model, out, extra) in [
        ("triangles", &tri, None),
        ("triangles", &sub, Some(MIN_INRADIUS)),
        ("gaussians", &gs, None),
    ] {
        let mut a = vec![model, p(&d), "-o", p(out)];
        a.extend(common);
        if let Some(m) = extra {
            a.extend(["--min-inradius", m]);
        }
        common::run_ok("train", &a);
    }
    let ((t, ts), (u, us), (g, gs_sum)) = (evals(&tri), evals(&sub), evals(&gs));
    eprintln!(
        "held-out PSNR: triangles {t:.2?} ({ts}), triangles --min-inradius {MIN_INRADIUS} \
         {u:.2?} ({us}), Gaussians {g:.2?} ({gs_sum})"
    );
    let g_end = g[g.len() - 1];
    for (name, e) in [("triangles", &t), ("triangles --min-inradius", &u)] {
        assert_eq!(
            e.len(),
            4,
            "{name}: evaluations at 0, 1000, 2000, 3000: {e:?}"
        );
        for w in e.windows(2) {
            assert!(
                w[1] >= w[0] - 0.5,
                "{name}: held-out PSNR fell between evaluations: {e:?}"
            );
        }
    }
    let (t_end, u_end) = (t[3], u[3]);
    assert!(
        t_end >= g_end - 6.0,
        "triangles {t_end:.2} dB vs Gaussians {g_end:.2} dB"
    );
    assert!(
        u_end >= g_end - 5.0 && u_end >= t_end + 0.5,
        "triangles --min-inradius {MIN_INRADIUS}: {u_end:.2} dB vs Gaussians {g_end:.2} dB and \
         the 1-px run's {t_end:.2} dB"
    );
    // `render --min-inradius` of the same value reproduces the run's own
    // final evaluation of the held-out views (every 8th from v00)
    let r = dir.path().join("renders");
    let model = sub.join("point_cloud/iteration_3000/triangles.ply");
    let cams = d.join("cameras.json");
    let images = d.join("images");
    let out = common::run_ok(
        "render",
        &[
            p(&model),
            "--cameras",
            p(&cams),
            "-o",
            p(&r),
            "--outputs",
            "rgb",
            "--compare",
            p(&images),
            "--min-inradius",
            MIN_INRADIUS,
            "--json",
            "-q",
        ],
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let views = j["views"].as_array().unwrap();
    let held: Vec<f64> = views
        .iter()
        .enumerate()
        .filter(|(i, _)| i % 8 == 0)
        .map(|(_, v)| v["psnr"].as_f64().unwrap())
        .collect();
    let mean = held.iter().sum::<f64>() / held.len() as f64;
    // both are the same f32 render compared with the same PNGs; 1e-3 dB
    // leaves room for the report's rounding only
    assert!(
        (mean - u[3]).abs() < 1e-3,
        "render --min-inradius: {mean} dB vs the run's {} dB",
        u[3]
    );
}
