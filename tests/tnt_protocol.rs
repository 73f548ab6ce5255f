//! `chamfer --protocol tnt` end to end on a generated scene: the
//! reconstruction is the ground truth under a known similarity (scale 2,
//! a rotation, a shift), with its camera trajectory transformed the same way.
//! The pipeline must undo the similarity and find every point within τ
//! (F-score 1), and write the plot and the coloured clouds.

mod common;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use glam::{DMat4, DVec3};
use splatkit::io::ply::{Format, points::write_points};
use splatkit::io::tnt::{LogFrame, write_crop_json, write_log};
use splatkit::model::PointCloud;
use splatkit::model::crop::{Axis, CropVolume};

const TAU: f64 = 0.01; // Barn's threshold

/// Box surface on a lattice of spacing τ (a voxel-aligned scene).
fn box_surface() -> Vec<[f64; 3]> {
    let mut v = Vec::new();
    for i in 0..=60i64 {
        for j in 0..=40i64 {
            for k in 0..=30i64 {
                if i == 0 || i == 60 || j == 0 || j == 40 || k == 0 || k == 30 {
                    v.push([i as f64 * TAU, j as f64 * TAU, k as f64 * TAU]);
                }
            }
        }
    }
    v
}

fn similarity(p: [f64; 3]) -> [f64; 3] {
    // Rotation by 30° about z, scale 2, shift (1, 2, 3).
    let (s, c) = 30f64.to_radians().sin_cos();
    [
        2.0 * (c * p[0] - s * p[1]) + 1.0,
        2.0 * (s * p[0] + c * p[1]) + 2.0,
        2.0 * p[2] + 3.0,
    ]
}

fn pose(c: [f64; 3]) -> LogFrame {
    LogFrame {
        meta: [0, 0, 0],
        pose: DMat4::from_translation(DVec3::from_array(c)),
    }
}

fn cloud(p: &[[f64; 3]]) -> PointCloud {
    PointCloud {
        positions: p.iter().map(|q| q.map(|x| x as f32)).collect(),
        ..Default::default()
    }
}

/// The generated Barn scene under `root`: the ground-truth folder
/// `root/Barn` (points, crop, identity alignment, a 30-camera reference
/// trajectory), the reconstruction `root/rec.ply` (the points under the
/// similarity) and its trajectory `root/rec.log`. Returns (ground-truth
/// folder, reference camera centres, reconstruction log, reconstruction).
fn write_scene(root: &Path) -> (PathBuf, Vec<[f64; 3]>, PathBuf, PathBuf) {
    let gt_dir = root.join("Barn");
    std::fs::create_dir_all(&gt_dir).unwrap();
    let gt = box_surface();
    splatkit::io::write_output(&gt_dir.join("Barn.ply"), |w| {
        write_points(w, &cloud(&gt), Format::BinaryLittleEndian)
    })
    .unwrap();
    let crop = CropVolume {
        orthogonal_axis: Axis::Z,
        axis_min: -0.1,
        axis_max: 0.5,
        bounding_polygon: vec![
            [-0.1, -0.1, 0.0],
            [0.8, -0.1, 0.0],
            [0.8, 0.6, 0.0],
            [-0.1, 0.6, 0.0],
        ],
    };
    write_crop_json(&gt_dir.join("Barn.json"), &crop).unwrap();
    std::fs::write(
        gt_dir.join("Barn_trans.txt"),
        "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n",
    )
    .unwrap();
    let centres: Vec<[f64; 3]> = (0..30)
        .map(|i| {
            let a = i as f64 / 30.0 * std::f64::consts::TAU;
            [
                0.3 + 2.0 * a.cos(),
                0.2 + 2.0 * a.sin(),
                1.0 + 0.1 * (3.0 * a).sin(),
            ]
        })
        .collect();
    write_log(
        &gt_dir.join("Barn_COLMAP_SfM.log"),
        &centres.iter().map(|&c| pose(c)).collect::<Vec<_>>(),
    )
    .unwrap();
    let rec_log = root.join("rec.log");
    write_log(
        &rec_log,
        &centres
            .iter()
            .map(|&c| pose(similarity(c)))
            .collect::<Vec<_>>(),
    )
    .unwrap();
    let rec: Vec<[f64; 3]> = gt.iter().map(|&p| similarity(p)).collect();
    let rec_ply = root.join("rec.ply");
    splatkit::io::write_output(&rec_ply, |w| {
        write_points(w, &cloud(&rec), Format::BinaryLittleEndian)
    })
    .unwrap();

    (gt_dir, centres, rec_log, rec_ply)
}

