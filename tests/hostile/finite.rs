//! Issue 23 hostile cases: finite (see docs/RELIABILITY.md). Every reader
//! that feeds optimisation or binding refuses NaN and ±inf with the file
//! and the element, and training / refinement stop (exit 1, nothing
//! written) when the loss or a parameter becomes non-finite. Each case
//! snapshots every file of its folder (inputs and pre-existing outputs)
//! and checks they are byte-identical after the failing run, with nothing
//! added.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::common::{fails, run, s, snapshot, succeeds};

use splatkit::geom::binding::{BindOptions, bind, to_raster};
use splatkit::io::any::{load_gaussians, load_soup, save, save_gaussians, save_soup};
use splatkit::io::cameras::write_gs_json;
use splatkit::io::detect::FileFormat;
use splatkit::io::image::write_png8;
use splatkit::model::{Column, Mesh, ScalarData, Scene};
use splatkit::ops::bind_gaussians::save_bound;
use splatkit::testing::{cameras_around, uv_sphere, write_sphere_dataset};
use splatkit_render::gaussian::{RasterSettings, render};

/// Asserts that `dir` holds exactly the files, folders and links of
/// `before`, byte for byte.
fn unchanged(dir: &Path, before: &BTreeMap<PathBuf, Vec<u8>>, case: &str) {
    let after = snapshot(dir);
    let names = |m: &BTreeMap<PathBuf, Vec<u8>>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(
        names(&after),
        names(before),
        "{case}: files added or removed"
    );
    for (p, b) in before {
        assert!(after[p] == *b, "{case}: {} changed", p.display());
    }
}

/// The sphere mesh (8 rings, 114 vertices) with vertex colours.
fn sphere_mesh() -> Mesh {
    let mut m = uv_sphere(8, 1.0);
    m.vertex_colors = Some(
        m.vertices
            .iter()
            .map(|v| [0, 1, 2].map(|k| (127.0 * (v[k] + 1.0)) as u8))
            .map(|c| [c[0], c[1], c[2], 255])
            .collect(),
    );
    m
}

/// A scene for `refine` in `dir`: `mesh.ply`, `bound.ply` (1 Gaussian per
/// face), and 10 photos of the bound model at 32² with `cameras.json`.
struct RefineScene {
    mesh: PathBuf,
    bound: PathBuf,
    images: PathBuf,
    cameras: PathBuf,
}

fn refine_scene(dir: &Path) -> RefineScene {
    let m = sphere_mesh();
    let mesh = dir.join("mesh.ply");
    save(&mesh, &Scene::Mesh(m.clone()), FileFormat::Ply).unwrap();
    let opts = BindOptions {
        per_face: 1,
        thickness: 1e-4,
        sh_degree: 1,
    };
    let b = bind(&m, &opts, None).unwrap();
    let bound = dir.join("bound.ply");
    save_bound(&bound, &b).unwrap();
    let cams = cameras_around(10, 3.0, 32, 32.0);
    let images = dir.join("images");
    std::fs::create_dir_all(&images).unwrap();
    let g = to_raster(&b, 0);
    for c in &cams {
        let px = render(&g, c, &RasterSettings::default()).rgb;
        let data: Vec<u8> = px
            .iter()
            .flat_map(|p| p.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
            .collect();
        let mut f = std::fs::File::create(images.join(format!("{}.png", c.name))).unwrap();
        write_png8(&mut f, &c.name, 32, 32, 3, &data).unwrap();
    }
    let cameras = dir.join("cameras.json");
    write_gs_json(&cameras, &cams).unwrap();
    RefineScene {
        mesh,
        bound,
        images,
        cameras,
    }
}

/// `refine BOUND [MESH] --images … --cameras … -o OUT [extra]`.
fn refine(
    sc: &RefineScene,
    bound: &Path,
    mesh: Option<&Path>,
    out: &Path,
    extra: &[&str],
) -> std::process::Output {
    let mut a = vec![s(bound)];
    if let Some(m) = mesh {
        a.push(s(m));
    }
    a.extend([
        "--images",
        s(&sc.images),
        "--cameras",
        s(&sc.cameras),
        "-o",
        s(out),
        "--test-every",
        "0",
        "-q",
    ]);
    a.extend(extra);
    run("refine", &a, None)
}

/// A pre-existing output folder with one file, so that a failing run's
/// effect on an existing target is checked too.
fn existing_output(dir: &Path) -> PathBuf {
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("metrics.json"), b"{\"from\": \"an earlier run\"}").unwrap();
    out
}

