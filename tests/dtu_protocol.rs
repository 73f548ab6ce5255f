//! A synthetic DTU scene, built here with the project's own writers (PLY,
//! MATLAB v5 .mat, .npz, PNG), run through `chamfer --protocol dtu` in point,
//! mesh and mesh + mask-culling modes, against mean_d2s / mean_s2d computed by
//! hand.
//!
//! Scene (millimetres; every coordinate is a dyadic rational, so the f32
//! rounding of the culled mesh and the normalise/denormalise round trip are
//! exact):
//! - STL: a 20 × 20 grid at z = 0 (spacing 1), five points at z = −2 (below
//!   the plane P = [0, 0, 1, 1]) and one far point (25, 0, 0);
//! - prediction: the grid lifted to z = 0.25, three outliers 25 above it
//!   (distance ≥ 20: discarded) and one point outside the bounding box;
//!   spacing ≥ 1 > 0.2, so downsampling keeps every point whatever the seed;
//! - ObsMask: BB = [−1, 21]×[−1, 21]×[−1, 29], Res 1, set for x ≤ 14;
//! - one camera 100 mm above the grid looking down, and a mask that is white
//!   for image columns ≤ 830: with the 24 px dilation, grid columns x ≤ 15
//!   stay and x ≥ 16 are culled.

mod common;

use std::io::Write;
use std::path::Path;

use assert_cmd::Command;
use common::dtu::{write_neus_npz, write_rgb_png};
use glam::{DMat3, DMat4, DVec3};
use splatkit::io::dtu::{ObsMask, write_obs_mask, write_plane};
use splatkit::io::ply::{Format, mesh::write_mesh, points::write_points};
use splatkit::model::{Mesh, PointCloud};

const S: f64 = 4.0;
const C: [f64; 3] = [8.0, 16.0, 32.0];

fn pred_points() -> Vec<[f64; 3]> {
    let mut v: Vec<[f64; 3]> = (0..20)
        .flat_map(|x| (0..20).map(move |y| [x as f64, y as f64, 0.25]))
        .collect();
    for x in [2.0, 5.0, 8.0] {
        v.push([x, 3.0, 25.0]);
    }
    v.push([-100.0, 0.0, 0.25]);
    v
}

fn f32s(v: &[[f64; 3]]) -> Vec<[f32; 3]> {
    v.iter().map(|p| p.map(|c| c as f32)).collect()
}

fn write_file(path: &Path, f: impl FnOnce(&mut dyn Write) -> splatkit::Result<()>) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    splatkit::io::write_output(path, f).unwrap();
}

fn build_dataset(root: &Path) {
    let mut stl: Vec<[f64; 3]> = (0..20)
        .flat_map(|x| (0..20).map(move |y| [x as f64, y as f64, 0.0]))
        .collect();
    stl.extend((0..5).map(|x| [x as f64, 0.0, -2.0]));
    stl.push([25.0, 0.0, 0.0]);
    let pc = PointCloud {
        positions: f32s(&stl),
        ..Default::default()
    };
    write_file(&root.join("Points/stl/stl024_total.ply"), |w| {
        write_points(w, &pc, Format::BinaryLittleEndian)
    });
    let dims = [23usize, 23, 30];
    let mut mask = vec![0u8; dims[0] * dims[1] * dims[2]];
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..=15 {
                mask[x + dims[0] * (y + dims[1] * z)] = 1;
            }
        }
    }
    std::fs::create_dir_all(root.join("ObsMask")).unwrap();
    let obs = ObsMask {
        mask,
        dims,
        bb: [[-1.0, -1.0, -1.0], [21.0, 21.0, 29.0]],
        res: 1.0,
    };
    write_obs_mask(&root.join("ObsMask/ObsMask24_10.mat"), &obs).unwrap();
    write_plane(&root.join("ObsMask/Plane24.mat"), [0.0, 0.0, 1.0, 1.0]).unwrap();
}

fn build_scene(dir: &Path) {
    // Camera at (10, 10, 100) mm looking down −z: x right, y down.
    let k = DMat3::from_cols(
        DVec3::new(1000.0, 0.0, 0.0),
        DVec3::new(0.0, 1000.0, 0.0),
        DVec3::new(800.0, 600.0, 1.0),
    );
    let r = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
    let t = -(r * DVec3::new(10.0, 10.0, 100.0));
    let mut rt = DMat4::from_mat3(k * r);
    rt.w_axis = (k * t).extend(1.0);
    let scale = DMat4::from_cols_array(&[
        S, 0.0, 0.0, 0.0, 0.0, S, 0.0, 0.0, 0.0, 0.0, S, 0.0, C[0], C[1], C[2], 1.0,
    ]);
    std::fs::create_dir_all(dir.join("mask")).unwrap();
    write_neus_npz(&dir.join("cameras.npz"), &[(rt, scale)]);
    // 1600 × 1200 RGB mask: white for columns ≤ 830.
    let (w, h) = (1600u32, 1200u32);
    let mut img = vec![0u8; (w * h * 3) as usize];
    for row in img.chunks_exact_mut((w * 3) as usize) {
        row[..831 * 3].fill(255);
    }
    write_rgb_png(&dir.join("mask/000.png"), w, h, &img);
}