#[test]
fn similarity_copy_scores_one() {
    let tmp = tempfile::tempdir().unwrap();
    let (gt_dir, _, rec_log, rec_ply) = write_scene(tmp.path());
    let plot = tmp.path().join("pr.png");
    let vis = tmp.path().join("vis");
    let out = Command::cargo_bin("chamfer")
        .unwrap()
        .args(["--protocol", "tnt", "--scene", "Barn", "--gt-dir"])
        .arg(&gt_dir)
        .arg("--traj")
        .arg(&rec_log)
        .arg(&rec_ply)
        .arg("--plot")
        .arg(&plot)
        .arg("--vis-dir")
        .arg(&vis)
        .args(["--json", "-q"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["tau"], TAU);
    assert_eq!(v["precision"], 1.0);
    assert_eq!(v["recall"], 1.0);
    assert_eq!(v["fscore"], 1.0);
    // The recovered transform maps the reconstruction back: scale 1/2 on the
    // rotation block (row norms), to the f32 rounding of the input files.
    let t = &v["transformation"];
    let row_norm = |i: usize| {
        (0..3)
            .map(|j| t[i][j].as_f64().unwrap().powi(2))
            .sum::<f64>()
            .sqrt()
    };
    for i in 0..3 {
        assert!((row_norm(i) - 0.5).abs() < 1e-6, "row {i}: {}", row_norm(i));
    }
    assert!(std::fs::read(&plot).unwrap().starts_with(b"\x89PNG"));
    // The plot is a 640×480 RGB PNG.
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&plot).unwrap()));
    let reader = dec.read_info().unwrap();
    let info = reader.info();
    assert_eq!((info.width, info.height), (640, 480));
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert!(vis.join("Barn.precision.ply").exists() && vis.join("Barn.recall.ply").exists());

    // An all-zero _trans.txt cannot align anything: an error naming the
    // file (never precision = recall = 1 with exit 0), under the 2 GB
    // limit; the existing visualisation folder keeps its files.
    std::fs::write(gt_dir.join("Barn_trans.txt"), "0 0 0 0\n".repeat(4)).unwrap();
    let before = std::fs::read(vis.join("Barn.precision.ply")).unwrap();
    let p = |x: &std::path::Path| x.to_str().unwrap().to_string();
    let (gt_s, log_s, rec_s, vis_s) = (p(&gt_dir), p(&rec_log), p(&rec_ply), p(&vis));
    let out = common::run(
        "chamfer",
        &[
            "--protocol",
            "tnt",
            "--scene",
            "Barn",
            "--gt-dir",
            &gt_s,
            "--traj",
            &log_s,
            &rec_s,
            "--vis-dir",
            &vis_s,
        ],
        None,
    );
    common::fails(
        &out,
        1,
        &["Barn_trans.txt", "not a usable alignment transform"],
    );
    assert_eq!(
        std::fs::read(vis.join("Barn.precision.ply")).unwrap(),
        before
    );
    assert!(std::fs::read_dir(tmp.path()).unwrap().all(|e| {
        !e.unwrap()
            .file_name()
            .to_string_lossy()
            .contains(".splatkit-")
    }));

    // Missing ground-truth files are named.
    std::fs::remove_file(gt_dir.join("Barn_trans.txt")).unwrap();
    Command::cargo_bin("chamfer")
        .unwrap()
        .args(["--protocol", "tnt", "--scene", "Barn", "--gt-dir"])
        .arg(&gt_dir)
        .arg("--traj")
        .arg(&rec_log)
        .arg(&rec_ply)
        .assert()
        .code(1)
        .stderr(predicates::str::contains("Barn_trans.txt"));
}

