//! Hostile input never takes the machine down (issue 11): each case is a
//! few hundred bytes of input or a flag a hostile user could pass, run
//! under a 2 GB address-space limit (`ulimit -v`), and must end with exit
//! 1 (bad data) or 2 (bad usage), a message naming the file or flag and the
//! problem, no panic text, and no output created or replaced.

mod common;

use std::path::{Path, PathBuf};

use common::{cameras_file, fails, mesh_file, run, s, succeeds, triangle};

use glam::{DMat3, DVec3};
use splatkit::io::any::save;
use splatkit::io::detect::FileFormat;
use splatkit::model::{Camera, Mesh, PointCloud, Scene};

fn camera(name: &str, w: u32, h: u32) -> Camera {
    Camera::pinhole(
        name,
        w,
        h,
        100.0,
        100.0,
        w as f64 / 2.0,
        h as f64 / 2.0,
        DMat3::IDENTITY,
        DVec3::new(0.0, 0.0, 4.0),
    )
}

/// `mesh.ply` in `dir`: one [`triangle`].
fn triangle_file(dir: &Path) -> PathBuf {
    mesh_file(dir, "mesh.ply", triangle())
}

/// Image sizes from a camera file are checked before anything is allocated:
/// 100000×100000 names the pixel limit; 4294967295 on a side too.
#[test]
fn huge_image_sizes_from_camera_files() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triangle_file(dir.path());
    let out_dir = dir.path().join("renders");
    for (w, h) in [(100_000, 100_000), (u32::MAX, u32::MAX), (u32::MAX, 1)] {
        let cams = cameras_file(dir.path(), "cameras.json", &[camera("a", w, h)]);
        let out = run(
            "render",
            &[s(&mesh), "--cameras", s(&cams), "-o", s(&out_dir)],
            None,
        );
        fails(
            &out,
            1,
            &["cameras.json", "exceeds the limit of 268435456 pixels"],
        );
        assert!(!out_dir.exists(), "no output folder for a refused run");
    }
}

/// Zero-size images, zero or NaN focal lengths, a non-finite pose, no
/// cameras at all, and two cameras with one name are refused whatever the
/// camera format (the JSON readers refuse some of these themselves; a
/// COLMAP model goes through the shared checks), naming the source and the
/// camera.
#[test]
fn unusable_cameras_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triangle_file(dir.path());
    let out_dir = dir.path().join("renders");
    let mut nan_focal = camera("nanf", 64, 48);
    nan_focal.fx = f64::NAN;
    let mut zero_focal = camera("zerof", 64, 48);
    zero_focal.fy = 0.0;
    let mut nan_pose = camera("nanpose", 64, 48);
    nan_pose.translation.x = f64::NAN;
    // The camera list, what the error says, and which file of the COLMAP
    // model it names (intrinsics live in cameras.txt, poses and names in
    // images.txt).
    let cases: Vec<(Vec<Camera>, &str, &str)> = vec![
        (vec![camera("w0", 0, 48)], "zero side", "cameras.txt"),
        (vec![nan_focal], "focal length", "cameras.txt"),
        (vec![zero_focal], "focal length", "cameras.txt"),
        (vec![nan_pose], "NaN or infinite", "images.txt"),
        (
            vec![camera("same", 64, 48), camera("same", 64, 48)],
            "same name as camera 0",
            "images.txt",
        ),
    ];
    for (k, (cams, want, file)) in cases.into_iter().enumerate() {
        // COLMAP text model, written directly (our writer would refuse some).
        let model = dir.path().join(format!("colmap{k}"));
        std::fs::create_dir_all(&model).unwrap();
        let mut cameras_txt = String::new();
        let mut images_txt = String::new();
        for (i, c) in cams.iter().enumerate() {
            cameras_txt += &format!(
                "{} PINHOLE {} {} {} {} {} {}\n",
                i + 1,
                c.width,
                c.height,
                c.fx,
                c.fy,
                c.cx,
                c.cy
            );
            let t = c.translation;
            images_txt += &format!(
                "{} 1 0 0 0 {} {} {} {} {}\n\n",
                i + 1,
                t.x,
                t.y,
                t.z,
                i + 1,
                c.name
            );
        }
        std::fs::write(model.join("cameras.txt"), cameras_txt).unwrap();
        std::fs::write(model.join("images.txt"), images_txt).unwrap();
        std::fs::write(model.join("points3D.txt"), "").unwrap();
        let out = run(
            "render",
            &[s(&mesh), "--cameras", s(&model), "-o", s(&out_dir)],
            None,
        );
        let named = model.join(file);
        fails(&out, 1, &[s(&named), want]);
        assert!(!out_dir.exists());
        // The same cameras as cameras.json: refused too, by the reader or the checks.
        if cams
            .iter()
            .all(|c| c.width > 0 && c.fx.is_finite() && c.fy != 0.0)
        {
            let f = cameras_file(dir.path(), "cams.json", &cams);
            let out = run(
                "render",
                &[s(&mesh), "--cameras", s(&f), "-o", s(&out_dir)],
                None,
            );
            fails(&out, 1, &["cams.json"]);
            assert!(!out_dir.exists());
        }
    }
    // An image whose camera id the model lacks names images.txt and the image.
    let model = dir.path().join("colmap_missing_id");
    std::fs::create_dir_all(&model).unwrap();
    std::fs::write(model.join("cameras.txt"), "1 PINHOLE 64 48 50 50 32 24\n").unwrap();
    std::fs::write(model.join("images.txt"), "1 1 0 0 0 0 0 3 7 a.png\n\n").unwrap();
    let out = run(
        "render",
        &[s(&mesh), "--cameras", s(&model), "-o", s(&out_dir)],
        None,
    );
    fails(
        &out,
        1,
        &[s(&model.join("images.txt")), "'a.png'", "camera 7"],
    );
    assert!(!out_dir.exists());
    let empty = dir.path().join("empty.json");
    std::fs::write(&empty, "[]").unwrap();
    let out = run(
        "render",
        &[s(&mesh), "--cameras", s(&empty), "-o", s(&out_dir)],
        None,
    );
    fails(&out, 1, &["empty.json", "no cameras"]);
    assert!(!out_dir.exists());
}

