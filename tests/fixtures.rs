//! Files written by the tools splatkit's users already run (testdata/, one
//! line each in testdata/README.md; written by scripts/make_fixtures.py),
//! read with splatkit's readers and compared with the values the tools
//! themselves reported (testdata/expected.json). The files are committed:
//! nothing here skips.
//!
//! Tolerances: where the tool wrote binary floats, the reader's f32 must be
//! bit-equal to the stored value rounded to f32 (f64 files are rounded by the
//! reader, f32 files copied). Where the tool printed text, each entry of
//! expected.json states the tool's precision as `|got − want| ≤ abs + rel·|want|`
//! (`%g`: 6 significant digits; `%.8f`: 8 decimals; 16–17 digits: one f32
//! rounding). Integers, colours and indices are exact everywhere; f64 values
//! written in binary (`.mat`, `.npz`) or with 17 digits (COLMAP text) are
//! exact in f64; camera decompositions are compared at 1e-9 relative.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use assert_cmd::Command;
use glam::{DMat3, DMat4};
use serde_json::Value;
use splatkit::io::cameras::colmap::ColmapModel;
use splatkit::io::cameras::npz::{NpzOptions, read_neus_cameras};
use splatkit::io::{dtu, gltf, mat, obj, ply};
use splatkit::model::{Column, Mesh, PointCloud};

const TESTDATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/testdata");

fn path(rel: &str) -> PathBuf {
    Path::new(TESTDATA).join(rel)
}

fn read(rel: &str) -> Vec<u8> {
    std::fs::read(path(rel)).unwrap_or_else(|e| panic!("testdata/{rel}: {e}"))
}

/// testdata/expected.json.
fn expected() -> &'static Value {
    static E: OnceLock<Value> = OnceLock::new();
    E.get_or_init(|| serde_json::from_slice(&read("expected.json")).expect("expected.json parses"))
}

/// The entries of expected.json's `files` of one `kind`, with their paths.
fn entries(kind: &str) -> Vec<(&'static str, &'static Value)> {
    let all: Vec<_> = expected()["files"]
        .as_object()
        .expect("files")
        .iter()
        .filter(|(_, e)| e["kind"] == kind)
        .map(|(k, e)| (k.as_str(), e))
        .collect();
    assert!(!all.is_empty(), "no '{kind}' entries in expected.json");
    all
}

/// A value of an entry, following `"@name"` references into `arrays`.
fn resolve(v: &'static Value) -> &'static Value {
    match v.as_str().and_then(|s| s.strip_prefix('@')) {
        Some(name) => &expected()["arrays"][name],
        None => v,
    }
}

fn f64s(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().flat_map(f64s).collect(),
        Value::Number(n) => vec![n.as_f64().unwrap()],
        other => panic!("expected numbers, found {other}"),
    }
}

fn u64s(v: &Value) -> Vec<u64> {
    f64s(v).into_iter().map(|x| x as u64).collect()
}

/// How floats of one file compare (see the module docs).
struct Tol {
    exact: bool,
    rel: f64,
    abs: f64,
    note: String,
}

fn tol(e: &Value) -> Tol {
    let t = &e["tol"];
    Tol {
        exact: t["exact"].as_bool().unwrap_or(false),
        rel: t["rel"].as_f64().unwrap(),
        abs: t["abs"].as_f64().unwrap(),
        note: t["note"].as_str().unwrap_or("").to_string(),
    }
}

fn check_f32(file: &str, what: &str, got: &[f32], want: &[f64], t: &Tol) {
    assert_eq!(got.len(), want.len(), "{file}: {what}: count");
    for (i, (&g, &w)) in got.iter().zip(want).enumerate() {
        if t.exact {
            assert_eq!(
                g.to_bits(),
                (w as f32).to_bits(),
                "{file}: {what}[{i}] = {g}, the tool stored {w} ({})",
                t.note
            );
        } else {
            let err = (f64::from(g) - w).abs();
            assert!(
                err <= t.abs + t.rel * w.abs(),
                "{file}: {what}[{i}] = {g}, the tool had {w}: error {err:e} ({})",
                t.note
            );
        }
    }
}

