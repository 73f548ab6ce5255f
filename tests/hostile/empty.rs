//! Issue 23, item 6: an empty or meaningless result is an error by default
//! (exit 1, every pre-existing output byte-identical, every input too), the
//! message saying what came out empty and which flag or input caused it;
//! `--allow-empty` (clean, prune-triangles, export-off, poisson) writes the
//! empty file instead. Metrics over zero pixels are refused up front.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::common::{cameras_file, fails, mesh_file, run, s, snapshot, succeeds};

use splatkit::io::any::save;
use splatkit::io::cameras::write_gs_json;
use splatkit::io::detect::FileFormat;
use splatkit::model::{Gaussians, Mesh, PointCloud, Scene, TriangleSoup};
use splatkit::testing::{cameras_around, uv_sphere, write_sphere_dataset};

/// What an output held before a run that must leave it alone.
const BEFORE: &[u8] = b"previous contents";

/// An output file holding [`BEFORE`].
fn existing(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, BEFORE).unwrap();
    p
}

/// A closed tetrahedron (one component, 4 faces, area > 0).
fn tetrahedron() -> Mesh {
    Mesh::new(
        vec![
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    )
}

/// `n` Gaussians on a small grid about the origin, opacity 0.95.
fn gaussians(n: usize) -> Gaussians {
    Gaussians {
        means: (0..n)
            .map(|i| [(i % 5) as f32 * 0.2 - 0.4, (i / 5) as f32 * 0.2 - 0.4, 0.0])
            .collect(),
        normals: None,
        sh_degree: 0,
        sh_dc: vec![[0.5; 3]; n],
        sh_rest: Vec::new(),
        opacity_logits: vec![3.0; n],
        log_scales: vec![[-2.5; 3]; n],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        extras: Default::default(),
    }
}

fn gaussians_file(dir: &Path, name: &str, g: Gaussians) -> PathBuf {
    let p = dir.join(name);
    save(&p, &Scene::Gaussians(g), FileFormat::Ply).unwrap();
    p
}

/// Five triangle splats of activated opacity sigmoid(-1) ≈ 0.27.
fn soup_file(dir: &Path) -> PathBuf {
    let n = 5;
    let soup = TriangleSoup {
        triangles: (0..n)
            .map(|i| {
                let x = i as f32;
                [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 1.0, 0.0]]
            })
            .collect(),
        opacity_raw: vec![-1.0; n],
        sigma_raw: vec![-2.0; n],
        sh_degree: 0,
        active_sh_degree: 0,
        sh_dc: vec![[0.5; 3]; n],
        sh_rest: Vec::new(),
        extras: Default::default(),
    };
    let p = dir.join("soup.ply");
    save(&p, &Scene::TriangleSoup(soup), FileFormat::Ply).unwrap();
    p
}

/// Asserts that nothing under `dir` changed since `before` and that each
/// of `outputs` still holds [`BEFORE`].
fn untouched(before: &BTreeMap<PathBuf, Vec<u8>>, dir: &Path, outputs: &[&Path]) {
    assert_eq!(&snapshot(dir), before, "an input or output changed");
    for o in outputs {
        assert_eq!(
            std::fs::read(o).unwrap(),
            BEFORE,
            "{} replaced",
            o.display()
        );
    }
}