/// `--threads` beyond the bound is a usage error, not a rayon panic or a
/// minute of thread start-up.
#[test]
fn thread_counts_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triangle_file(dir.path());
    let out_path = dir.path().join("out.ply");
    for n in ["0", "2000", "100000"] {
        let out = run(
            "clean",
            &[s(&mesh), "-o", s(&out_path), "--threads", n],
            None,
        );
        fails(&out, 2, &["--threads"]);
        assert!(!out_path.exists());
    }
}

/// Orbit counts and sizes: `--orbit 4294967295` and `--orbit 100000` are
/// refused at parse time; `--size 0x0` says zero and `--size 100000x100000`
/// the pixel limit; nothing is written.
#[test]
fn orbit_counts_and_sizes_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triangle_file(dir.path());
    let out_dir = dir.path().join("orbit");
    for n in ["4294967295", "100000", "0"] {
        let out = run(
            "render",
            &[s(&mesh), "--orbit", n, "--size", "8x8", "-o", s(&out_dir)],
            None,
        );
        fails(&out, 2, &["--orbit"]);
    }
    let out = run(
        "render",
        &[s(&mesh), "--orbit", "2", "--size", "0x0", "-o", s(&out_dir)],
        None,
    );
    fails(&out, 2, &["--size", "greater than zero"]);
    // Checked before the scene is read: a missing scene is not reached.
    let missing = dir.path().join("missing.ply");
    let out = run(
        "render",
        &[s(&missing), "--size", "0x0", "-o", s(&out_dir)],
        None,
    );
    fails(&out, 2, &["--size", "greater than zero"]);
    // splat2points' own orbit with --radius 0 blames the flag, not cameras.
    let g = dir.path().join("g.ply");
    std::fs::write(
        &g,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
         property float z\nproperty float opacity\nproperty float scale_0\nproperty float scale_1\n\
         property float scale_2\nproperty float rot_0\nproperty float rot_1\nproperty float rot_2\n\
         property float rot_3\nproperty float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n\
         end_header\n0 0 0 2 -3 -3 -3 1 0 0 0 0.5 0.5 0.5\n",
    )
    .unwrap();
    let pts = dir.path().join("pts.ply");
    let out = run(
        "splat2points",
        &[s(&g), "--orbit", "4", "--radius", "0", "-o", s(&pts)],
        None,
    );
    fails(&out, 2, &["--radius", "positive"]);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("camera"));
    assert!(!pts.exists());
    let out = run(
        "render",
        &[
            s(&mesh),
            "--orbit",
            "2",
            "--size",
            "100000x100000",
            "-o",
            s(&out_dir),
        ],
        None,
    );
    fails(
        &out,
        2,
        &["--size", "exceeds the limit of 268435456 pixels"],
    );
    assert!(!out_dir.exists());
}