fn check_f64(file: &str, what: &str, got: &[f64], want: &[f64], rel: f64, abs: f64) {
    assert_eq!(got.len(), want.len(), "{file}: {what}: count");
    for (i, (&g, &w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= abs + rel * w.abs(),
            "{file}: {what}[{i}] = {g:?}, expected {w:?}"
        );
    }
}

fn flat3(v: &[[f32; 3]]) -> Vec<f32> {
    v.iter().flatten().copied().collect()
}

/// Row-major entries of a DMat3 / DMat4 (glam is column-major).
fn rows3(m: &DMat3) -> Vec<f64> {
    (0..3)
        .flat_map(|r| (0..3).map(move |c| m.col(c)[r]))
        .collect()
}

fn rows4(m: &DMat4) -> Vec<f64> {
    (0..4)
        .flat_map(|r| (0..4).map(move |c| m.col(c)[r]))
        .collect()
}

/// Reads a mesh fixture with the reader its extension names, and checks that
/// the format-detecting loader agrees.
fn read_mesh(rel: &str) -> Mesh {
    let bytes = read(rel);
    let m = match rel.rsplit('.').next().unwrap() {
        "ply" => ply::mesh::parse_mesh(rel, &bytes),
        "obj" => obj::parse_obj(rel, &bytes),
        "glb" => gltf::parse_gltf(rel, &bytes),
        other => panic!("{rel}: no mesh reader for .{other}"),
    }
    .unwrap_or_else(|e| panic!("{rel}: {e}"));
    m.validate().unwrap_or_else(|e| panic!("{rel}: {e}"));
    let loaded = splatkit::io::any::load_mesh(&path(rel), "fixtures test").unwrap();
    assert_eq!(loaded.vertices, m.vertices, "{rel}: load_mesh");
    assert_eq!(loaded.faces, m.faces, "{rel}: load_mesh");
    m
}

fn check_mesh(file: &str, e: &'static Value) {
    let m = read_mesh(file);
    let t = tol(e);
    let want_v = f64s(resolve(&e["vertices"]));
    check_f32(file, "vertices", &flat3(&m.vertices), &want_v, &t);
    let faces: Vec<u64> = m.faces.iter().flatten().map(|&i| u64::from(i)).collect();
    assert_eq!(faces, u64s(resolve(&e["faces"])), "{file}: faces");
    match (&m.normals, resolve(&e["normals"])) {
        (Some(n), want @ Value::Array(_)) => check_f32(file, "normals", &flat3(n), &f64s(want), &t),
        (None, Value::Null) => {}
        (got, _) => panic!("{file}: normals present: {}", got.is_some()),
    }
    match (&m.vertex_colors, resolve(&e["colors"])) {
        (Some(c), want @ Value::Array(_)) => {
            let got: Vec<u64> = c.iter().flatten().map(|&x| u64::from(x)).collect();
            let mut want = u64s(want);
            if file.ends_with(".glb") {
                // trimesh stores its 8-bit colours in COLOR_0 unconverted;
                // glTF defines COLOR_0 as linear, so a reader that follows
                // the specification (ours, Blender's) shows sRGB(c / 255).
                for (k, w) in want.iter_mut().enumerate() {
                    if k % 4 != 3 {
                        let l = *w as f64 / 255.0;
                        let v = if l <= 0.0031308 {
                            12.92 * l
                        } else {
                            1.055 * l.powf(1.0 / 2.4) - 0.055
                        };
                        *w = (v * 255.0).round() as u64;
                    }
                }
            }
            assert_eq!(got, want, "{file}: vertex colours (RGBA)");
        }
        (None, Value::Null) => {}
        (got, _) => panic!("{file}: vertex colours present: {}", got.is_some()),
    }
    assert!(m.face_colors.is_none(), "{file}: no face colours written");
    // MeshLab's per-vertex `quality` is a PLY double: kept, as read, in
    // the vertex extras (f64, exact).
    for (name, want) in e
        .get("vertex_scalars")
        .and_then(Value::as_object)
        .into_iter()
        .flatten()
    {
        let p = m
            .extras
            .vertex
            .iter()
            .find(|p| &p.name == name)
            .unwrap_or_else(|| panic!("{file}: vertex property {name} missing"));
        let Column::Scalar(d) = &p.data else {
            panic!("{file}: {name} is a list")
        };
        let got: Vec<f64> = (0..d.len()).map(|i| d.get_f64(i)).collect();
        assert_eq!(got, f64s(resolve(want)), "{file}: {name}");
    }
}