/// Rewrites `path` (a Gaussians PLY) with `edit` applied.
fn edit_gaussians(path: &Path, edit: impl FnOnce(&mut splatkit::model::Gaussians)) {
    let mut g = load_gaussians(path, "test").unwrap();
    edit(&mut g);
    save_gaussians(path, &g).unwrap();
}

/// The f32 column `prop` of element `element` (`vertex` = the Gaussians'
/// extra properties) of a Gaussians model.
fn column<'a>(
    g: &'a mut splatkit::model::Gaussians,
    element: &str,
    prop: &str,
) -> &'a mut Vec<f32> {
    let props = if element == "vertex" {
        &mut g.extras.item
    } else {
        &mut g
            .extras
            .elements
            .iter_mut()
            .find(|e| e.name == element)
            .unwrap()
            .properties
    };
    match &mut props.iter_mut().find(|p| p.name == prop).unwrap().data {
        Column::Scalar(ScalarData::F32(v)) => v,
        other => panic!("{prop} is {other:?}"),
    }
}

const BAD: [(f32, &str); 3] = [
    (f32::NAN, "NaN"),
    (f32::INFINITY, "inf"),
    (f32::NEG_INFINITY, "-inf"),
];

/// The example: one NaN vertex in a bound PLY's mesh (the
/// `bound_vertex` element; the Gaussians' own values untouched), and ±inf.
/// `refine` and `bind-gaussians --rebind` refuse it naming the file, the
/// element and the coordinate; an existing output folder and every input
/// are untouched.
#[test]
fn bound_ply_mesh_vertex_not_finite() {
    let dir = tempfile::tempdir().unwrap();
    let sc = refine_scene(dir.path());
    let out = existing_output(dir.path());
    let clean = std::fs::read(&sc.bound).unwrap();
    for (x, shown) in BAD {
        std::fs::write(&sc.bound, &clean).unwrap();
        edit_gaussians(&sc.bound, |g| column(g, "bound_vertex", "y")[17] = x);
        let want = format!("bound_vertex 17 has a non-finite coordinate (y = {shown})");
        let before = snapshot(dir.path());
        let o = refine(&sc, &sc.bound, None, &out, &["--iterations", "2"]);
        // exit 1 (bad data), the file and the vertex named
        fails(&o, 1, &["bound.ply", &want]);
        unchanged(dir.path(), &before, &format!("refine {shown}"));
        let rebound = dir.path().join("rebound.ply");
        let o = run(
            "bind-gaussians",
            &[
                s(&sc.bound),
                "--rebind",
                s(&sc.mesh),
                "-o",
                s(&rebound),
                "-q",
            ],
            None,
        );
        fails(&o, 1, &["bound.ply", &want]);
        unchanged(dir.path(), &before, &format!("rebind {shown}"));
    }
}