/// Stdin is read once whatever its format (an OBJ piped into `chamfer -`
/// works), and `chamfer - -` is refused as a usage error.
#[test]
fn stdin_is_read_once() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("mesh.obj");
    let m = Mesh::new(
        vec![[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    save(&obj, &Scene::Mesh(m), FileFormat::Obj).unwrap();
    let pts = dir.path().join("pts.ply");
    let pc = PointCloud {
        positions: vec![[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.5, 0.0]],
        ..Default::default()
    };
    save(&pts, &Scene::PointCloud(pc), FileFormat::Ply).unwrap();
    let out = run(
        "chamfer",
        &["-", s(&pts), "--count", "1000", "--json"],
        Some(&obj),
    );
    succeeds(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["pred"], "<stdin>");
    assert_eq!(v["pred_points"], 1000);
    let out = run("chamfer", &["-", "-"], Some(&obj));
    fails(&out, 2, &["stdin is read once"]);
}

/// Numeric flags that would give a meaningless score or a silent fallback
/// are usage errors: `--max-dist 0`, `--spacing 0 / nan / inf`.
#[test]
fn chamfer_numeric_flags_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triangle_file(dir.path());
    for (flag, v) in [
        ("--max-dist", "0"),
        ("--max-dist", "-1"),
        ("--max-dist", "nan"),
        ("--spacing", "0"),
        ("--spacing", "nan"),
        ("--spacing", "inf"),
    ] {
        let arg = format!("{flag}={v}");
        let out = run("chamfer", &[s(&mesh), s(&mesh), &arg], None);
        fails(&out, 2, &[flag]);
    }
}

/// A run that fails on a bad output path fails before any work: the data
/// output already on disk is left as it was (`clean`, `decimate`,
/// `export-off`, `poisson`, `prune-triangles`, `splat2points` check `-o` and
/// `--json=FILE` first).
#[test]
fn a_bad_report_path_leaves_the_output_alone() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triangle_file(dir.path());
    let out_path = dir.path().join("out.ply");
    std::fs::write(&out_path, b"previous contents").unwrap();
    let missing = dir.path().join("missing_dir/r.json");
    let json_arg = format!("--json={}", missing.display());
    for (bin, extra) in [
        ("clean", vec![]),
        ("decimate", vec!["--faces", "1"]),
        ("export-off", vec![]),
        ("poisson", vec![]),
    ] {
        let mut args = vec![s(&mesh), "-o", s(&out_path), json_arg.as_str()];
        args.extend(extra);
        let out = run(bin, &args, None);
        fails(&out, 1, &["--json", "missing_dir", "does not exist"]);
        assert_eq!(
            std::fs::read(&out_path).unwrap(),
            b"previous contents",
            "{bin} replaced its output before failing"
        );
    }
    // An output inside a folder that does not exist: refused before reading.
    let nowhere = dir.path().join("nowhere/out.ply");
    let out = run("clean", &[s(&mesh), "-o", s(&nowhere)], None);
    fails(&out, 1, &["-o", "nowhere", "does not exist"]);
}

/// `render --compare DIR` with a missing ground truth fails before any
/// image is rendered or written: the output folder keeps what it held.
#[test]
fn render_compare_checks_ground_truth_first() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triangle_file(dir.path());
    let cams = cameras_file(dir.path(), "cameras.json", &[camera("a", 32, 24)]);
    let out_dir = dir.path().join("renders");
    std::fs::create_dir_all(&out_dir).unwrap();
    std::fs::write(out_dir.join("a.png"), b"previous").unwrap();
    let gt = dir.path().join("gt");
    std::fs::create_dir_all(&gt).unwrap();
    let out = run(
        "render",
        &[
            s(&mesh),
            "--cameras",
            s(&cams),
            "-o",
            s(&out_dir),
            "--compare",
            s(&gt),
        ],
        None,
    );
    fails(&out, 1, &["no ground-truth PNG", "gt"]);
    assert_eq!(std::fs::read(out_dir.join("a.png")).unwrap(), b"previous");
}