fn check_points(file: &str, e: &'static Value) {
    let pc: PointCloud =
        ply::points::parse_points(file, &read(file)).unwrap_or_else(|err| panic!("{file}: {err}"));
    let t = tol(e);
    check_f32(
        file,
        "positions",
        &flat3(&pc.positions),
        &f64s(resolve(&e["positions"])),
        &t,
    );
    match (&pc.normals, resolve(&e["normals"])) {
        (Some(n), want @ Value::Array(_)) => check_f32(file, "normals", &flat3(n), &f64s(want), &t),
        (None, Value::Null) => {}
        (got, _) => panic!("{file}: normals present: {}", got.is_some()),
    }
    let colors = pc.colors.as_ref().expect("colours");
    let got: Vec<u64> = colors.iter().flatten().map(|&x| u64::from(x)).collect();
    assert_eq!(got, u64s(resolve(&e["colors"])), "{file}: colours (RGB)");
}

/// Checks every mesh and point cloud entry whose writer starts with `tool`;
/// returns how many files were checked.
fn check_tool(tool: &str) -> usize {
    let mut n = 0;
    for kind in ["mesh", "points"] {
        for (file, e) in entries(kind) {
            if !e["writer"].as_str().unwrap().starts_with(tool) {
                continue;
            }
            if kind == "mesh" {
                check_mesh(file, e)
            } else {
                check_points(file, e)
            }
            n += 1;
        }
    }
    n
}

/// Open3D 0.20: ASCII and binary PLY meshes (double x y z nx ny nz, uchar
/// rgb, `list uchar uint`), an OBJ with `v x y z r g b` and `vn`, ASCII and
/// binary point clouds: every vertex, normal, colour and index.
#[test]
fn open3d_meshes_and_point_clouds() {
    assert_eq!(check_tool("Open3D"), 5);
}

/// trimesh: binary and ASCII (`%.8f`) PLY with float normals and RGBA, an
/// OBJ, a GLB (f32 POSITION/NORMAL, normalised u8 COLOR_0, u32 indices), and
/// binary and ASCII point clouds.
#[test]
fn trimesh_meshes_glb_and_point_clouds() {
    assert_eq!(check_tool("trimesh"), 6);
}

/// pymeshlab (VCGLIB): binary and ASCII (`%.16g`) PLY with double
/// coordinates and normals, RGBA and a double `quality`, an OBJ with colours
/// and normals, and a face-less binary PLY (point cloud, `face 0`).
#[test]
fn pymeshlab_meshes_and_point_cloud() {
    assert_eq!(check_tool("pymeshlab"), 4);
}

/// scipy.io.savemat (compressed and not): the variables as saved, then the
/// DTU reader: dims, the logical mask in MATLAB's column-major order, BB,
/// Res, and `eval.py`'s observability test on probe points, whose answers
/// numpy computed.
#[test]
fn mat_obsmask_written_by_scipy() {
    for (file, e) in entries("obsmask") {
        let vars = mat::parse_mat(file, &read(file)).unwrap_or_else(|err| panic!("{file}: {err}"));
        let names: BTreeSet<&str> = vars.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names, BTreeSet::from(["ObsMask", "BB", "Res"]), "{file}");
        let m = mat::find(&vars, "ObsMask").unwrap();
        assert!(m.logical, "{file}: scipy writes bool arrays as logical");
        assert_eq!(m.class, mat::MatClass::Uint8, "{file}");
        assert_eq!(mat::find(&vars, "BB").unwrap().dims, [2, 3], "{file}");
        assert_eq!(mat::find(&vars, "Res").unwrap().dims, [1, 1], "{file}");

        let om = dtu::read_obs_mask(&path(file)).unwrap();
        let dims: Vec<u64> = om.dims.iter().map(|&d| d as u64).collect();
        assert_eq!(dims, u64s(&e["dims"]), "{file}: dims");
        let mask: Vec<u64> = om.mask.iter().map(|&b| u64::from(b)).collect();
        assert_eq!(mask, u64s(&e["mask_column_major"]), "{file}: mask");
        let bb: Vec<f64> = om.bb.iter().flatten().copied().collect();
        assert_eq!(bb, f64s(&e["bb"]), "{file}: BB");
        assert_eq!(om.res, e["res"].as_f64().unwrap(), "{file}: Res");
        let probes = f64s(&e["probes"]);
        let in_obs = e["in_obs"].as_array().unwrap();
        assert_eq!(probes.len(), 3 * in_obs.len());
        for (i, (p, want)) in probes.chunks_exact(3).zip(in_obs).enumerate() {
            assert_eq!(
                om.contains([p[0], p[1], p[2]]),
                want.as_bool().unwrap(),
                "{file}: probe {i} {p:?}"
            );
        }
    }
}