/// The binding and 3DGS values of a bound PLY: a NaN `bary_0` (the issue's
/// "passes the table check" example), a non-finite complex rotation, in-plane
/// scale, thickness, opacity, colour or stored rotation. Each is refused
/// naming the file, the Gaussian and the property.
#[test]
fn bound_ply_binding_values_not_finite() {
    let dir = tempfile::tempdir().unwrap();
    let sc = refine_scene(dir.path());
    let out = existing_output(dir.path());
    let clean = std::fs::read(&sc.bound).unwrap();
    type Edit = fn(&mut splatkit::model::Gaussians, f32);
    let cases: [(&str, Edit); 8] = [
        ("bary_0", |g, x| column(g, "vertex", "bary_0")[5] = x),
        ("bary_2", |g, x| column(g, "vertex", "bary_2")[5] = x),
        ("complex_re", |g, x| {
            column(g, "vertex", "complex_re")[5] = x
        }),
        ("complex_im", |g, x| {
            column(g, "vertex", "complex_im")[5] = x
        }),
        ("scale_1", |g, x| g.log_scales[5][1] = x),
        ("scale_0", |g, x| g.log_scales[5][0] = x),
        ("opacity", |g, x| g.opacity_logits[5] = x),
        ("rot_0", |g, x| g.rotations[5][0] = x),
    ];
    for (prop, edit) in cases {
        for (x, shown) in BAD {
            std::fs::write(&sc.bound, &clean).unwrap();
            edit_gaussians(&sc.bound, |g| edit(g, x));
            let before = snapshot(dir.path());
            let o = refine(&sc, &sc.bound, None, &out, &["--iterations", "2"]);
            let want = format!("Gaussian 5 has {prop} = {shown}, not a finite number");
            fails(&o, 1, &["bound.ply", &want]);
            unchanged(dir.path(), &before, &format!("{prop} {shown}"));
        }
    }
    // f_dc through bind-gaussians --rebind as well
    std::fs::write(&sc.bound, &clean).unwrap();
    edit_gaussians(&sc.bound, |g| g.sh_dc[9][2] = f32::NAN);
    let before = snapshot(dir.path());
    let o = run(
        "bind-gaussians",
        &[
            s(&sc.bound),
            "--rebind",
            s(&sc.mesh),
            "-o",
            s(&dir.path().join("r.ply")),
        ],
        None,
    );
    fails(&o, 1, &["bound.ply", "Gaussian 9 has f_dc_2 = NaN"]);
    unchanged(dir.path(), &before, "f_dc_2");
}

/// The example: one NaN vertex in `refine`'s MESH; also +inf in an
/// OBJ. Refused naming the file and the vertex, before any photo is read.
#[test]
fn refine_mesh_not_finite() {
    let dir = tempfile::tempdir().unwrap();
    let sc = refine_scene(dir.path());
    let out = existing_output(dir.path());
    let mut m = sphere_mesh();
    m.vertices[17][0] = f32::NAN;
    let ply = dir.path().join("edited.ply");
    save(&ply, &Scene::Mesh(m.clone()), FileFormat::Ply).unwrap();
    m.vertices[17][0] = 0.5;
    m.vertices[40][2] = f32::INFINITY;
    let obj = dir.path().join("edited.obj");
    save(&obj, &Scene::Mesh(m), FileFormat::Obj).unwrap();
    for (mesh, want) in [
        (&ply, "vertex 17 has a non-finite coordinate (x = NaN)"),
        (&obj, "vertex 40 has a non-finite coordinate (z = inf)"),
    ] {
        let before = snapshot(dir.path());
        let o = refine(&sc, &sc.bound, Some(mesh), &out, &["--iterations", "2"]);
        let name = mesh.file_name().unwrap().to_str().unwrap();
        fails(&o, 1, &[name, want]);
        unchanged(dir.path(), &before, name);
    }
}