/// Numeric flags are checked when parsed (exit 2, naming the flag): NaN,
/// infinities, zero where meaningless, out-of-range counts.
#[test]
fn numeric_flags_are_checked_at_parse_time() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triangle_file(dir.path());
    let out_path = dir.path().join("out.ply");
    let cases: &[(&str, &str)] = &[
        ("poisson", "--point-weight=inf"),
        ("poisson", "--point-weight=-1"),
        ("poisson", "--trim=nan"),
        ("poisson", "--trim-quantile=1.5"),
        ("poisson", "--iters=4294967295"),
        ("poisson", "--iters=0"),
        ("poisson", "--samples-per-node=0"),
        ("poisson", "--width=nan"),
        ("render", "--near=nan"),
        ("render", "--depth-scale=0"),
        ("splat2points", "--min-opacity=nan"),
        ("splat2points", "--max-points=9223372036854775808"),
        ("splat2points", "--max-points=0"),
    ];
    for (bin, arg) in cases {
        let out = run(bin, &[s(&mesh), arg, "-o", s(&out_path)], None);
        let flag = arg.split('=').next().unwrap();
        fails(&out, 2, &[flag]);
        assert!(!out_path.exists(), "{bin} {arg} wrote output");
    }
}

/// A DTU evaluation whose inputs cannot give a score is an error naming
/// the file and what is wrong, never `overall NaN` with exit 0: an
/// inverted ObsMask bounding box, a NaN plane, an empty STL, a prediction
/// outside the observed volume.
#[test]
fn dtu_inputs_without_a_meaningful_score_are_errors() {
    use splatkit::io::dtu::{ObsMask, write_obs_mask, write_plane};
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("dtu");
    std::fs::create_dir_all(root.join("Points/stl")).unwrap();
    std::fs::create_dir_all(root.join("ObsMask")).unwrap();
    let grid: Vec<[f32; 3]> = (0..100)
        .map(|i| [(i % 10) as f32, (i / 10) as f32, 1.0])
        .collect();
    let stl = root.join("Points/stl/stl024_total.ply");
    let good_mask = ObsMask {
        mask: vec![1; 12 * 12 * 4],
        dims: [12, 12, 4],
        bb: [[-1.0, -1.0, -1.0], [11.0, 11.0, 3.0]],
        res: 1.0,
    };
    let write_all = |stl_pts: &[[f32; 3]], mask: &ObsMask, plane: [f64; 4]| {
        let pc = PointCloud {
            positions: stl_pts.to_vec(),
            ..Default::default()
        };
        save(&stl, &Scene::PointCloud(pc), FileFormat::Ply).unwrap();
        write_obs_mask(&root.join("ObsMask/ObsMask24_10.mat"), mask).unwrap();
        write_plane(&root.join("ObsMask/Plane24.mat"), plane).unwrap();
    };
    let pred = dir.path().join("pred.ply");
    let near = PointCloud {
        positions: grid.iter().map(|p| [p[0] + 0.1, p[1], p[2]]).collect(),
        ..Default::default()
    };
    save(&pred, &Scene::PointCloud(near), FileFormat::Ply).unwrap();
    let dtu = |extra: &[&str]| {
        let mut a = vec![
            "--protocol",
            "dtu",
            "--scan",
            "24",
            "--pcd",
            "--dataset-dir",
            s(&root),
            s(&pred),
        ];
        a.extend_from_slice(extra);
        run("chamfer", &a, None)
    };
    // The well-formed case scores (so the failures below are about the inputs).
    write_all(&grid, &good_mask, [0.0, 0.0, 1.0, 0.0]);
    let ok = dtu(&["--json"]);
    succeeds(&ok);
    let v: serde_json::Value = serde_json::from_slice(&ok.stdout).unwrap();
    assert!(v["overall"].as_f64().unwrap().is_finite());

    let mut inverted = good_mask.clone();
    inverted.bb = [[11.0, -1.0, -1.0], [-1.0, 11.0, 3.0]];
    write_all(&grid, &inverted, [0.0, 0.0, 1.0, 0.0]);
    fails(&dtu(&[]), 1, &["ObsMask24_10.mat", "inverted bounding box"]);

    write_all(&grid, &good_mask, [f64::NAN, 0.0, 1.0, 0.0]);
    fails(&dtu(&[]), 1, &["Plane24.mat", "not a plane"]);

    write_all(&[], &good_mask, [0.0, 0.0, 1.0, 0.0]);
    fails(&dtu(&[]), 1, &["stl024_total.ply", "no points"]);

    write_all(&grid, &good_mask, [0.0, 0.0, 1.0, 0.0]);
    let far = PointCloud {
        positions: grid.iter().map(|p| [p[0] + 1000.0, p[1], p[2]]).collect(),
        ..Default::default()
    };
    save(&pred, &Scene::PointCloud(far), FileFormat::Ply).unwrap();
    fails(&dtu(&[]), 1, &["pred.ply", "observed volume"]);
    // A failing evaluation leaves a --vis-dir as it was.
    let vis = dir.path().join("vis");
    std::fs::create_dir_all(&vis).unwrap();
    std::fs::write(vis.join("vis_024_d2s.ply"), b"previous").unwrap();
    fails(
        &dtu(&["--vis-dir", s(&vis)]),
        1,
        &["pred.ply", "observed volume"],
    );
    assert_eq!(
        std::fs::read(vis.join("vis_024_d2s.ply")).unwrap(),
        b"previous"
    );
    assert!(!vis.join("vis_024_s2d.ply").exists());
    assert!(leftovers(dir.path()).is_empty());

    // A mesh prediction whose DTU up-sampling cannot fit: refused up front.
    let big = dir.path().join("big.ply");
    save(&big, &Scene::Mesh(big_triangle()), FileFormat::Ply).unwrap();
    let out = run(
        "chamfer",
        &[
            "--protocol",
            "dtu",
            "--scan",
            "24",
            "--dataset-dir",
            s(&root),
            s(&big),
        ],
        None,
    );
    fails(&out, 1, &["prediction", "big.ply", "--max-samples"]);
}