/// scipy.io.savemat of the DTU plane: `P` as a 4×1 double, bit-exact.
#[test]
fn mat_plane_written_by_scipy() {
    for (file, e) in entries("plane") {
        let vars = mat::parse_mat(file, &read(file)).unwrap_or_else(|err| panic!("{file}: {err}"));
        assert_eq!(mat::find(&vars, "P").unwrap().dims, [4, 1], "{file}");
        let p = dtu::read_plane(&path(file)).unwrap();
        assert_eq!(p.to_vec(), f64s(&e["p"]), "{file}: P");
    }
}

/// np.savez / np.savez_compressed in the NeuS `cameras_sphere.npz` layout:
/// raw matrices bit-exact; the cameras (normalised frame by default, world
/// frame without scale_mat) against scipy's RQ decomposition: names, sizes
/// (2·cx × 2·cy, no image folder), intrinsics with the +0.5 pixel-centre
/// shift, rotation and translation.
#[test]
fn npz_cameras_written_by_numpy() {
    for (file, e) in entries("neus_npz") {
        let t = tol(e);
        let scale = f64s(&e["scale_mat"]);
        for (apply, key) in [(true, "cameras_normalised"), (false, "cameras_world")] {
            let opts = NpzOptions {
                apply_scale_mat: apply,
            };
            let cams =
                read_neus_cameras(&path(file), &opts).unwrap_or_else(|err| panic!("{file}: {err}"));
            assert!(cams.has_scale_mat, "{file}");
            assert_eq!(cams.scale_mat_applied, apply, "{file}");
            assert_eq!(rows4(&cams.scale_mat), scale, "{file}: scale_mat");
            let want = e[key].as_array().unwrap();
            let world = e["world_mats"].as_array().unwrap();
            assert_eq!(cams.cameras.len(), want.len(), "{file}: camera count");
            for ((c, v), (w, wm)) in cams
                .cameras
                .iter()
                .zip(&cams.views)
                .zip(want.iter().zip(world))
            {
                let what = format!("{key} {}", c.name);
                assert_eq!(c.name, w["name"].as_str().unwrap(), "{file}: {what}");
                assert_eq!(rows4(&v.world_mat), f64s(wm), "{file}: {what}: world_mat");
                assert_eq!(rows4(&v.scale_mat), scale, "{file}: {what}: scale_mat");
                assert_eq!(
                    u64::from(c.width),
                    w["width"].as_u64().unwrap(),
                    "{file}: {what}"
                );
                assert_eq!(
                    u64::from(c.height),
                    w["height"].as_u64().unwrap(),
                    "{file}: {what}"
                );
                let got = [c.fx, c.fy, c.cx, c.cy];
                let exp = ["fx", "fy", "cx", "cy"].map(|k| w[k].as_f64().unwrap());
                check_f64(file, &format!("{what} K"), &got, &exp, t.rel, t.abs);
                check_f64(
                    file,
                    &format!("{what} R"),
                    &rows3(&c.rotation),
                    &f64s(&w["rotation"]),
                    0.0,
                    t.abs,
                );
                let tr = c.translation.to_array();
                check_f64(
                    file,
                    &format!("{what} t"),
                    &tr,
                    &f64s(&w["translation"]),
                    t.rel,
                    t.abs,
                );
            }
        }
        // Auto-detection by extension gives the normalised cameras.
        let auto = splatkit::io::cameras::read_cameras(&path(file)).unwrap();
        assert_eq!(
            auto.len(),
            e["cameras_normalised"].as_array().unwrap().len()
        );
    }
}