/// `bind-gaussians MESH` with a NaN vertex (before the thickness is derived
/// from the mesh's extent), `--rebind EDITED` with a -inf vertex, and
/// `--colors-from` Gaussians with a NaN mean: each names its file and the
/// element; nothing is written.
#[test]
fn bind_gaussians_inputs_not_finite() {
    let dir = tempfile::tempdir().unwrap();
    let sc = refine_scene(dir.path());
    let out = dir.path().join("existing.ply");
    std::fs::write(&out, b"an earlier output").unwrap();
    let mut m = sphere_mesh();
    m.vertices[17][1] = f32::NAN;
    let nan_mesh = dir.path().join("nan_mesh.ply");
    save(&nan_mesh, &Scene::Mesh(m.clone()), FileFormat::Ply).unwrap();
    m.vertices[17][1] = f32::NEG_INFINITY;
    let inf_mesh = dir.path().join("inf_mesh.ply");
    save(&inf_mesh, &Scene::Mesh(m), FileFormat::Ply).unwrap();
    let colours = dir.path().join("colours.ply");
    std::fs::copy(&sc.bound, &colours).unwrap();
    edit_gaussians(&colours, |g| {
        g.extras = Default::default();
        g.means[3][2] = f32::NAN;
    });
    let cases: [(Vec<&str>, [&str; 2]); 4] = [
        (
            vec![s(&nan_mesh)],
            [
                "nan_mesh.ply",
                "vertex 17 has a non-finite coordinate (y = NaN)",
            ],
        ),
        (
            vec![s(&nan_mesh), "--thickness", "0.001"],
            [
                "nan_mesh.ply",
                "vertex 17 has a non-finite coordinate (y = NaN)",
            ],
        ),
        (
            vec![s(&sc.bound), "--rebind", s(&inf_mesh)],
            [
                "inf_mesh.ply",
                "vertex 17 has a non-finite coordinate (y = -inf)",
            ],
        ),
        (
            vec![s(&sc.mesh), "--colors-from", s(&colours)],
            ["colours.ply", "Gaussian 3 has z = NaN, not a finite number"],
        ),
    ];
    for (mut args, needles) in cases {
        args.extend(["-o", s(&out), "-q"]);
        let before = snapshot(dir.path());
        let o = run("bind-gaussians", &args, None);
        fails(&o, 1, &needles);
        unchanged(dir.path(), &before, needles[0]);
    }
}

/// Offsets of each group of an `optimizer.bin`: (name, byte of m[0], n).
fn groups(b: &[u8]) -> Vec<(String, usize, usize)> {
    let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap()) as usize;
    let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap()) as usize;
    let mut o = 20;
    let mut out = Vec::new();
    for _ in 0..u32_at(16) {
        let nl = u32_at(o);
        let name = String::from_utf8(b[o + 4..o + 4 + nl].to_vec()).unwrap();
        o += 4 + nl;
        let n = u64_at(o);
        o += 8;
        out.push((name, o, n));
        o += 8 * n;
    }
    out
}

/// Writes `x` over `count` f32 values of `file` from byte `at`.
fn poke(file: &Path, at: usize, count: usize, x: f32) {
    let mut b = std::fs::read(file).unwrap();
    for k in 0..count {
        b[at + 4 * k..at + 4 * k + 4].copy_from_slice(&x.to_le_bytes());
    }
    std::fs::write(file, b).unwrap();
}

/// Sets every first moment of optimizer group `group` in the checkpoint of
/// the output folder `out` to `x`.
fn first_moments_to(out: &Path, group: &str, x: f32) {
    let opt = out.join("checkpoint/optimizer.bin");
    let b = std::fs::read(&opt).unwrap();
    let (_, m0, n) = groups(&b)
        .into_iter()
        .find(|g| g.0 == group)
        .unwrap_or_else(|| panic!("no {group} group"));
    poke(&opt, m0, n, x);
}

/// A small DATA folder: 6 views of the textured sphere at 24² with 150
/// seed points.
fn dataset(dir: &Path) -> PathBuf {
    let d = dir.join("data");
    write_sphere_dataset(&d, 6, 24, 150).unwrap();
    d
}