/// `clean` down to 0 faces — all faces degenerate, all vertices NaN,
/// `--keep-largest 0`, a component filter that removes everything — is
/// exit 1 naming the cause; `--allow-empty` writes the empty mesh.
#[test]
fn clean_to_no_faces() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let degen = mesh_file(
        d,
        "degen.ply",
        Mesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            vec![[0, 1, 2], [0, 0, 1]],
        ),
    );
    let nan = mesh_file(
        d,
        "nan.ply",
        Mesh::new(
            vec![[f32::NAN; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        ),
    );
    let tet = mesh_file(d, "tet.ply", tetrahedron());
    let out = existing(d, "out.ply");
    let before = snapshot(d);
    let cases: &[(&Path, &[&str], &[&str])] = &[
        (&degen, &[], &["degen.ply", "degenerate", "--allow-empty"]),
        (
            &tet,
            &["--keep-largest", "0"],
            &["--keep-largest 0", "--allow-empty"],
        ),
        (
            &tet,
            &["--min-component-faces", "10"],
            &["tet.ply", "--min-component-faces 10", "--allow-empty"],
        ),
        // a NaN vertex: refused by the reader or cleaned away as degenerate
        (&nan, &[], &["nan.ply"]),
    ];
    for (input, extra, needles) in cases {
        let mut a = vec![s(input), "-o", s(&out)];
        a.extend(extra.iter());
        // exit 1: the output would hold no face, so nothing is written
        fails(&run("clean", &a, None), 1, needles);
        untouched(&before, d, &[&out]);
    }
    // --allow-empty: the empty mesh is what the caller asked for
    let out = run(
        "clean",
        &[s(&degen), "-o", s(&d.join("empty.ply")), "--allow-empty"],
        None,
    );
    succeeds(&out);
    let text = std::fs::read(d.join("empty.ply")).unwrap();
    assert!(
        String::from_utf8_lossy(&text).contains("element face 0"),
        "an empty mesh written"
    );
}

/// `decimate` to nothing (`--faces 0`, `--vertices 0` or 2, `--ratio 0`)
/// is exit 1 naming the flag, before the input is read (the simplifier
/// used to return the mesh unchanged, exit 0).
#[test]
fn decimate_to_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tet = mesh_file(d, "tet.ply", tetrahedron());
    let out = existing(d, "out.ply");
    let before = snapshot(d);
    for (flag, v) in [
        ("--faces", "0"),
        ("--vertices", "0"),
        ("--vertices", "2"),
        ("--ratio", "0"),
    ] {
        let o = run("decimate", &[s(&tet), flag, v, "-o", s(&out)], None);
        // the target itself asks for an empty mesh
        fails(&o, 1, &[&format!("{flag} {v}"), "empty"]);
        untouched(&before, d, &[&out]);
    }
}

/// `prune-triangles` keeping nothing and `export-off` of a soup with no
/// triangle are exit 1 naming the flag / file; with `--allow-empty` both
/// write their empty file, so a batch pipeline can carry on.
#[test]
fn prune_and_export_of_no_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let soup = soup_file(d);
    let out = existing(d, "out.ply");
    let off = existing(d, "out.off");
    let before = snapshot(d);
    for (extra, needles) in [
        (
            vec!["--min-opacity", "0.5"],
            vec!["soup.ply", "--min-opacity 0.5", "--allow-empty"],
        ),
        (
            vec!["--max-count", "0"],
            vec!["--max-count 0", "--allow-empty"],
        ),
    ] {
        let mut a = vec![s(&soup), "-o", s(&out)];
        a.extend(extra);
        // every triangle is below the threshold: nothing would be kept
        fails(&run("prune-triangles", &a, None), 1, &needles);
        untouched(&before, d, &[&out, &off]);
    }
    let empty = d.join("empty.ply");
    succeeds(&run(
        "prune-triangles",
        &[
            s(&soup),
            "--min-opacity",
            "0.5",
            "-o",
            s(&empty),
            "--allow-empty",
        ],
        None,
    ));
    let before = snapshot(d);
    // the empty soup, exported: no triangle to write
    fails(
        &run("export-off", &[s(&empty), "-o", s(&off)], None),
        1,
        &["empty.ply", "no triangles", "--allow-empty"],
    );
    untouched(&before, d, &[&out, &off]);
    let empty_off = d.join("empty.off");
    succeeds(&run(
        "export-off",
        &[s(&empty), "-o", s(&empty_off), "--allow-empty"],
        None,
    ));
    // an OFF header (COFF: create_off.py's face colours) with 0 vertices and faces
    let text = String::from_utf8(std::fs::read(&empty_off).unwrap()).unwrap();
    assert!(text.contains("OFF\n0 0 0"), "{text:?}");
}

/// `render` of a scene with no primitive is exit 1 naming the file; the
/// output folder keeps what it held.
#[test]
fn render_of_no_primitives() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let g = gaussians_file(d, "none.ply", gaussians(0));
    let cams = cameras_file(d, "cameras.json", &cameras_around(2, 4.0, 16, 20.0));
    let out_dir = d.join("renders");
    std::fs::create_dir_all(&out_dir).unwrap();
    let old = existing(&out_dir, "v00.png");
    let before = snapshot(d);
    let o = run(
        "render",
        &[s(&g), "--cameras", s(&cams), "-o", s(&out_dir)],
        None,
    );
    // background-only pictures are not a render of the scene
    fails(&o, 1, &["none.ply", "no gaussians"]);
    untouched(&before, d, &[&old]);
}

/// `tsdf-fuse` of a scene with no primitive names the file (it used to
/// blame `--sdf-trunc`); the output is left as it was.
#[test]
fn fusion_of_no_primitives() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let g = gaussians_file(d, "none.ply", gaussians(0));
    let cams = cameras_file(d, "cameras.json", &cameras_around(2, 4.0, 16, 20.0));
    let out = existing(d, "fused.ply");
    let before = snapshot(d);
    let o = run(
        "tsdf-fuse",
        &[s(&g), "--cameras", s(&cams), "-o", s(&out)],
        None,
    );
    // no depth can come from nothing
    fails(&o, 1, &["none.ply", "no primitives"]);
    untouched(&before, d, &[&out]);
}