/// pycolmap's `Reconstruction.write_text` (cameras, images, points3D, plus
/// the rigs.txt / frames.txt that COLMAP ≥ 3.12 writes and splatkit
/// ignores): every camera, image (sorted by name), 2-D observation and 3-D
/// point with its track, f64-exact; poses as rotation matrices at 1e-12.
#[test]
fn colmap_text_model_written_by_pycolmap() {
    let e = &expected()["files"]["colmap"];
    let dir = path("colmap");
    let model = ColmapModel::read(&dir).unwrap_or_else(|err| panic!("testdata/colmap: {err}"));

    let want_cams = e["cameras"].as_array().unwrap();
    assert_eq!(model.cameras.len(), want_cams.len(), "camera count");
    for (c, w) in model.cameras.iter().zip(want_cams) {
        assert_eq!(u64::from(c.id), w["id"].as_u64().unwrap());
        assert_eq!(
            c.model_name(),
            w["model"].as_str().unwrap(),
            "camera {}",
            c.id
        );
        assert_eq!(c.width, w["width"].as_u64().unwrap(), "camera {}", c.id);
        assert_eq!(c.height, w["height"].as_u64().unwrap(), "camera {}", c.id);
        assert_eq!(c.params, f64s(&w["params"]), "camera {} params", c.id);
    }

    let want_imgs = e["images"].as_array().unwrap();
    assert_eq!(model.images.len(), want_imgs.len(), "image count");
    for (im, w) in model.images.iter().zip(want_imgs) {
        assert_eq!(
            im.name,
            w["name"].as_str().unwrap(),
            "images sorted by name"
        );
        assert_eq!(u64::from(im.id), w["id"].as_u64().unwrap(), "{}", im.name);
        assert_eq!(
            u64::from(im.camera_id),
            w["camera_id"].as_u64().unwrap(),
            "{}",
            im.name
        );
        assert_eq!(im.qvec.to_vec(), f64s(&w["qvec_wxyz"]), "{}: qvec", im.name);
        assert_eq!(im.tvec.to_vec(), f64s(&w["tvec"]), "{}: tvec", im.name);
        let obs: Vec<f64> = im
            .points2d
            .iter()
            .flat_map(|p| [p.x, p.y, p.point3d_id as f64])
            .collect();
        assert_eq!(obs, f64s(&w["points2d"]), "{}: points2D", im.name);
    }

    let want_pts = e["points3d"].as_array().unwrap();
    assert_eq!(model.points3d.len(), want_pts.len(), "point count");
    for (p, w) in model.points3d.iter().zip(want_pts) {
        assert_eq!(p.id, w["id"].as_u64().unwrap());
        assert_eq!(p.xyz.to_array().to_vec(), f64s(&w["xyz"]), "point {}", p.id);
        let rgb: Vec<u64> = p.rgb.iter().map(|&c| u64::from(c)).collect();
        assert_eq!(rgb, u64s(&w["rgb"]), "point {}", p.id);
        assert_eq!(p.error, w["error"].as_f64().unwrap(), "point {}", p.id);
        let track: Vec<u64> = p
            .track
            .iter()
            .flat_map(|t| [u64::from(t.image_id), u64::from(t.point2d_idx)])
            .collect();
        assert_eq!(track, u64s(&w["track"]), "point {} track", p.id);
    }

    // As `Camera`s (what every command uses): world-to-camera R from the
    // quaternion against pycolmap's matrix; intrinsics from the parameters.
    let cams = splatkit::io::cameras::read_cameras(&dir).unwrap();
    assert_eq!(cams.len(), want_imgs.len());
    for (c, w) in cams.iter().zip(want_imgs) {
        assert_eq!(c.name, w["name"].as_str().unwrap());
        check_f64(
            &c.name,
            "R",
            &rows3(&c.rotation),
            &f64s(&w["rotation"]),
            0.0,
            1e-12,
        );
        assert_eq!(
            c.translation.to_array().to_vec(),
            f64s(&w["tvec"]),
            "{}",
            c.name
        );
        let cam = &want_cams[w["camera_id"].as_u64().unwrap() as usize - 1];
        let p = f64s(&cam["params"]);
        let (fx, fy, cx, cy) = match cam["model"].as_str().unwrap() {
            "SIMPLE_RADIAL" => (p[0], p[0], p[1], p[2]),
            _ => (p[0], p[1], p[2], p[3]),
        };
        assert_eq!([c.fx, c.fy, c.cx, c.cy], [fx, fy, cx, cy], "{}", c.name);
        assert_eq!(u64::from(c.width), cam["width"].as_u64().unwrap());
        let model = match &c.model {
            splatkit::model::CameraModel::Pinhole => "PINHOLE".to_string(),
            splatkit::model::CameraModel::Distorted { name, params } => {
                let skip = if name == "SIMPLE_RADIAL" { 3 } else { 4 };
                assert_eq!(params[..], p[skip..], "{}: distortion", c.name);
                name.clone()
            }
        };
        assert_eq!(model, cam["model"].as_str().unwrap(), "{}", c.name);
    }
}