/// `train MODEL DATA -o OUT --iterations 6 [extra]` (3 held-out
/// evaluations at most, tiny models).
fn train(model: &str, data: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut a = vec![
        model,
        s(data),
        "-o",
        s(out),
        "--iterations",
        "6",
        "--eval-every",
        "0",
        "-q",
    ];
    if model == "triangles" {
        a.extend(["--max-shapes", "300"]);
    }
    a.extend(extra);
    run("train", &a, None)
}

/// `refine --resume OUT -o OUT --iterations ITERATIONS`.
fn resume_refine(sc: &RefineScene, out: &Path, iterations: &str) -> std::process::Output {
    refine(
        sc,
        &sc.bound,
        None,
        out,
        &["--iterations", iterations, "--resume", s(out)],
    )
}

/// `train MODEL DATA -o OUT --resume OUT`.
fn resume_train(model: &str, data: &Path, out: &Path) -> std::process::Output {
    train(model, data, out, &["--resume", s(out)])
}

/// A refine scene and a DATA folder in `dir`, and three output folders
/// stopped after 2 iterations with their checkpoints: `refined` (refine),
/// `tri` (train triangles) and `gau` (train gaussians).
struct Checkpoints {
    sc: RefineScene,
    data: PathBuf,
    refined: PathBuf,
    tri: PathBuf,
    gau: PathBuf,
}

fn checkpoints(dir: &Path) -> Checkpoints {
    let sc = refine_scene(dir);
    let data = dataset(dir);
    let refined = dir.join("refined");
    succeeds(&refine(
        &sc,
        &sc.bound,
        None,
        &refined,
        &["--iterations", "2"],
    ));
    let tri = dir.join("tri");
    succeeds(&train("triangles", &data, &tri, &["--stop-at", "2"]));
    let gau = dir.join("gau");
    succeeds(&train("gaussians", &data, &gau, &["--stop-at", "2"]));
    Checkpoints {
        sc,
        data,
        refined,
        tri,
        gau,
    }
}

/// The example: 4 NaN floats in `optimizer.bin` for `--resume`
/// (refine, train gaussians, train triangles), and variants: +inf in a
/// second moment, a negative second moment. Refused naming the file, the
/// group and the element; the checkpoint folder (also the output) is left
/// byte-identical.
#[test]
fn optimizer_state_not_finite() {
    let dir = tempfile::tempdir().unwrap();
    let Checkpoints {
        sc,
        data,
        refined,
        tri,
        gau,
    } = checkpoints(dir.path());
    let runs: [(&Path, &dyn Fn() -> std::process::Output); 3] = [
        (&refined, &|| resume_refine(&sc, &refined, "4")),
        (&tri, &|| resume_train("triangles", &data, &tri)),
        (&gau, &|| resume_train("gaussians", &data, &gau)),
    ];
    for (ck_dir, resume) in runs {
        let opt = ck_dir.join("checkpoint/optimizer.bin");
        let clean = std::fs::read(&opt).unwrap();
        let g = groups(&clean);
        let (name, m0, n) = g[1].clone();
        assert!(n >= 8, "{name}: {n} values");
        let cases = [
            (
                m0 + 8,
                4,
                f32::NAN,
                format!("group {name}: element 2 of m (first moment) is NaN"),
            ),
            (
                m0 + 4 * n + 12,
                1,
                f32::INFINITY,
                format!("group {name}: element 3 of v (second moment) is inf"),
            ),
            (
                m0 + 4 * n,
                1,
                -0.5,
                format!("group {name}: element 0 of v (second moment) is -0.5, below 0"),
            ),
        ];
        for (at, count, x, want) in cases {
            std::fs::write(&opt, &clean).unwrap();
            poke(&opt, at, count, x);
            let before = snapshot(dir.path());
            let o = resume();
            fails(&o, 1, &["optimizer.bin", &format!("byte {at}"), &want]);
            unchanged(dir.path(), &before, &want);
        }
        std::fs::write(&opt, &clean).unwrap();
    }
}