/// One triangle 10⁴ units across.
fn big_triangle() -> Mesh {
    Mesh::new(
        vec![[0.0, 0.0, 0.0], [1.0e4, 0.0, 0.0], [0.0, 1.0e4, 0.0]],
        vec![[0, 1, 2]],
    )
}

/// Sampling that would not fit in memory is refused before it starts,
/// naming the side and the file: the DTU up-sampling of a huge triangle,
/// a tiny `--spacing`, an enormous `--count`.
#[test]
fn sample_counts_are_estimated_and_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.ply");
    save(&big, &Scene::Mesh(big_triangle()), FileFormat::Ply).unwrap();
    let small = triangle_file(dir.path());
    for (args, side) in [
        (vec![s(&big), s(&small), "--sample", "dtu"], "prediction"),
        (vec![s(&small), s(&big), "--sample", "dtu"], "ground truth"),
        (
            vec![s(&small), s(&small), "--sample", "dtu", "--spacing", "1e-6"],
            "prediction",
        ),
        (
            vec![s(&small), s(&small), "--count", "300000000"],
            "prediction",
        ),
    ] {
        let out = run("chamfer", &args, None);
        fails(&out, 1, &[side, "--max-samples"]);
    }
    // Raising --max-samples past memory does not lift the budget (the
    // fuzzer's `--count 4294967295 --max-samples 4294967295` aborted
    // allocating 103 GB): refused with the estimate and the budget.
    let out = run(
        "chamfer",
        &[
            s(&small),
            s(&big),
            "--count",
            "4294967295",
            "--max-samples",
            "4294967295",
        ],
        None,
    );
    fails(&out, 1, &["prediction", "--count", "memory budget"]);
    // Within the bound, the same files evaluate.
    let out = run("chamfer", &[s(&small), s(&small), "--count", "1000"], None);
    succeeds(&out);
}