/// testdata/surfels/expected.json (the 2DGS fixture keeps its own values).
fn surfels_expected() -> Value {
    serde_json::from_slice(&read("surfels/expected.json")).expect("surfels/expected.json parses")
}

/// A 2DGS PLY written as hbb1/2d-gaussian-splatting's `save_ply` does (x y z
/// nx ny nz f_dc_0..2 f_rest_0..44 opacity scale_0 scale_1 rot_0..3, f32,
/// binary little-endian): detected as surfels, every value bit-exact,
/// `f_rest` transposed to coefficient-major, each disc normal (R[:, 2] of
/// 2DGS's `build_rotation`, computed by NumPy in f64) within 1e-6, and
/// re-writing reproduces plyfile's bytes.
#[test]
fn surfels_written_like_2dgs_save_ply() {
    use splatkit::io::any;
    use splatkit::model::{Scene, SceneKind};
    let file = "surfels/point_cloud.ply";
    let e = surfels_expected();
    let bytes = read(file);
    let opened = any::open(&path(file)).unwrap();
    assert_eq!(opened.kind().unwrap(), SceneKind::Surfels);
    let Scene::Surfels(s) = opened.decode().unwrap() else {
        panic!("not surfels")
    };
    let t = tol(&e);
    assert!(t.exact);
    assert_eq!(s.len() as u64, e["n"].as_u64().unwrap());
    assert_eq!(s.sh_degree as u64, e["sh_degree"].as_u64().unwrap());
    check_f32(file, "means", &flat3(&s.means), &f64s(&e["means"]), &t);
    let normals = s.normals.as_ref().expect("save_ply writes nx ny nz");
    assert!(flat3(normals).iter().all(|&x| x.to_bits() == 0));
    check_f32(file, "f_dc", &flat3(&s.sh_dc), &f64s(&e["sh_dc"]), &t);
    check_f32(
        file,
        "sh_rest",
        &s.sh_rest,
        &f64s(&e["sh_rest_coefficient_major"]),
        &t,
    );
    check_f32(
        file,
        "opacity",
        &s.opacity_logits,
        &f64s(&e["opacity_logits"]),
        &t,
    );
    let scales: Vec<f32> = s.log_scales.iter().flatten().copied().collect();
    check_f32(file, "scales", &scales, &f64s(&e["log_scales"]), &t);
    let rot: Vec<f32> = s.rotations.iter().flatten().copied().collect();
    check_f32(file, "rot (w x y z)", &rot, &f64s(&e["rotations_wxyz"]), &t);
    let want_n = f64s(&e["disc_normals"]);
    let abs = e["normal_tol"]["abs"].as_f64().unwrap();
    for i in 0..s.len() {
        let n = s.disc_normal(i);
        for c in 0..3 {
            let err = (f64::from(n[c]) - want_n[3 * i + c]).abs();
            assert!(err <= abs, "{file}: disc normal {i}[{c}] off by {err:e}");
        }
    }
    let mut again = Vec::new();
    ply::surfels::write_surfels(&mut again, &s, ply::Format::BinaryLittleEndian).unwrap();
    assert!(
        again == bytes,
        "re-writing does not reproduce plyfile's file"
    );
}

