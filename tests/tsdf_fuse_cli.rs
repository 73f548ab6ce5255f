//! `tsdf-fuse` as a binary: a generated sphere mesh fused from cameras all
//! around (on the surface, closed), the same result from `render`'s depth
//! files as from rendering inside the command, and bad inputs (wrong size,
//! missing map, NaN depth, nothing observed) as clear errors that leave the
//! output alone.

mod common;

use std::path::Path;

use glam::DVec3;
use splatkit::io::cameras::npz::encode_npy_f32;
use splatkit::io::ply::{Format, mesh::write_mesh};
use splatkit::model::Mesh;
use splatkit::testing::{cameras_around, uv_sphere};

fn write_scene(dir: &Path) -> (String, String) {
    let mesh = uv_sphere(96, 1.0);
    let mp = dir.join("sphere.ply");
    let mut b = Vec::new();
    write_mesh(&mut b, &mesh, Format::BinaryLittleEndian).unwrap();
    std::fs::write(&mp, b).unwrap();
    let cp = dir.join("cameras.json");
    splatkit::io::cameras::write_gs_json(&cp, &cameras_around(20, 3.5, 192, 160.0)).unwrap();
    (
        mp.to_str().unwrap().to_string(),
        cp.to_str().unwrap().to_string(),
    )
}

fn read_mesh(p: &Path) -> Mesh {
    splatkit::io::any::load_mesh(p, "test").unwrap()
}

const FLAGS: [&str; 6] = [
    "--voxel",
    "0.02",
    "--sdf-trunc",
    "0.08",
    "--depth-trunc",
    "10",
];

/// The sphere rendered and fused inside the command: vertices on the
/// (faceted, sag ≤ r·(1 − cos(π/192)) = 1.4e-4) sphere within 0.1 voxel on
/// average, every edge shared by two faces; the JSON reports the settings.
/// `render` to files then `tsdf-fuse --depth` gives the identical mesh
/// (depth is exact f32 in the `.npy` files).
#[test]
fn sphere_mesh_fuses_on_its_surface_and_files_match_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let (mp, cp) = write_scene(dir.path());
    let out = dir.path().join("fused.ply");
    let json = dir.path().join("r.json");
    let o = common::run(
        "tsdf-fuse",
        &[
            &mp,
            "--cameras",
            &cp,
            "-o",
            out.to_str().unwrap(),
            &format!("--json={}", json.display()),
            "-q",
            FLAGS[0],
            FLAGS[1],
            FLAGS[2],
            FLAGS[3],
            FLAGS[4],
            FLAGS[5],
        ],
        None,
    );
    common::succeeds(&o);
    let m = read_mesh(&out);
    assert!(m.faces.len() > 10_000, "{} faces", m.faces.len());
    let err = m
        .vertices
        .iter()
        .map(|p| (DVec3::from(p.map(f64::from)).length() - 1.0).abs())
        .sum::<f64>()
        / m.vertices.len() as f64;
    assert!(err < 0.002, "mean distance {err}");
    let mut edges = std::collections::HashMap::new();
    for f in &m.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    assert!(edges.values().all(|&c| c == 2), "not closed");
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(r["voxel"].as_f64(), Some(0.02));
    assert_eq!(r["views"].as_array().unwrap().len(), 20);
    assert_eq!(r["faces"].as_u64(), Some(m.faces.len() as u64));

    let renders = dir.path().join("renders");
    let o = common::run(
        "render",
        &[
            &mp,
            "--cameras",
            &cp,
            "-o",
            renders.to_str().unwrap(),
            "--outputs",
            "depth",
            "-q",
        ],
        None,
    );
    common::succeeds(&o);
    let out2 = dir.path().join("from_files.ply");
    let o = common::run(
        "tsdf-fuse",
        &[
            "--depth",
            renders.to_str().unwrap(),
            "--cameras",
            &cp,
            "-o",
            out2.to_str().unwrap(),
            "-q",
            FLAGS[0],
            FLAGS[1],
            FLAGS[2],
            FLAGS[3],
            FLAGS[4],
            FLAGS[5],
        ],
        None,
    );
    common::succeeds(&o);
    let m2 = read_mesh(&out2);
    assert_eq!(m2.vertices, m.vertices);
    assert_eq!(m2.faces, m.faces);
}

/// Bad inputs: a depth map of the wrong size (names the file and both
/// sizes), a camera without a depth map (names the camera), depth that
/// sees nothing (empty mesh: an error), a scene and --depth together
/// (usage, exit 2). None of them creates or replaces the output; NaN and
/// negative depths are dropped and counted.
#[test]
fn bad_depth_inputs_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (mp, cp) = write_scene(dir.path());
    let d = dir.path().join("depth");
    std::fs::create_dir(&d).unwrap();
    let out = dir.path().join("out.ply");
    std::fs::write(&out, b"keep me").unwrap();
    let o = out.to_str().unwrap();
    let ds = d.to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut a = vec!["--depth", ds, "--cameras", cp.as_str(), "-o", o];
        a.extend(FLAGS);
        a.extend(extra);
        common::run("tsdf-fuse", &a, None)
    };
    // v00 has no map
    let r = run(&[]);
    common::fails(&r, 1, &["\"v00\"", "v00_depth.npy"]);
    // every map present, v03 of the wrong size
    for k in 0..20 {
        let (w, h) = if k == 3 { (3, 2) } else { (192, 192) };
        std::fs::write(
            d.join(format!("v{k:02}_depth.npy")),
            encode_npy_f32(&[h, w], &vec![0.0; w * h]),
        )
        .unwrap();
    }
    let r = run(&[]);
    common::fails(&r, 1, &["v03_depth.npy", "3x2", "192x192"]);
    // all maps empty: nothing to fuse
    std::fs::write(
        d.join("v03_depth.npy"),
        encode_npy_f32(&[192, 192], &vec![0.0; 192 * 192]),
    )
    .unwrap();
    let r = run(&[]);
    common::fails(&r, 1, &["fused mesh is empty"]);
    // NaN and negative depths are missing data: still empty, and counted
    let mut bad = vec![f32::NAN; 192 * 192];
    bad[..100].fill(-1.0);
    std::fs::write(d.join("v05_depth.npy"), encode_npy_f32(&[192, 192], &bad)).unwrap();
    let r = run(&[]);
    common::fails(&r, 1, &["fused mesh is empty"]);
    let r = common::run(
        "tsdf-fuse",
        &[&mp, "--depth", ds, "--cameras", &cp, "-o", o],
        None,
    );
    common::fails(&r, 2, &["not both"]);
    let r = common::run(
        "tsdf-fuse",
        &[&mp, "--cameras", &cp, "-o", o, "--bound", "1.0"],
        None,
    );
    common::fails(&r, 2, &["--bound goes with --unbounded"]);
    assert_eq!(std::fs::read(&out).unwrap(), b"keep me");
}