/// A zero-byte or garbage `.obj` is not an empty mesh that commands
/// happily process: it is an error naming the file.
#[test]
fn empty_or_garbage_obj_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("out.ply");
    for (name, bytes) in [
        ("empty.obj", &b""[..]),
        ("garbage.obj", &b"\x00\x01hello world\nnot an obj\n"[..]),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        for bin in ["clean", "decimate", "export-off"] {
            let mut args = vec![s(&p), "-o", s(&out_path)];
            if bin == "decimate" {
                args.extend(["--faces", "1"]);
            }
            let out = run(bin, &args, None);
            fails(&out, 1, &[name]);
            assert!(!out_path.exists(), "{bin} wrote output for {name}");
        }
    }
}

/// Names in `dir` that look like a staging folder left behind.
fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".splatkit-"))
        .collect()
}

fn png(path: &Path, w: usize, h: usize) {
    let mut f = std::fs::File::create(path).unwrap();
    splatkit::io::image::write_png8(&mut f, "gt", w, h, 3, &vec![128; w * h * 3]).unwrap();
}

/// `render -o DIR` is all or nothing: a run that fails after rendering some
/// views (here the second ground-truth image has the wrong size) leaves the
/// folder exactly as it was and no staging folder behind; a run that
/// succeeds replaces the files it writes and keeps the others.
#[test]
fn folder_outputs_are_all_or_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triangle_file(dir.path());
    let cams = cameras_file(
        dir.path(),
        "cameras.json",
        &[camera("a", 32, 24), camera("b", 32, 24)],
    );
    let out_dir = dir.path().join("renders");
    std::fs::create_dir_all(&out_dir).unwrap();
    std::fs::write(out_dir.join("a.png"), b"previous").unwrap();
    std::fs::write(out_dir.join("notes.txt"), b"keep").unwrap();
    let gt = dir.path().join("gt");
    std::fs::create_dir_all(&gt).unwrap();
    png(&gt.join("a.png"), 32, 24);
    png(&gt.join("b.png"), 16, 16);
    let args = [
        s(&mesh),
        "--cameras",
        s(&cams),
        "-o",
        s(&out_dir),
        "--compare",
        s(&gt),
    ];
    let out = run("render", &args, None);
    fails(&out, 1, &["b.png", "16x16 pixels"]);
    assert_eq!(std::fs::read(out_dir.join("a.png")).unwrap(), b"previous");
    assert!(!out_dir.join("b.png").exists());
    assert!(
        leftovers(dir.path()).is_empty(),
        "{:?}",
        leftovers(dir.path())
    );
    // The same into a folder that does not exist yet: not created.
    let fresh = dir.path().join("fresh");
    let mut fresh_args = args;
    fresh_args[4] = s(&fresh);
    fails(&run("render", &fresh_args, None), 1, &["b.png"]);
    assert!(!fresh.exists());
    assert!(leftovers(dir.path()).is_empty());
    // With a right-sized image the run succeeds and commits.
    png(&gt.join("b.png"), 32, 24);
    let out = run("render", &args, None);
    succeeds(&out);
    assert!(
        std::fs::read(out_dir.join("a.png"))
            .unwrap()
            .starts_with(b"\x89PNG")
    );
    assert!(out_dir.join("b.png").exists());
    assert_eq!(std::fs::read(out_dir.join("notes.txt")).unwrap(), b"keep");
    assert!(leftovers(dir.path()).is_empty());
}

/// A `.pt` whose compressed storage record inflates far past what its
/// tensors need (a small archive claiming 16 MB for a few hundred bytes of
/// tensors) is refused before inflating, naming the file, by every command
/// that reads it.
#[test]
fn decompression_is_capped_by_the_declared_tensors() {
    use std::io::{Read, Write};
    let dir = tempfile::tempdir().unwrap();
    let (soup, _) = splatkit::geom::scenes::synthetic::demo_soup(1, 4);
    let stored = dir.path().join("stored.pt");
    save(&stored, &Scene::TriangleSoup(soup), FileFormat::TorchPt).unwrap();
    let bytes = std::fs::read(&stored).unwrap();
    let mut src = zip::ZipArchive::new(std::io::Cursor::new(&bytes[..])).unwrap();
    let bomb = dir.path().join("bomb.pt");
    {
        let mut w = zip::ZipWriter::new(std::fs::File::create(&bomb).unwrap());
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        for i in 0..src.len() {
            let mut f = src.by_index(i).unwrap();
            let name = f.name().unwrap().to_string();
            let mut data = Vec::new();
            f.read_to_end(&mut data).unwrap();
            w.start_file(name.as_str(), opts).unwrap();
            w.write_all(&data).unwrap();
            if name.ends_with("/data/0") {
                let zeros = vec![0u8; 1 << 20];
                for _ in 0..16 {
                    w.write_all(&zeros).unwrap();
                }
            }
        }
        w.finish().unwrap();
    }
    assert!(std::fs::metadata(&bomb).unwrap().len() < 1 << 20);
    fails(
        &run("info", &[s(&bomb)], None),
        1,
        &["bomb.pt", "needs at most"],
    );
    let out_path = dir.path().join("out.ply");
    fails(
        &run("prune-triangles", &[s(&bomb), "-o", s(&out_path)], None),
        1,
        &["bomb.pt", "needs at most"],
    );
    assert!(!out_path.exists());
}