/// Runs `chamfer` with `args` (and `--json -q`), expecting success; the JSON.
fn tnt_json(args: &[&str]) -> serde_json::Value {
    let out = Command::cargo_bin("chamfer")
        .unwrap()
        .args(args)
        .args(["--json", "-q"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The toolbox's command line (`--dataset-dir` named after the scene,
/// `--traj-path`, `--ply-path`, outputs in `evaluation/` beside the
/// reconstruction) gives the same numbers and byte-identical files as
/// splatkit's flags with `--out-dir`; the text files hold numpy's `%.18e`
/// lines ([P, R, F, τ, 5] = 1, 1, 1, 0.01, 5) and the plot is named
/// `PR_Barn_@d_th_0_0100.png`. A lower-case `--scene barn` finds `Barn.ply`.
#[test]
fn toolbox_flags_give_the_same_numbers_and_files() {
    let tmp = tempfile::tempdir().unwrap();
    let (gt_dir, _, rec_log, rec_ply) = write_scene(tmp.path());
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let a = tnt_json(&[
        "--protocol",
        "tnt",
        "--dataset-dir",
        &s(&gt_dir),
        "--traj-path",
        &s(&rec_log),
        "--ply-path",
        &s(&rec_ply),
    ]);
    let eval = tmp.path().join("evaluation");
    let mine = tmp.path().join("mine");
    let b = tnt_json(&[
        "--protocol",
        "tnt",
        "--scene",
        "barn",
        "--gt-dir",
        &s(&gt_dir),
        "--traj",
        &s(&rec_log),
        &s(&rec_ply),
        "--out-dir",
        &s(&mine),
    ]);
    for k in [
        "precision",
        "recall",
        "fscore",
        "tau",
        "source_points",
        "target_points",
    ] {
        assert_eq!(a[k], b[k], "{k}");
    }
    assert_eq!(a["scene"], "Barn");
    assert_eq!(b["scene"], "Barn");
    let names = [
        "Barn.precision.ply",
        "Barn.recall.ply",
        "Barn.precision.txt",
        "Barn.recall.txt",
        "Barn.prf_tau_plotstr.txt",
        "PR_Barn_@d_th_0_0100.png",
    ];
    for n in names {
        let (x, y) = (std::fs::read(eval.join(n)), std::fs::read(mine.join(n)));
        assert!(x.is_ok() && y.is_ok(), "{n} missing");
        assert_eq!(x.unwrap(), y.unwrap(), "{n} differs");
    }
    let prf = std::fs::read_to_string(eval.join("Barn.prf_tau_plotstr.txt")).unwrap();
    assert_eq!(
        prf,
        "1.000000000000000000e+00\n1.000000000000000000e+00\n1.000000000000000000e+00\n\
         1.000000000000000021e-02\n5.000000000000000000e+00\n"
    );
    let rec = std::fs::read_to_string(eval.join("Barn.recall.txt")).unwrap();
    // one line per histogram bin, as in the JSON
    assert_eq!(
        rec.lines().count(),
        b["cum_recall"].as_array().unwrap().len()
    );
}

/// A full-video trajectory (1700 frames, the reference cameras at video
/// frames 1, 41, 81, … with the others elsewhere) is reduced with
/// `Barn_mapping_reference.txt` and scores as the short log; without the
/// mapping file it is an error naming both lengths.
#[test]
fn long_trajectories_go_through_the_mapping() {
    let tmp = tempfile::tempdir().unwrap();
    let (gt_dir, centres, _, rec_ply) = write_scene(tmp.path());
    let mut frames: Vec<LogFrame> = (0..1700).map(|i| pose([i as f64, -5.0, 40.0])).collect();
    let mut map = format!("{}\n1700\n", centres.len());
    for (k, &c) in centres.iter().enumerate() {
        frames[40 * k] = pose(similarity(c));
        map.push_str(&format!("{k} {}\n", 40 * k + 1));
    }
    let long = tmp.path().join("long.log");
    write_log(&long, &frames).unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let args = |log: &Path| {
        vec![
            "--protocol".to_string(),
            "tnt".into(),
            "--dataset-dir".into(),
            s(&gt_dir),
            "--traj-path".into(),
            s(log),
            s(&rec_ply),
        ]
    };
    let out = common::run(
        "chamfer",
        &args(&long).iter().map(String::as_str).collect::<Vec<_>>(),
        None,
    );
    common::fails(&out, 1, &["1700", "30"]);
    std::fs::write(gt_dir.join("Barn_mapping_reference.txt"), map).unwrap();
    let v = tnt_json(&args(&long).iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(v["trajectory_mapped"], true);
    assert_eq!(v["fscore"], 1.0);
}