/// `poisson --trim` above every density leaves no face: exit 1 naming
/// `--trim`; `--allow-empty` writes the empty mesh.
#[test]
fn poisson_trimmed_to_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let n = 500;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let positions: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            [(r * a.cos()) as f32, (r * a.sin()) as f32, z as f32]
        })
        .collect();
    let pc = PointCloud {
        normals: Some(positions.clone()),
        positions,
        ..Default::default()
    };
    let pts = d.join("pts.ply");
    save(&pts, &Scene::PointCloud(pc), FileFormat::Ply).unwrap();
    let out = existing(d, "mesh.ply");
    let before = snapshot(d);
    let o = run(
        "poisson",
        &[s(&pts), "--depth", "5", "--trim", "1e30", "-o", s(&out)],
        None,
    );
    // the density threshold removes every face
    fails(&o, 1, &["pts.ply", "--trim 1e30", "--allow-empty"]);
    untouched(&before, d, &[&out]);
    let empty = d.join("empty.ply");
    succeeds(&run(
        "poisson",
        &[
            s(&pts),
            "--depth",
            "5",
            "--trim",
            "1e30",
            "-o",
            s(&empty),
            "--allow-empty",
        ],
        None,
    ));
    assert!(String::from_utf8_lossy(&std::fs::read(&empty).unwrap()).contains("element face 0"));
}

/// `bake-texture` from a file of 0 Gaussians has no colour to bake: exit
/// 1 naming the file, the OBJ / MTL / PNG left as they were.
#[test]
fn bake_texture_from_no_gaussians() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh = mesh_file(d, "tet.ply", tetrahedron());
    let g = gaussians_file(d, "none.ply", gaussians(0));
    let cams = cameras_file(d, "cameras.json", &cameras_around(2, 4.0, 16, 20.0));
    let obj = existing(d, "t.obj");
    let mtl = existing(d, "t.mtl");
    let png = existing(d, "t.png");
    let before = snapshot(d);
    let o = run(
        "bake-texture",
        &[s(&mesh), s(&g), "--cameras", s(&cams), "-o", s(&obj)],
        None,
    );
    // "91.2 % seen" from nothing was the old answer
    fails(&o, 1, &["none.ply", "no Gaussians"]);
    untouched(&before, d, &[&obj, &mtl, &png]);
}

/// `splat2points` from a file of 0 Gaussians makes no point: exit 1 naming
/// the scene file and `--min-opacity` (the "no ray crossed" case is in
/// `messages.rs`).
#[test]
fn splat2points_with_no_points() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cams = cameras_file(d, "cameras.json", &cameras_around(3, 4.0, 24, 30.0));
    let none = gaussians_file(d, "none.ply", gaussians(0));
    let out = existing(d, "points.ply");
    let before = snapshot(d);
    let a = [
        s(&none),
        "--cameras",
        s(&cams),
        "--all-views",
        "-o",
        s(&out),
    ];
    // nothing to sample from: refused before any view is rendered
    fails(
        &run("splat2points", &a, None),
        1,
        &["none.ply", "--min-opacity"],
    );
    untouched(&before, d, &[&out]);
}

/// `train triangles --max-shapes 0` is refused at parse (exit 2); a cap
/// below the initial triangles (one per point of `input.ply`) is refused
/// before training, naming the flag and the file, instead of being ignored.
#[test]
fn train_max_shapes_means_what_it_says() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    write_sphere_dataset(&data, 4, 16, 50).unwrap();
    let out = dir.path().join("out");
    let before = snapshot(dir.path());
    for (v, code, needles) in [
        ("0", 2, vec!["--max-shapes"]),
        (
            "10",
            2,
            vec!["--max-shapes 10", "50 initial triangles", "input.ply"],
        ),
    ] {
        let o = run(
            "train",
            &[
                "triangles",
                s(&data),
                "-o",
                s(&out),
                "--iterations",
                "2",
                "--max-shapes",
                v,
                "-q",
            ],
            None,
        );
        fails(&o, code, &needles);
        assert_eq!(snapshot(dir.path()), before, "nothing written");
        assert!(!out.exists());
    }
}