fn run(args: &[&str], root: &Path, pred: &Path, extra: &[&Path]) -> serde_json::Value {
    let mut cmd = Command::cargo_bin("chamfer").unwrap();
    cmd.args(["--protocol", "dtu", "--scan", "24", "--dataset-dir"])
        .arg(root)
        .arg(pred)
        .args(args);
    for e in extra {
        cmd.arg(e);
    }
    let out = cmd.args(["--json", "-q"]).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn close(v: &serde_json::Value, key: &str, want: f64) {
    let got = v[key].as_f64().unwrap_or(f64::NAN);
    assert!((got - want).abs() < 1e-6, "{key}: {got} vs {want}");
}

#[test]
fn synthetic_scene_matches_hand_computed_values() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("DTU");
    build_dataset(&root);
    let scene = tmp.path().join("scan24");
    build_scene(&scene);
    let pts = pred_points();

    // Hand-computed, culling off: 300 grid points in the ObsMask at 0.25, the
    // three outliers at 25 ≥ 20 discarded; 401 STL points above the plane,
    // 400 at 0.25 and the far one at √(6² + 0.25²).
    let d2s = 0.25;
    let s2d = (400.0 * 0.25 + 36.0625f64.sqrt()) / 401.0;

    let pcd = tmp.path().join("pred_pcd.ply");
    let pc = PointCloud {
        positions: f32s(&pts),
        ..Default::default()
    };
    write_file(&pcd, |w| write_points(w, &pc, Format::BinaryLittleEndian));
    let v = run(&["--pcd"], &root, &pcd, &[]);
    close(&v, "mean_d2s", d2s);
    close(&v, "mean_s2d", s2d);
    close(&v, "overall", (d2s + s2d) / 2.0);
    assert_eq!(v["points_in_obs"], 303);
    assert_eq!(v["points_in_bb"], 403);

    // Mesh mode: one degenerate face (zero area: no up-samples), so the
    // evaluated points are the vertices; same numbers for any seed.
    let mesh = Mesh::new(f32s(&pts), vec![[0, 0, 0]]);
    let mesh_path = tmp.path().join("pred_mesh.ply");
    write_file(&mesh_path, |w| {
        write_mesh(w, &mesh, Format::BinaryLittleEndian)
    });
    for seed in ["0", "7"] {
        let v = run(&["--seed", seed], &root, &mesh_path, &[]);
        close(&v, "mean_d2s", d2s);
        close(&v, "mean_s2d", s2d);
    }

    // Culling on: the mesh in the normalised frame; grid columns x ≥ 16 (80
    // vertices) are culled. STL columns 16..19 then reach column 15:
    // √((x − 15)² + 0.25²); the far point reaches (15, 0, 0.25): √(100.0625).
    let norm: Vec<[f64; 3]> = pts
        .iter()
        .map(|p| [0, 1, 2].map(|k| (p[k] - C[k]) / S))
        .collect();
    let mesh_n = Mesh::new(f32s(&norm), vec![[0, 0, 0]]);
    let norm_path = tmp.path().join("pred_norm.ply");
    write_file(&norm_path, |w| {
        write_mesh(w, &mesh_n, Format::BinaryLittleEndian)
    });
    let cams = scene.join("cameras.npz");
    let masks = scene.join("mask");
    let v = run(
        &["--cull", "--cameras"],
        &root,
        &norm_path,
        &[&cams, Path::new("--masks"), &masks],
    );
    let ring: f64 = [1.0625f64, 4.0625, 9.0625, 16.0625]
        .iter()
        .map(|x| x.sqrt())
        .sum();
    let s2d_culled = (320.0 * 0.25 + 20.0 * ring + 100.0625f64.sqrt()) / 401.0;
    assert_eq!(v["culled_vertices"], 80);
    close(&v, "mean_d2s", d2s);
    close(&v, "mean_s2d", s2d_culled);
    close(&v, "overall", (d2s + s2d_culled) / 2.0);
}

#[test]
fn bad_dtu_inputs_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("DTU");
    build_dataset(&root);
    let pcd = tmp.path().join("p.ply");
    let pc = PointCloud {
        positions: f32s(&pred_points()),
        ..Default::default()
    };
    write_file(&pcd, |w| write_points(w, &pc, Format::BinaryLittleEndian));
    // A scan the dataset does not have: the missing files are named.
    let out = Command::cargo_bin("chamfer")
        .unwrap()
        .args(["--protocol", "dtu", "--scan", "37", "--dataset-dir"])
        .arg(&root)
        .arg(&pcd)
        .arg("--pcd")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("stl037_total.ply") && err.contains("ObsMask37_10.mat"),
        "{err}"
    );
    // A mask folder with more masks than the camera file has views.
    let scene = tmp.path().join("scan24");
    build_scene(&scene);
    std::fs::copy(scene.join("mask/000.png"), scene.join("mask/001.png")).unwrap();
    let mesh = Mesh::new(f32s(&pred_points()), vec![[0, 0, 0]]);
    let mp = tmp.path().join("m.ply");
    write_file(&mp, |w| write_mesh(w, &mesh, Format::BinaryLittleEndian));
    let out = Command::cargo_bin("chamfer")
        .unwrap()
        .args(["--protocol", "dtu", "--scan", "24", "--dataset-dir"])
        .arg(&root)
        .arg(&mp)
        .arg("--cull")
        .arg("--cameras")
        .arg(scene.join("cameras.npz"))
        .arg("--masks")
        .arg(scene.join("mask"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("1 views") && err.contains("2 masks"), "{err}");
}