/// A 3DGS PLY written with plyfile exactly as graphdeco's `save_ply`
/// (x y z nx ny nz f_dc_0..2 f_rest_0..44 opacity scale_0..2 rot_0..3, f32,
/// binary little-endian): every value bit-exact, `f_rest` transposed from
/// the file's channel-major order to coefficient-major, and re-writing the
/// Gaussians reproduces plyfile's bytes.
#[test]
fn gaussians_written_like_graphdeco_save_ply() {
    let file = "gaussians/point_cloud.ply";
    let e = &expected()["files"][file];
    let bytes = read(file);
    let g = ply::gaussians::parse_gaussians(file, &bytes).unwrap();
    let t = tol(e);
    assert!(t.exact);
    assert_eq!(g.len() as u64, e["n"].as_u64().unwrap());
    assert_eq!(g.sh_degree as u64, e["sh_degree"].as_u64().unwrap());
    check_f32(file, "means", &flat3(&g.means), &f64s(&e["means"]), &t);
    let normals = g.normals.as_ref().expect("save_ply writes nx ny nz");
    assert!(
        flat3(normals).iter().all(|&x| x.to_bits() == 0),
        "zero normals"
    );
    check_f32(file, "f_dc", &flat3(&g.sh_dc), &f64s(&e["sh_dc"]), &t);
    check_f32(
        file,
        "sh_rest",
        &g.sh_rest,
        &f64s(&e["sh_rest_coefficient_major"]),
        &t,
    );
    check_f32(
        file,
        "opacity",
        &g.opacity_logits,
        &f64s(&e["opacity_logits"]),
        &t,
    );
    check_f32(
        file,
        "scales",
        &flat3(&g.log_scales),
        &f64s(&e["log_scales"]),
        &t,
    );
    let rot: Vec<f32> = g.rotations.iter().flatten().copied().collect();
    check_f32(file, "rot (w x y z)", &rot, &f64s(&e["rotations_wxyz"]), &t);
    let mut again = Vec::new();
    ply::gaussians::write_gaussians(&mut again, &g, ply::Format::BinaryLittleEndian).unwrap();
    assert!(
        again == bytes,
        "re-writing does not reproduce plyfile's file"
    );
}

/// `info --json` on every fixture it knows (all but the .mat files): format,
/// kind and counts as the tools reported them.
#[test]
fn cli_info_json_on_every_fixture() {
    let mut files: Vec<(String, &'static Value)> = expected()["files"]
        .as_object()
        .unwrap()
        .iter()
        .filter(|(_, e)| !matches!(e["kind"].as_str(), Some("obsmask" | "plane")))
        .map(|(k, e)| (k.clone(), e))
        .collect();
    let pt: &'static Value = Box::leak(Box::new(
        serde_json::from_slice::<Value>(&read("pt/expected.json")).unwrap(),
    ));
    for (k, e) in pt.as_object().unwrap() {
        files.push((format!("pt/{k}"), e));
    }
    let out = Command::cargo_bin("info")
        .unwrap()
        .args(files.iter().map(|(f, _)| path(f)))
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "info failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let infos: Value = serde_json::from_slice(&out.stdout).unwrap();
    let infos = infos.as_array().unwrap();
    assert_eq!(infos.len(), files.len());
    let count = |v: &'static Value| resolve(v).as_array().unwrap().len() as u64;
    for ((file, e), i) in files.iter().zip(infos) {
        let ctx = format!("{file}: {i}");
        if file.starts_with("pt/") {
            assert_eq!(i["kind"], "triangle-soup", "{ctx}");
            assert_eq!(i["format"], "pt", "{ctx}");
            assert_eq!(i["triangles"], e["n"], "{ctx}");
            assert_eq!(i["sh_degree"], e["sh_degree"], "{ctx}");
            continue;
        }
        match e["kind"].as_str().unwrap() {
            "mesh" => {
                assert_eq!(i["kind"], "mesh", "{ctx}");
                assert_eq!(i["vertices"].as_u64(), Some(count(&e["vertices"])), "{ctx}");
                assert_eq!(i["faces"].as_u64(), Some(count(&e["faces"])), "{ctx}");
                let attrs = i["attributes"].to_string();
                assert!(
                    attrs.contains("normals") && attrs.contains("vertex-colors"),
                    "{ctx}"
                );
            }
            "points" => {
                assert_eq!(i["kind"], "point-cloud", "{ctx}");
                assert_eq!(i["format"], "ply", "{ctx}");
                assert_eq!(i["points"].as_u64(), Some(count(&e["positions"])), "{ctx}");
            }
            "gaussians" => {
                assert_eq!(i["kind"], "gaussians", "{ctx}");
                assert_eq!(i["gaussians"], e["n"], "{ctx}");
                assert_eq!(i["sh_degree"], e["sh_degree"], "{ctx}");
                assert_eq!(i["encoding"], "binary_little_endian", "{ctx}");
            }
            "neus_npz" => {
                assert_eq!(i["kind"], "cameras", "{ctx}");
                assert_eq!(
                    i["cameras"].as_u64(),
                    Some(count(&e["cameras_normalised"])),
                    "{ctx}"
                );
                let mut sizes: Vec<String> = e["cameras_normalised"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|c| format!("{}x{}", c["width"], c["height"]))
                    .collect();
                sizes.sort();
                sizes.dedup();
                assert_eq!(i["image_sizes"], serde_json::json!(sizes), "{ctx}");
            }
            "colmap" => {
                assert_eq!(i["kind"], "cameras", "{ctx}");
                assert_eq!(
                    i["cameras"].as_u64(),
                    Some(e["images"].as_array().unwrap().len() as u64),
                    "{ctx}"
                );
            }
            other => panic!("{file}: kind {other} not covered"),
        }
    }
}