/// Writes `masks/NAME.png` all zero (no object pixel) for every photo of
/// the DATA folder `data`, `size`² pixels.
fn zero_masks(data: &Path, size: usize) -> PathBuf {
    let masks = data.join("masks");
    std::fs::create_dir_all(&masks).unwrap();
    for e in std::fs::read_dir(data.join("images")).unwrap() {
        let name = e.unwrap().file_name();
        let mut f = std::fs::File::create(masks.join(&name)).unwrap();
        splatkit::io::image::write_png8(&mut f, "mask", size, size, 1, &vec![0; size * size])
            .unwrap();
    }
    masks
}

/// Metrics over zero pixels are refused up front, not reported as
/// `psnr: null, ssim: 1.0`: all-zero masks in `train` and `refine`
/// (naming the mask), `refine --resolution 1` that leaves a 0-pixel-high
/// view (exit 2 naming the flag).
#[test]
fn metrics_over_zero_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = d.join("data");
    write_sphere_dataset(&data, 4, 16, 50).unwrap();
    let masks = zero_masks(&data, 16);
    let out = d.join("out");
    let before = snapshot(d);
    let o = run(
        "train",
        &[
            "gaussians",
            s(&data),
            "-o",
            s(&out),
            "--iterations",
            "2",
            "-q",
        ],
        None,
    );
    // every view's loss and metric would be over 0 pixels
    fails(&o, 1, &["mask", "no object pixel"]);
    assert_eq!(snapshot(d), before);
    assert!(!out.exists());

    // refine: a bound file from a small sphere
    let mesh = mesh_file(d, "sphere.ply", uv_sphere(6, 1.0));
    let bound = d.join("bound.ply");
    succeeds(&run("bind-gaussians", &[s(&mesh), "-o", s(&bound)], None));
    let cams = data.join("cameras.json");
    let images = data.join("images");
    let before = snapshot(d);
    let base = [
        s(&bound),
        "--images",
        s(&images),
        "--cameras",
        s(&cams),
        "-o",
        s(&out),
        "--iterations",
        "2",
        "-q",
    ];
    let mut a = base.to_vec();
    a.extend(["--masks", s(&masks)]);
    fails(&run("refine", &a, None), 1, &["--masks", "no object pixel"]);
    assert_eq!(snapshot(d), before);
    // 16x16 cameras at --resolution 1 are 1x1: fine; a 16x8 camera is not
    let wide = d.join("wide.json");
    let mut cs = cameras_around(4, 3.5, 16, 20.0);
    for c in &mut cs {
        c.height = 8;
        c.cy = 4.0;
    }
    write_gs_json(&wide, &cs).unwrap();
    let before = snapshot(d);
    let mut a = base.to_vec();
    a[4] = s(&wide);
    a.extend(["--resolution", "1"]);
    fails(
        &run("refine", &a, None),
        2,
        &["wide.json", "--resolution 1", "no pixels"],
    );
    assert_eq!(snapshot(d), before);
    assert!(!out.exists());
}

/// `chamfer --max-dist` below every distance discards all of them: an error
/// naming the flag and the side, not exit 0 with null statistics.
#[test]
fn chamfer_with_every_distance_discarded() {
    use splatkit::io::any::save;
    use splatkit::io::detect::FileFormat;
    use splatkit::model::{Mesh, Scene};
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.ply");
    let b = dir.path().join("b.ply");
    let tri = |z: f32| {
        Scene::Mesh(Mesh::new(
            vec![[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]],
            vec![[0, 1, 2]],
        ))
    };
    save(&a, &tri(0.0), FileFormat::Ply).unwrap();
    save(&b, &tri(0.5), FileFormat::Ply).unwrap();
    let o = super::common::run(
        "chamfer",
        &[
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--count",
            "500",
            "--max-dist",
            "1e-30",
            "--json",
        ],
        None,
    );
    super::common::fails(&o, 1, &["--max-dist", "accuracy"]);
}

/// A run that takes no step (`--iterations 0`: the initial model written
/// as it is) reports `final_loss` as null, not a loss of 0 that was never
/// computed.
#[test]
fn no_step_reports_no_loss() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    write_sphere_dataset(&data, 4, 16, 50).unwrap();
    let out = dir.path().join("out");
    // `train triangles DATA --iterations N`, then its metrics.json
    let metrics = |n: &str| -> serde_json::Value {
        let args = [
            "triangles",
            s(&data),
            "-o",
            s(&out),
            "--iterations",
            n,
            "-q",
        ];
        succeeds(&run("train", &args, None));
        serde_json::from_slice(&std::fs::read(out.join("metrics.json")).unwrap()).unwrap()
    };
    let m = metrics("0");
    assert_eq!(m["iterations_this_run"], 0);
    assert!(m["final_loss"].is_null(), "{m}");
    // one step: a finite loss
    let m = metrics("1");
    assert!(m["final_loss"].as_f64().is_some_and(f64::is_finite), "{m}");
}
