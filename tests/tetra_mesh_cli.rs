//! `tetra-mesh` (GOF's marching-tetrahedra extraction) on generated scenes
//! of flat Gaussians covering a known closed surface: the mesh lies on the
//! surface, is closed and faces outward, and agrees with `tsdf-fuse` of the
//! same scene; plus its errors and its JSON report.

mod common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use common::{fails, run, s, succeeds};
use glam::DVec3;
use splatkit::io::any::{load_mesh, save_gaussians};
use splatkit::model::Mesh;
use splatkit::testing::{
    cameras_around, flat_gaussians, sphere_surface_points, torus_surface_points,
};

/// The scene's Gaussian PLY and a cameras.json of `n` views all around.
fn scene(
    dir: &Path,
    points: &[(DVec3, DVec3)],
    sigma: f64,
    thin: f64,
    views: usize,
) -> (PathBuf, PathBuf) {
    let ply = dir.join("scene.ply");
    save_gaussians(&ply, &flat_gaussians(points, sigma, thin, 3)).unwrap();
    let cams = dir.join("cameras.json");
    splatkit::io::cameras::write_gs_json(&cams, &cameras_around(views, 3.5, 96, 100.0)).unwrap();
    (ply, cams)
}

fn tetra_mesh(ply: &Path, cams: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    let json = out.with_extension("json");
    let mut args = vec![s(ply), "--cameras", s(cams), "-o", s(out), "-q"];
    let j = format!("--json={}", s(&json));
    args.push(&j);
    args.extend_from_slice(extra);
    succeeds(&run("tetra-mesh", &args, None));
    serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap()
}

