//! Issue 23, item 7: messages name the file (for `chamfer` also the side:
//! prediction / ground truth), the element and the flag; a numeric flag
//! whose value has no meaning is refused when parsed (exit 2), before any
//! input is read or output written.

use super::common::{cameras_file, fails, mesh_file, run, s, snapshot, succeeds, triangle};

use splatkit::io::any::save;
use splatkit::io::detect::FileFormat;
use splatkit::model::{Gaussians, Mesh, PointCloud, Scene};
use splatkit::testing::{cameras_around, write_sphere_dataset};

/// A mesh whose only face has zero area (collinear corners).
fn flat() -> Mesh {
    Mesh::new(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        vec![[0, 1, 2]],
    )
}

/// `chamfer` cannot sample a mesh of zero area: the message names the file
/// and its side, whichever side it is on.
#[test]
fn chamfer_zero_area_names_file_and_side() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = mesh_file(d, "good.ply", triangle());
    let bad = mesh_file(d, "flat.ply", flat());
    let before = snapshot(d);
    for (pred, gt, side) in [(&bad, &good, "prediction"), (&good, &bad, "ground truth")] {
        let o = run("chamfer", &[s(pred), s(gt), "--count", "100"], None);
        fails(&o, 1, &[&format!("{side} "), "flat.ply", "total area is 0"]);
        assert_eq!(snapshot(d), before);
    }
}

/// `splat2points` whose rays never cross `--level` names the scene file
/// and the level.
#[test]
fn splat2points_no_crossing_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cams = cameras_file(d, "cameras.json", &cameras_around(3, 4.0, 24, 30.0));
    // one Gaussian of opacity 0.51: its density never reaches 0.9
    let g = Gaussians {
        means: vec![[0.0; 3]],
        normals: None,
        sh_degree: 0,
        sh_dc: vec![[0.5; 3]],
        sh_rest: Vec::new(),
        opacity_logits: vec![0.04],
        log_scales: vec![[-1.0; 3]],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]],
        extras: Default::default(),
    };
    let scene = d.join("faint.ply");
    save(&scene, &Scene::Gaussians(g), FileFormat::Ply).unwrap();
    let out = d.join("points.ply");
    let o = run(
        "splat2points",
        &[
            s(&scene),
            "--cameras",
            s(&cams),
            "--all-views",
            "--level",
            "0.9",
            "-o",
            s(&out),
        ],
        None,
    );
    fails(&o, 1, &["faint.ply", "no ray crossed", "--level 0.9"]);
    assert!(!out.exists(), "no output for a run that made no point");
}

/// `train` with a non-finite seed point names the file it came from
/// (`input.ply`), whether the reader or the initialisation finds it.
#[test]
fn train_seed_error_names_the_points_file() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    write_sphere_dataset(&data, 4, 16, 20).unwrap();
    let mut pc = splatkit::testing::sphere_points(20, 3);
    pc.positions[0] = [f32::NAN, 0.0, 0.0];
    save(
        &data.join("input.ply"),
        &Scene::PointCloud(pc),
        FileFormat::Ply,
    )
    .unwrap();
    let out = dir.path().join("out");
    let before = snapshot(dir.path());
    for model in ["triangles", "gaussians"] {
        let o = run(
            "train",
            &[model, s(&data), "-o", s(&out), "--iterations", "2", "-q"],
            None,
        );
        fails(&o, 1, &["input.ply", "finite"]);
        assert_eq!(snapshot(dir.path()), before);
    }
}

/// `poisson --width W` too fine for 16 octree levels says that `--width`
/// implies the depth, and the smallest width that fits.
#[test]
fn poisson_width_is_named_for_its_depth() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let pts = d.join("pts.ply");
    let pc = PointCloud {
        positions: (0..8)
            .map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32])
            .collect(),
        normals: Some(vec![[0.0, 0.0, 1.0]; 8]),
        ..Default::default()
    };
    save(&pts, &Scene::PointCloud(pc), FileFormat::Ply).unwrap();
    let out = d.join("mesh.ply");
    let o = run(
        "poisson",
        &[s(&pts), "--width", "1e-9", "-o", s(&out)],
        None,
    );
    fails(&o, 1, &["--width 1e-9", "depth", "2..=16", "at least"]);
    assert!(!out.exists());
}

/// An `--orbit` that cannot frame the scene (a radius below the rounding
/// step of the scene's coordinates puts every eye on the centre) is refused
/// naming the scene and the orbit, before any camera or picture is written
/// (it used to fail only at the camera writer, naming no file).
#[test]
fn render_degenerate_orbit_names_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = mesh_file(d, "far.ply", {
        let mut m = triangle();
        for p in &mut m.vertices {
            p[0] += 1.0e6;
        }
        m
    });
    let out = d.join("rend");
    let before = snapshot(d);
    let o = run(
        "render",
        &[
            s(&scene),
            "--orbit",
            "2",
            "--size",
            "16x12",
            "--radius",
            "1e-12",
            "-o",
            s(&out),
        ],
        None,
    );
    fails(
        &o,
        1,
        &["far.ply", "--orbit", "radius", "no viewing direction"],
    );
    assert_eq!(snapshot(d), before);
}