/// A `.gltf` whose buffer is a separate file next to it (a relative URI) is
/// read through the path it was given, from any working folder.
#[test]
fn gltf_relative_external_buffers_resolve() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("model");
    std::fs::create_dir_all(&sub).unwrap();
    let mut bin = Vec::new();
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    bin.extend_from_slice(&[0, 0]);
    std::fs::write(sub.join("tri.bin"), &bin).unwrap();
    let gltf = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
"buffers":[{"uri":"tri.bin","byteLength":44}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]}"#;
    std::fs::write(sub.join("tri.gltf"), gltf).unwrap();
    let out = std::process::Command::new(assert_cmd::cargo::cargo_bin("info"))
        .arg(sub.join("tri.gltf"))
        .arg("--json")
        .current_dir(std::env::temp_dir())
        .output()
        .unwrap();
    succeeds(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (v[0]["vertices"].as_u64(), v[0]["faces"].as_u64()),
        (Some(3), Some(1))
    );
    // A missing buffer file is named (once, without a doubled prefix).
    std::fs::remove_file(sub.join("tri.bin")).unwrap();
    let out = run("info", &[s(&sub.join("tri.gltf"))], None);
    fails(&out, 1, &["tri.bin"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("invalid glTF: invalid glTF"), "{err}");
}

/// Chamfer's load errors say which side failed: the prediction or the
/// ground truth.
#[test]
fn chamfer_errors_name_the_side() {
    let dir = tempfile::tempdir().unwrap();
    let good = triangle_file(dir.path());
    let bad = dir.path().join("garbage.obj");
    std::fs::write(&bad, b"\x00\x01 not a mesh\n").unwrap();
    fails(
        &run("chamfer", &[s(&bad), s(&good)], None),
        1,
        &["prediction", "garbage.obj"],
    );
    fails(
        &run("chamfer", &[s(&good), s(&bad)], None),
        1,
        &["ground truth", "garbage.obj"],
    );
}

/// Commands that need triangles refuse point clouds and Gaussian PLYs
/// (which used to give a 0-face output with exit 0), saying what they take.
#[test]
fn mesh_commands_refuse_points_and_gaussians() {
    let dir = tempfile::tempdir().unwrap();
    let pts = dir.path().join("points.ply");
    let pc = PointCloud {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        ..Default::default()
    };
    save(&pts, &Scene::PointCloud(pc), FileFormat::Ply).unwrap();
    let out_path = dir.path().join("out.ply");
    for bin in ["clean", "decimate"] {
        let mut args = vec![s(&pts), "-o", s(&out_path)];
        if bin == "decimate" {
            args.extend(["--faces", "1"]);
        }
        fails(
            &run(bin, &args, None),
            1,
            &["points.ply", bin, "takes", "point cloud"],
        );
        assert!(!out_path.exists());
    }
}

// Issue 23: one file per promise, each run under the same 2 GB limit.
#[path = "hostile/budget.rs"]
mod budget;
#[path = "hostile/empty.rs"]
mod empty;
#[path = "hostile/finite.rs"]
mod finite;
#[path = "hostile/inputs.rs"]
mod inputs;
#[path = "hostile/messages.rs"]
mod messages;
#[path = "hostile/reads.rs"]
mod reads;
#[path = "hostile/splats.rs"]
mod splats;
#[path = "hostile/transaction.rs"]
mod transaction;