/// Every undirected edge in exactly two faces, once in each direction
/// (closed and consistently oriented); the signed volume it encloses.
fn closed_volume(m: &Mesh) -> f64 {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for f in &m.faces {
        for k in 0..3 {
            *directed.entry((f[k], f[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "edge {a}->{b} in {n} faces of one direction");
        assert_eq!(
            directed.get(&(b, a)),
            Some(&1),
            "edge {a}-{b} is on a boundary"
        );
    }
    m.faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| DVec3::from(m.vertices[i as usize].map(f64::from)));
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// 5,000 flat Gaussians (σ = 0.03 tangent, 0.0005 normal) on the unit
/// sphere, 12 views (96², f = 100): the mesh is closed, faces outward
/// (positive volume within 2 % of the ball's), and its vertices lie within
/// 0.5 % of the radius on average. Measured: mean |r − 1| = 0.00168, all of
/// it outward. Two causes, both of the scene: GOF's 0.5-opacity level of
/// thin Gaussians lies about 1.9 × the thin σ outside them (0.001), and flat
/// discs tangent to a sphere stand off it by s²/2r at distance s from their
/// centres (σ²/r on average, 0.0009). The 8-step search adds at most 1/512
/// of an edge.
///
/// `tsdf-fuse` of the same scene (voxel 0.02) lands on the same surface: the
/// Chamfer-L1 between the meshes is under 0.02 (measured 0.0140). The
/// difference is tsdf-fuse's own offset: its mesh sits 0.016 outside the
/// sphere on average (0.009 at 192²). 3DGS's median depth is the centre
/// depth of the Gaussian where T crosses 0.5, and on a convex surface that
/// centre is nearer the camera than the ray's hit.
#[test]
fn sphere_of_flat_gaussians() {
    let dir = tempfile::tempdir().unwrap();
    let (ply, cams) = scene(
        dir.path(),
        &sphere_surface_points(5000, 1.0),
        0.03,
        0.0005,
        12,
    );
    let out = dir.path().join("mesh.ply");
    let r = tetra_mesh(&ply, &cams, &out, &[]);
    let m = load_mesh(&out, "test").unwrap();
    assert_eq!(r["faces"].as_u64().unwrap() as usize, m.faces.len());
    assert_eq!(r["gaussians"], 5000);
    assert!(m.faces.len() > 1000, "{} faces", m.faces.len());
    let radial: Vec<f64> = m
        .vertices
        .iter()
        .map(|v| DVec3::from(v.map(f64::from)).length() - 1.0)
        .collect();
    let mean = radial.iter().map(|e| e.abs()).sum::<f64>() / radial.len() as f64;
    let signed = radial.iter().sum::<f64>() / radial.len() as f64;
    eprintln!(
        "sphere: {} vertices, {} faces, mean |r - 1| {mean:.5}, mean r - 1 {signed:.5}",
        m.vertices.len(),
        m.faces.len()
    );
    assert!(mean < 0.005, "mean radial error {mean}");
    let vol = closed_volume(&m);
    let ball = 4.0 / 3.0 * std::f64::consts::PI;
    assert!((vol - ball).abs() < 0.02 * ball, "volume {vol} vs {ball}");
    assert!(m.vertex_colors.is_some(), "colours by default");

    // tsdf-fuse of the same scene lands on the same surface: the Chamfer
    // mean between the two meshes is under 1 % of the radius
    let fused = dir.path().join("fused.ply");
    succeeds(&run(
        "tsdf-fuse",
        &[
            s(&ply),
            "--cameras",
            s(&cams),
            "--voxel",
            "0.02",
            "--sdf-trunc",
            "0.08",
            "--depth-trunc",
            "10",
            "-q",
            "-o",
            s(&fused),
        ],
        None,
    ));
    let fm = load_mesh(&fused, "test").unwrap();
    let fr = fm
        .vertices
        .iter()
        .map(|v| DVec3::from(v.map(f64::from)).length() - 1.0)
        .sum::<f64>()
        / fm.vertices.len() as f64;
    eprintln!("tsdf-fuse: mean r - 1 {fr:.5}");
    let o = run("chamfer", &[s(&out), s(&fused), "--json", "-q"], None);
    succeeds(&o);
    let c: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    eprintln!("tetra-mesh vs tsdf-fuse: {c}");
    let l1 = c["chamfer_l1"].as_f64().expect("chamfer_l1");
    assert!(l1 < 0.02, "Chamfer-L1 to tsdf-fuse {l1}");
    assert!(
        fr > 0.0 && fr < 0.025,
        "tsdf-fuse's mean radial offset {fr}"
    );
}

/// The same on a torus (ring 1, tube 0.5; 8,000 Gaussians, σ = 0.03 and
/// 0.0005; 8 views): vertices within 0.5 % of the tube radius on average
/// from the torus (measured 0.0018, 0.37 %), closed, outward (volume
/// 2π²Rr² within 3 %, measured +0.7 %).
#[test]
fn torus_of_flat_gaussians() {
    let dir = tempfile::tempdir().unwrap();
    let (big, small) = (1.0, 0.5);
    let (ply, cams) = scene(
        dir.path(),
        &torus_surface_points(8000, big, small),
        0.03,
        0.0005,
        8,
    );
    let out = dir.path().join("mesh.ply");
    tetra_mesh(&ply, &cams, &out, &["--no-color"]);
    let m = load_mesh(&out, "test").unwrap();
    assert!(m.vertex_colors.is_none());
    let err: Vec<f64> = m
        .vertices
        .iter()
        .map(|v| {
            let p = DVec3::from(v.map(f64::from));
            let ring = (p.x * p.x + p.z * p.z).sqrt() - big;
            ((ring * ring + p.y * p.y).sqrt() - small).abs()
        })
        .collect();
    let mean = err.iter().sum::<f64>() / err.len() as f64;
    eprintln!("torus: {} faces, mean distance {mean:.5}", m.faces.len());
    let vol = closed_volume(&m);
    let want = 2.0 * std::f64::consts::PI.powi(2) * big * small * small;
    eprintln!("torus volume {vol} vs {want}");
    assert!(mean < 0.005 * small, "mean distance {mean}");
    assert!((vol - want).abs() < 0.03 * want, "volume {vol} vs {want}");
}

/// Bad input: a mesh is the wrong kind; a camera file that sees nothing
/// leaves no tetra points; --level outside (0, 1) is a usage error. No
/// output is created.
#[test]
fn errors_are_clear() {
    let dir = tempfile::tempdir().unwrap();
    let (ply, cams) = scene(dir.path(), &sphere_surface_points(200, 1.0), 0.1, 0.001, 4);
    let out = dir.path().join("out.ply");
    let o = run(
        "tetra-mesh",
        &[
            s(&ply),
            "--cameras",
            s(&cams),
            "--level",
            "1.5",
            "-o",
            s(&out),
        ],
        None,
    );
    fails(&o, 2, &["--level"]);
    // cameras looking away: every point is outside every view
    let away = dir.path().join("away.json");
    let mut c = cameras_around(4, 3.5, 64, 80.0);
    for cam in &mut c {
        let (r, t) = splatkit::model::Camera::pose_from_c2w(
            cam.rotation.transpose() * glam::DMat3::from_diagonal(DVec3::new(-1.0, 1.0, -1.0)),
            cam.center(),
        );
        cam.rotation = r;
        cam.translation = t;
    }
    splatkit::io::cameras::write_gs_json(&away, &c).unwrap();
    let o = run(
        "tetra-mesh",
        &[s(&ply), "--cameras", s(&away), "-o", s(&out)],
        None,
    );
    fails(&o, 1, &["tetra points", "scene.ply"]);
    assert!(!out.exists());
    // a mesh is not a splat scene
    let mesh = dir.path().join("m.ply");
    splatkit::io::any::save_mesh(
        &mesh,
        &splatkit::testing::uv_sphere(8, 1.0),
        splatkit::io::detect::FileFormat::Ply,
        &Default::default(),
    )
    .unwrap();
    let o = run(
        "tetra-mesh",
        &[s(&mesh), "--cameras", s(&cams), "-o", s(&out)],
        None,
    );
    fails(&o, 1, &["m.ply"]);
    assert!(!out.exists());
}