/// Numeric flags with no meaning — NaN, out of range, zero where nothing
/// would come out — are refused at parse (exit 2, naming the flag), before
/// any file is read: the inputs named here do not even exist.
#[test]
fn bad_flag_values_fail_at_parse() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out");
    let o = s(&out);
    // (command, its arguments split at spaces, the flag named)
    let cases = [
        ("decimate", "m.ply --ratio NaN", "--ratio"),
        ("decimate", "m.ply --ratio 1.5", "--ratio"),
        ("decimate", "m.ply --ratio=-0.5", "--ratio"),
        ("poisson", "p.ply --depth 30", "--depth"),
        ("poisson", "p.ply --depth 1", "--depth"),
        ("poisson", "p.ply --full-depth 17", "--full-depth"),
        ("poisson", "p.ply --bbox 1,2,3", "--bbox"),
        ("poisson", "p.ply --bbox=0,0,0,-1,1,1", "--bbox"),
        ("poisson", "p.ply --bbox 0,0,0,nan,1,1", "--bbox"),
        (
            "clean",
            "m.ply --min-component-area nan",
            "--min-component-area",
        ),
        (
            "clean",
            "m.ply --min-component-area 2",
            "--min-component-area",
        ),
        (
            "prune-triangles",
            "s.ply --min-opacity 1.5",
            "--min-opacity",
        ),
        (
            "prune-triangles",
            "s.ply --min-opacity nan",
            "--min-opacity",
        ),
        ("prune-triangles", "s.ply --max-sigma 0", "--max-sigma"),
        ("prune-triangles", "s.ply --max-sigma inf", "--max-sigma"),
        ("chamfer", "a.ply b.ply --count 0", "--count"),
        ("chamfer", "a.ply b.ply --tau 0.1,nan", "--tau"),
        ("chamfer", "a.ply b.ply --tau=-1", "--tau"),
        ("train", "triangles data --max-shapes 0", "--max-shapes"),
        ("train", "gaussians data --resolution 0", "--resolution"),
        (
            "refine",
            "b.ply --images i --cameras c.json --resolution 0",
            "--resolution",
        ),
        ("train", "gaussians data --test-every 1", "--test-every"),
        (
            "splat2points",
            "g.ply --every-nth-test 1",
            "--every-nth-test",
        ),
        (
            "refine",
            "b.ply --images i --cameras c.json --test-every 1",
            "--test-every",
        ),
    ];
    for (bin, args, flag) in cases {
        let mut a: Vec<&str> = args.split(' ').collect();
        if bin != "chamfer" {
            a.extend(["-o", o]);
        }
        let r = run(bin, &a, None);
        // clap's own error: exit 2, the flag named, nothing read or written
        fails(&r, 2, &[flag]);
        assert!(!out.exists(), "{bin} {args:?} wrote output");
    }
}

/// `train MODEL DATA -o OUT --iterations 2 -q` plus `extra`, on a 4-view
/// sphere data set in `dir/data` (written unless present); `dir/out` is OUT.
fn train_tiny(dir: &std::path::Path, model: &str, extra: &[&str]) -> std::process::Output {
    let data = dir.join("data");
    if !data.exists() {
        write_sphere_dataset(&data, 4, 16, 20).unwrap();
    }
    let out = dir.join("out");
    let mut a = vec![model, s(&data), "-o", s(&out), "--iterations", "2", "-q"];
    a.extend(extra);
    run("train", &a, None)
}

/// A checkpoint whose `state.json` has undecodable `evals` is named in the
/// message (the fuzzer found "checkpoint state.json: evals: missing field
/// `iteration`", which named no file); the folder is left as it was.
#[test]
fn resume_with_bad_evals_names_the_state_file() {
    let dir = tempfile::tempdir().unwrap();
    let o = train_tiny(dir.path(), "gaussians", &[]);
    succeeds(&o);
    let out = dir.path().join("out");
    let state = out.join("checkpoint/state.json");
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&state).unwrap()).unwrap();
    v["evals"] = serde_json::json!([{"psnr": 1.0}]);
    std::fs::write(&state, v.to_string()).unwrap();
    let before = snapshot(dir.path());
    let o = train_tiny(dir.path(), "gaussians", &["--resume", s(&out)]);
    fails(&o, 1, &["checkpoint/state.json", "evals"]);
    assert_eq!(snapshot(dir.path()), before);
}

/// A camera file whose rotations a reader accepts (within its 1e-4
/// tolerance) is also written back: `train` writes the training cameras to
/// OUT/cameras.json, and a rotation 4e-6 off orthonormal used to be refused
/// there by the writers' tighter 1e-6 check ("camera 'v00': rotation is not
/// orthonormal", naming no file; found by the command fuzzer).
#[test]
fn cameras_a_reader_accepts_are_written_back() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    write_sphere_dataset(&data, 4, 16, 20).unwrap();
    let path = data.join("cameras.json");
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    // row 0 scaled by 1 + 4e-6: |RᵀR − I| ≥ 8e-6 · max r0j² ≥ 2.7e-6
    for r in v[0]["rotation"][0].as_array_mut().unwrap() {
        *r = serde_json::json!(r.as_f64().unwrap() * (1.0 + 4e-6));
    }
    std::fs::write(&path, v.to_string()).unwrap();
    let o = train_tiny(dir.path(), "triangles", &[]);
    succeeds(&o);
    assert!(dir.path().join("out/cameras.json").is_file());
}