/// A non-finite model in the checkpoint `--resume` reads: a Gaussians file
/// with a NaN scale (train gaussians), a soup with an infinite vertex
/// (train triangles), a bound file with a NaN bary_1 (refine). Refused
/// naming `model.ply` and the element.
#[test]
fn resumed_models_not_finite() {
    let dir = tempfile::tempdir().unwrap();
    let Checkpoints {
        sc,
        data,
        refined,
        tri,
        gau,
    } = checkpoints(dir.path());
    edit_gaussians(&gau.join("checkpoint/model.ply"), |g| {
        g.log_scales[4][1] = f32::NAN
    });
    let model = tri.join("checkpoint/model.ply");
    let mut soup = load_soup(&model, "test").unwrap();
    soup.triangles[6][2][0] = f32::INFINITY;
    save_soup(&model, &soup, FileFormat::Ply).unwrap();
    edit_gaussians(&refined.join("checkpoint/model.ply"), |g| {
        column(g, "vertex", "bary_1")[0] = f32::NAN
    });
    let before = snapshot(dir.path());
    let o = resume_train("gaussians", &data, &gau);
    fails(
        &o,
        1,
        &[
            "model.ply",
            "Gaussian 4 has scale_1 = NaN, not a finite number",
        ],
    );
    let o = resume_train("triangles", &data, &tri);
    fails(
        &o,
        1,
        &[
            "model.ply",
            "triangle 6 has vertex 2 x = inf, not a finite number",
        ],
    );
    let o = resume_refine(&sc, &refined, "4");
    fails(
        &o,
        1,
        &[
            "model.ply",
            "Gaussian 0 has bary_1 = NaN, not a finite number",
        ],
    );
    unchanged(dir.path(), &before, "resumed models");
}

/// The loss becoming non-finite mid-run, from finite inputs: a checkpoint
/// whose SH DC first moments are all −3e38 (finite, so the reader takes
/// them) throws every colour to +inf at the first resumed Adam step, and
/// the next step's loss is not finite. Each loop stops with exit 1 naming
/// the iteration and the parameter, writes nothing, and says that the
/// output folder and the checkpoint it resumed from are left as they were
/// (checked byte for byte).
#[test]
fn loss_becomes_non_finite_mid_training() {
    let dir = tempfile::tempdir().unwrap();
    let Checkpoints {
        sc,
        data,
        refined,
        tri,
        gau,
    } = checkpoints(dir.path());
    for ck_dir in [&refined, &tri, &gau] {
        first_moments_to(ck_dir, "sh_dc", -3e38);
    }
    let before = snapshot(dir.path());
    let tail = "the output folder and any earlier checkpoint are left as they were";
    let o = resume_refine(&sc, &refined, "6");
    fails(
        &o,
        1,
        &[
            "refine: iteration 4: the loss became",
            "sh_dc of Gaussian",
            tail,
        ],
    );
    let o = resume_train("triangles", &data, &tri);
    fails(
        &o,
        1,
        &[
            "train triangles: iteration 4: the loss became",
            "sh_dc of triangle",
            tail,
        ],
    );
    let o = resume_train("gaussians", &data, &gau);
    fails(
        &o,
        1,
        &[
            "train gaussians: iteration 4: the loss became",
            "sh_dc of Gaussian",
            tail,
        ],
    );
    unchanged(dir.path(), &before, "mid-training");
}

/// A parameter that becomes non-finite without the loss showing it, from
/// finite inputs: complex-rotation first moments of −3e38 throw every
/// complex number to infinity, which the binding reads as (1, 0), so every
/// render and loss stays finite. The parameter guard at the end of the run
/// (before anything is written) stops `refine` with exit 1 naming the
/// parameter; the folder it resumed from is left byte-identical.
#[test]
fn parameter_becomes_non_finite_with_a_finite_loss() {
    let dir = tempfile::tempdir().unwrap();
    let sc = refine_scene(dir.path());
    let out = dir.path().join("refined");
    succeeds(&refine(&sc, &sc.bound, None, &out, &["--iterations", "2"]));
    first_moments_to(&out, "complex", -3e38);
    let before = snapshot(dir.path());
    let o = resume_refine(&sc, &out, "6");
    fails(
        &o,
        1,
        &[
            "refine: after iteration 6, a parameter is not finite: complex of Gaussian 0",
            "the output folder and any earlier checkpoint are left as they were",
        ],
    );
    unchanged(dir.path(), &before, "finite loss, infinite parameter");
}

