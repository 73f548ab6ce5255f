//! `train` from the command line: determinism, exact resume, the output
//! layout other tools read, and bad input (clear errors, nothing written).

mod common;

use std::path::{Path, PathBuf};

use common::{fails, run, succeeds};
use splatkit::testing::write_sphere_dataset;

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// A small generated DATA folder: 12 views of the textured sphere at 32²
/// with 200 seed points.
fn data(dir: &Path) -> PathBuf {
    let d = dir.join("data");
    write_sphere_dataset(&d, 12, 32, 200).unwrap();
    d
}

fn train(model: &str, data: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut a = vec![
        model,
        p(data),
        "-o",
        p(out),
        "--iterations",
        "450",
        "--eval-every",
        "200",
    ];
    if !extra.contains(&"--verbose") {
        a.push("-q");
    }
    if model == "gaussians" {
        a.extend(["--regularize", "density", "--samples", "500"]);
    } else {
        a.extend(["--max-shapes", "600"]);
    }
    a.extend(extra);
    run("train", &a, None)
}

fn files(model: &str) -> Vec<&'static str> {
    let mut f = vec!["checkpoint/optimizer.bin", "checkpoint/model.ply"];
    if model == "gaussians" {
        f.push("point_cloud/iteration_450/point_cloud.ply");
    } else {
        f.push("point_cloud/iteration_450/point_cloud_state_dict.pt");
        f.push("point_cloud/iteration_450/triangles.ply");
    }
    f
}

/// Same seed and thread count → identical checkpoint bytes (and, the
/// rasterisers and reductions being thread-count independent, also across
/// 1 and 2 threads); a run stopped at iteration 210 (after the first
/// densification at 200) and resumed equals the uninterrupted one, byte for
/// byte. The 1-thread run is `--verbose`: it prints each strategy's edits
/// at the iterations of the scaled schedule and writes the same bytes.
#[test]
fn deterministic_and_resume_exact() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(dir.path());
    for model in ["triangles", "gaussians"] {
        let a = dir.path().join(format!("{model}_a"));
        let b = dir.path().join(format!("{model}_b"));
        let c = dir.path().join(format!("{model}_c"));
        succeeds(&train(model, &d, &a, &["-j", "2"]));
        let verbose = train(model, &d, &b, &["-j", "1", "--verbose"]);
        succeeds(&verbose);
        let log = String::from_utf8_lossy(&verbose.stderr);
        // triangles: interval max(500·450/30000, 12 views, 200) = 200,
        // densify before 25,000 → 375, prune after; Gaussians (SuGaR, 15,000
        // reference iterations): ADC every 3 from 15 until 210, opacity
        // reset every 90, SuGaR's prune at 270
        let want: &[&str] = if model == "triangles" {
            &[
                "iteration 200: mcmc densify: ",
                "iteration 400: mcmc prune: ",
            ]
        } else {
            &[
                "iteration 18: adc densify: ",
                "iteration 90: adc opacity reset: ",
                "iteration 270: sugar prune: ",
            ]
        };
        for w in want {
            assert!(log.contains(w), "{model}: no {w:?} in\n{log}");
        }
        assert!(
            !log.contains("iteration 213: adc"),
            "{model}: ADC after 210"
        );
        succeeds(&train(model, &d, &c, &["-j", "2", "--stop-at", "210"]));
        assert!(c.join("checkpoint/optimizer.bin").is_file());
        succeeds(&train(model, &d, &c, &["-j", "2", "--resume", p(&c)]));
        for f in files(model) {
            let want = std::fs::read(a.join(f)).unwrap_or_else(|e| panic!("{model} {f}: {e}"));
            assert_eq!(
                want,
                std::fs::read(b.join(f)).unwrap(),
                "{model} {f}: threads"
            );
            assert_eq!(
                want,
                std::fs::read(c.join(f)).unwrap(),
                "{model} {f}: resume"
            );
        }
        for f in ["cameras.json", "cfg_args", "input.ply", "metrics.json"] {
            assert!(a.join(f).is_file(), "{model}: {f}");
        }
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(c.join("metrics.json")).unwrap()).unwrap();
        let its: Vec<u64> = m["evals"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["iteration"].as_u64().unwrap())
            .collect();
        assert_eq!(its, vec![0, 200, 400, 450], "{model}");
    }
}

/// `--schedule reference`: the milestones stay at the reference's
/// iteration numbers, so `--iterations N --schedule reference` is the run
/// `--iterations R --stop-at N` (R the reference length: 30,000 for
/// triangles, 15,000 for SuGaR's coarse stage), byte for byte, and its
/// edits fall where the reference's do: triangles densify first at 1,000
/// (every 500 after the 500th), Gaussians every 100 from 600.
#[test]
fn reference_schedule_is_the_full_course_stopped_early() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(dir.path());
    for (model, n, full, edits) in [
        (
            "triangles",
            "1050",
            "30000",
            &["iteration 1000: mcmc densify: "][..],
        ),
        (
            "gaussians",
            "650",
            "15000",
            &["iteration 600: adc densify: "][..],
        ),
    ] {
        let extra: &[&str] = if model == "gaussians" {
            &["--regularize", "density", "--samples", "500"]
        } else {
            &["--max-shapes", "600"]
        };
        let a = dir.path().join(format!("{model}_ref"));
        let b = dir.path().join(format!("{model}_stop"));
        let mut args = vec![model, p(&d), "-o", p(&a), "--iterations", n];
        args.extend(["--schedule", "reference", "--eval-every", "0", "-v"]);
        args.extend(extra);
        let out = run("train", &args, None);
        succeeds(&out);
        let log = String::from_utf8_lossy(&out.stderr);
        for w in edits {
            assert!(log.contains(w), "{model}: no {w:?} in\n{log}");
        }
        // nothing before the reference's first step (the scaled schedule of
        // this length would have edited from iteration 200 / 18 on)
        let first = log.find("iteration ").map(|i| &log[i..i + 16]);
        assert!(
            first.is_some_and(|f| edits[0].starts_with(f)),
            "{model}: first edit {first:?}"
        );
        let mut args = vec![model, p(&d), "-o", p(&b), "--iterations", full];
        args.extend(["--stop-at", n, "--eval-every", "0", "-q"]);
        args.extend(extra);
        succeeds(&run("train", &args, None));
        let f = format!("point_cloud/iteration_{n}");
        for f in [
            format!(
                "{f}/{}",
                if model == "triangles" {
                    "triangles.ply"
                } else {
                    "point_cloud.ply"
                }
            ),
            "checkpoint/model.ply".into(),
        ] {
            assert_eq!(
                std::fs::read(a.join(&f)).unwrap(),
                std::fs::read(b.join(&f)).unwrap(),
                "{model} {f}"
            );
        }
    }
}