/// A file of the Gaussian-splat folders (`splats/`, `splats/scene300/`,
/// read by tests/splat_fixtures.rs and the SPZ/SOG unit tests) is checked
/// when its folder's own expected.json names it (or it is that file).
fn splat_fixture_checked(rel: &str) -> bool {
    let Some(rest) = rel.strip_prefix("splats/") else {
        return false;
    };
    let (dir, name) = match rest.rsplit_once('/') {
        Some((d, n)) => (format!("splats/{d}"), n),
        None => ("splats".to_string(), rest),
    };
    if name == "expected.json" {
        return true;
    }
    let exp = String::from_utf8(read(&format!("{dir}/expected.json"))).unwrap_or_default();
    exp.contains(&format!("\"{name}\""))
}

/// Every file under testdata/ has its line in testdata/README.md and is
/// checked here or by tests/torch_pt.rs (an entry of expected.json, of
/// pt/expected.json, part of the COLMAP model folder, or named by the
/// expected.json of its splats/ folder).
#[test]
fn every_fixture_is_listed_and_checked() {
    let readme = String::from_utf8(read("README.md")).unwrap();
    let files = expected()["files"].as_object().unwrap();
    let pt: Value = serde_json::from_slice(&read("pt/expected.json")).unwrap();
    let mut seen = 0;
    let mut stack = vec![PathBuf::from(TESTDATA)];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            let rel = p
                .strip_prefix(TESTDATA)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            if rel == "README.md" {
                continue;
            }
            assert!(
                readme.contains(&format!("`{rel}`")),
                "{rel} is not listed in testdata/README.md"
            );
            let checked = rel == "expected.json"
                || rel == "pt/expected.json"
                || files.contains_key(&rel)
                || rel.strip_prefix("pt/").is_some_and(|f| pt.get(f).is_some())
                || rel.starts_with("colmap/")
                || rel.starts_with("surfels/")
                // checked against their own JSON by tests/filter3d.rs and
                // tests/mip_filter.rs
                || rel.starts_with("gaussians/mip_splatting.")
                || rel == "render/mip_filter_reference.json"
                // checked by the Poisson unit test bunny_scan_matches_open3d_adaptivity
                || rel == "poisson/open3d_bunny_vertices_d9.json"
                || splat_fixture_checked(&rel);
            assert!(checked, "{rel} has no expected values");
            seen += 1;
        }
    }
    assert!(seen >= 30, "only {seen} fixtures found");
}