/// `tsdf-fuse` makes geometry from its scene: a NaN mesh vertex, or a
/// Gaussian with an infinite opacity, would silently drop primitives from
/// the fused mesh, so both are refused naming the file and the element. The
/// readers that describe or repair stay tolerant: `info` describes the NaN
/// mesh and `clean` removes the faces that use the NaN vertex (exit 0).
#[test]
fn fusion_refuses_and_clean_repairs() {
    let dir = tempfile::tempdir().unwrap();
    let sc = refine_scene(dir.path());
    let mut m = sphere_mesh();
    m.vertices[17][2] = f32::NAN;
    let nan_mesh = dir.path().join("nan_mesh.ply");
    save(&nan_mesh, &Scene::Mesh(m), FileFormat::Ply).unwrap();
    let splats = dir.path().join("splats.ply");
    std::fs::copy(&sc.bound, &splats).unwrap();
    edit_gaussians(&splats, |g| {
        g.extras = Default::default();
        g.opacity_logits[11] = f32::INFINITY;
    });
    let fused = dir.path().join("fused.ply");
    std::fs::write(&fused, b"an earlier output").unwrap();
    for (scene, needles) in [
        (
            &nan_mesh,
            [
                "nan_mesh.ply",
                "vertex 17 has a non-finite coordinate (z = NaN)",
            ],
        ),
        (
            &splats,
            [
                "splats.ply",
                "Gaussian 11 has opacity = inf, not a finite number",
            ],
        ),
    ] {
        let before = snapshot(dir.path());
        let o = run(
            "tsdf-fuse",
            &[s(scene), "--cameras", s(&sc.cameras), "-o", s(&fused), "-q"],
            None,
        );
        fails(&o, 1, &needles);
        unchanged(dir.path(), &before, needles[0]);
    }
    // describing and repairing still work on the NaN mesh
    succeeds(&run("info", &[s(&nan_mesh)], None));
    let cleaned = dir.path().join("cleaned.ply");
    succeeds(&run(
        "clean",
        &[s(&nan_mesh), "-o", s(&cleaned), "-q"],
        None,
    ));
    let c = splatkit::io::any::load_mesh(&cleaned, "test").unwrap();
    assert!(
        c.vertices.iter().flatten().all(|x| x.is_finite()) && !c.faces.is_empty(),
        "clean keeps the finite part"
    );
}

/// A path named as an input but left unread is still an input: `refine
/// BOUND … --resume DIR --json=BOUND` reads the checkpoint, not BOUND, and
/// wrote its report over BOUND (found by `fuzz_commands`). Refused with
/// exit 2 naming it; nothing changes. (Here for the refine helpers.)
#[test]
fn refine_resume_keeps_its_unread_bound_file() {
    let dir = tempfile::tempdir().unwrap();
    let sc = refine_scene(dir.path());
    let refined = dir.path().join("refined");
    succeeds(&refine(
        &sc,
        &sc.bound,
        None,
        &refined,
        &["--iterations", "2"],
    ));
    let before = snapshot(dir.path());
    let json = format!("--json={}", s(&sc.bound));
    let o = refine(
        &sc,
        &sc.bound,
        None,
        &dir.path().join("again"),
        &["--iterations", "4", "--resume", s(&refined), &json],
    );
    fails(&o, 2, &["bound.ply", "input"]);
    assert_eq!(snapshot(dir.path()), before);
}