/// The outputs are read by the other tools: `info` on the triangle
/// checkpoint and soup PLY, `splat2points` on the Gaussian run folder.
#[test]
fn outputs_are_read_by_other_tools() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(dir.path());
    let t = dir.path().join("t");
    let g = dir.path().join("g");
    succeeds(&train("triangles", &d, &t, &[]));
    succeeds(&train("gaussians", &d, &g, &[]));
    for f in [
        "point_cloud/iteration_450/point_cloud_state_dict.pt",
        "point_cloud/iteration_450/triangles.ply",
    ] {
        succeeds(&run("info", &[p(&t.join(f))], None));
    }
    let pts = dir.path().join("pts.ply");
    succeeds(&run(
        "splat2points",
        &[p(&g), "-o", p(&pts), "-q", "--min-opacity", "0.01"],
        None,
    ));
    assert!(pts.is_file());
}

/// Bad input: clear errors naming what is wrong, exit 1, and the output
/// folder is neither created nor (for a refused resume) changed.
#[test]
fn bad_input_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(dir.path());
    let out = dir.path().join("out");
    // an empty image folder
    let empty = dir.path().join("empty");
    std::fs::create_dir_all(empty.join("images")).unwrap();
    std::fs::copy(d.join("cameras.json"), empty.join("cameras.json")).unwrap();
    fails(&train("triangles", &empty, &out, &[]), 1, &["images"]);
    assert!(!out.exists());
    // a camera without its image
    let missing = dir.path().join("missing");
    write_sphere_dataset(&missing, 12, 32, 200).unwrap();
    std::fs::remove_file(missing.join("images/v03.png")).unwrap();
    fails(&train("gaussians", &missing, &out, &[]), 1, &["v03"]);
    assert!(!out.exists());
    // an image of the wrong size
    let sized = dir.path().join("sized");
    write_sphere_dataset(&sized, 12, 32, 200).unwrap();
    write_sphere_dataset(&dir.path().join("big"), 12, 40, 0).unwrap();
    std::fs::copy(
        dir.path().join("big/images/v05.png"),
        sized.join("images/v05.png"),
    )
    .unwrap();
    fails(
        &train("triangles", &sized, &out, &[]),
        1,
        &["40x40", "32x32"],
    );
    assert!(!out.exists());
    // a camera file with no usable view
    let none = dir.path().join("none");
    write_sphere_dataset(&none, 12, 32, 200).unwrap();
    std::fs::write(none.join("cameras.json"), "[]").unwrap();
    fails(&train("gaussians", &none, &out, &[]), 1, &["camera"]);
    assert!(!out.exists());
    // resuming a triangle run as Gaussians
    let t = dir.path().join("t");
    succeeds(&train("triangles", &d, &t, &[]));
    let before = std::fs::read(t.join("checkpoint/optimizer.bin")).unwrap();
    fails(
        &train("gaussians", &d, &t, &["--resume", p(&t)]),
        1,
        &["triangles run"],
    );
    assert_eq!(
        before,
        std::fs::read(t.join("checkpoint/optimizer.bin")).unwrap()
    );
    assert!(t.join("point_cloud/iteration_450/triangles.ply").is_file());
    // other settings
    fails(
        &train(
            "triangles",
            &d,
            &t,
            &["--resume", p(&t), "--white-background"],
        ),
        1,
        &["other settings"],
    );
}

/// `--lambda-opacity` (the reference's `--lambda_opacity`) reaches the
/// settings and the loss: 0 writes 0 in the settings and trains another
/// model than the default 0.0055; negative or non-finite weights are usage
/// errors (exit 2) and nothing is written.
#[test]
fn lambda_opacity_sets_the_regulariser() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(dir.path());
    let weight = |out: &Path| {
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("metrics.json")).unwrap()).unwrap();
        m["settings"]["params"]["lambda_opacity"].as_f64().unwrap()
    };
    let model = "point_cloud/iteration_450/triangles.ply";
    let (def, off) = (dir.path().join("def"), dir.path().join("off"));
    succeeds(&train("triangles", &d, &def, &[]));
    succeeds(&train("triangles", &d, &off, &["--lambda-opacity", "0"]));
    assert_eq!(weight(&def), 0.0055);
    assert_eq!(weight(&off), 0.0);
    assert_ne!(
        std::fs::read(def.join(model)).unwrap(),
        std::fs::read(off.join(model)).unwrap()
    );
    for bad in ["-1", "nan", "inf", "x"] {
        let out = dir.path().join("bad");
        fails(
            &train("triangles", &d, &out, &["--lambda-opacity", bad]),
            2,
            &["--lambda-opacity"],
        );
        assert!(!out.exists(), "{bad}");
    }
}
