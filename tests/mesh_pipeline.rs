//! End-to-end tests of `poisson`, `decimate` and `clean` as binaries on
//! generated inputs: pipes through `-`, `--json`, SuGaR options, errors that
//! name the file, and the real armadillo scan from `shared/data`.

use assert_cmd::Command;
use glam::{DMat3, DVec3};
use splatkit::geom::mesh_ops::clean::signed_volume;
use splatkit::io::ply::{Format, mesh::parse_mesh, points::write_points};
use splatkit::model::{Camera, PointCloud};

fn bin(name: &str) -> Command {
    Command::cargo_bin(name).expect("binary built")
}

/// Fibonacci points on a sphere (outward normals), optionally offset.
fn sphere(n: usize, r: f32, c: [f32; 3]) -> PointCloud {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let mut pc = PointCloud::default();
    let mut nrm = Vec::new();
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
        let s = (1.0 - z * z).sqrt();
        let t = golden * i as f32;
        let d = [s * t.cos(), s * t.sin(), z];
        pc.positions
            .push([c[0] + r * d[0], c[1] + r * d[1], c[2] + r * d[2]]);
        nrm.push(d);
    }
    pc.normals = Some(nrm);
    pc
}

fn ply(pc: &PointCloud) -> Vec<u8> {
    let mut b = Vec::new();
    write_points(&mut b, pc, Format::BinaryLittleEndian).unwrap();
    b
}

#[test]
fn poisson_decimate_clean_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("p.json");
    let out = bin("poisson")
        .args(["-", "--depth", "6", "-o", "-", "-q"])
        .arg(format!("--json={}", json.display()))
        .write_stdin(ply(&sphere(20_000, 1.0, [0.0; 3])))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m = parse_mesh("<stdout>", &out.stdout).unwrap();
    assert!(m.scalar("density").is_some() && m.normals.is_some());
    // A unit sphere: enclosed volume within 2 % of 4π/3 (a depth-6 cell is
    // 2.2/64 ≈ 0.034; the surface is within a small fraction of that).
    let want = 4.0 / 3.0 * std::f64::consts::PI;
    assert!(
        (signed_volume(&m) - want).abs() < 0.02 * want,
        "{}",
        signed_volume(&m)
    );
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(v["faces"].as_u64().unwrap() as usize, m.faces.len());
    assert_eq!(v["parts"][0]["poisson"]["depth"], 6);

    let dec = bin("splatkit")
        .args(["decimate", "-", "--faces", "2000", "-q", "-o", "-"])
        .write_stdin(out.stdout.clone())
        .output()
        .unwrap();
    assert!(dec.status.success());
    let cl = bin("clean")
        .args(["-", "-o", "-", "--json=/dev/null"])
        .write_stdin(dec.stdout)
        .output()
        .unwrap();
    assert!(cl.status.success());
    let m = parse_mesh("<stdout>", &cl.stdout).unwrap();
    assert!(
        m.faces.len() <= 2000 && m.faces.len() > 1800,
        "{}",
        m.faces.len()
    );
    assert!(
        m.scalar("density").is_some(),
        "attributes survive decimate and clean"
    );
}

#[test]
fn split_by_cameras_reconstructs_foreground_and_background() {
    let dir = tempfile::tempdir().unwrap();
    // cameras on a circle of radius 2 around the origin looking inward
    let cams: Vec<Camera> = (0..8)
        .map(|i| {
            let a = i as f64 * std::f64::consts::FRAC_PI_4;
            let c = DVec3::new(2.0 * a.cos(), 2.0 * a.sin(), 0.0);
            let fwd = (-c).normalize();
            let right = fwd.cross(DVec3::Z).normalize();
            let down = fwd.cross(right);
            let r_c2w = DMat3::from_cols(right, down, fwd);
            let r = r_c2w.transpose();
            Camera::pinhole(
                format!("{i:03}"),
                64,
                64,
                50.0,
                50.0,
                32.0,
                32.0,
                r,
                -(r * c),
            )
        })
        .collect();
    let cam_file = dir.path().join("cameras.json");
    splatkit::io::cameras::write_gs_json(&cam_file, &cams).unwrap();
    // R = 1.1 * 2 = 2.2: a sphere at the centre is foreground, one at x = 6
    // is background (< 8.8), one at x = 20 is dropped.
    let mut pc = sphere(8000, 0.8, [0.0; 3]);
    for (n, c) in [(4000, [6.0, 0.0, 0.0]), (500, [20.0, 0.0, 0.0])] {
        let s = sphere(n, 0.8, c);
        pc.positions.extend(s.positions);
        pc.normals.as_mut().unwrap().extend(s.normals.unwrap());
    }
    let input = dir.path().join("pts.ply");
    std::fs::write(&input, ply(&pc)).unwrap();
    let out = bin("poisson")
        .arg(&input)
        .args(["--depth", "6", "--split-by-cameras"])
        .arg(&cam_file)
        .args(["--json", "-q", "-o"])
        .arg(dir.path().join("m.ply"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["dropped_far"], 500);
    assert_eq!(v["parts"][0]["part"], "foreground");
    assert_eq!(v["parts"][0]["points"], 8000);
    assert_eq!(v["parts"][1]["part"], "background");
    assert_eq!(v["parts"][1]["points"], 4000);
    // --foreground-only keeps one part; --bbox alone splits without cameras
    let out = bin("poisson")
        .arg(&input)
        .args([
            "--depth",
            "5",
            "--bbox",
            "-1,-1,-1,1,1,1",
            "--foreground-only",
            "--json",
            "-q",
            "-o",
        ])
        .arg(dir.path().join("f.ply"))
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["parts"].as_array().unwrap().len(), 1);
    assert_eq!(v["parts"][0]["points"], 8000);
}

#[test]
fn bad_inputs_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let no_normals = dir.path().join("nonormals.ply");
    let mut pc = sphere(100, 1.0, [0.0; 3]);
    pc.normals = None;
    std::fs::write(&no_normals, ply(&pc)).unwrap();
    let out = bin("poisson")
        .arg(&no_normals)
        .args(["-o"])
        .arg(dir.path().join("x.ply"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("nonormals.ply") && err.contains("no normals"),
        "{err}"
    );
    assert!(!dir.path().join("x.ply").exists(), "no output on error");

    let three = dir.path().join("three.ply");
    std::fs::write(&three, ply(&sphere(3, 1.0, [0.0; 3]))).unwrap();
    let out = bin("poisson")
        .arg(&three)
        .args(["-o", "-"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("at least 4"));

    let garbage = dir.path().join("garbage.ply");
    std::fs::write(
        &garbage,
        b"ply\nformat binary_little_endian 1.0\nelement vertex 99\nproperty float x\nend_header\n",
    )
    .unwrap();
    for b in ["poisson", "clean", "decimate"] {
        let mut c = bin(b);
        c.arg(&garbage).args(["-o", "-"]);
        if b == "decimate" {
            c.args(["--faces", "10"]);
        }
        let out = c.output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{b}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("garbage.ply"),
            "{b}"
        );
    }
    let out = bin("poisson")
        .arg(&three)
        .args(["--bbox", "1,2,3", "-o", "-"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("6 finite numbers"));
}

/// The Stanford armadillo (38k points, normals pointing inward): with
/// --flip-normals the mesh is closed and outward (positive volume), and
/// without it inside-out (negative volume).
#[test]
fn armadillo_scan() {
    let Some(p) = splatkit::testing::shared_data("scanned-meshes/armadillo_points_normals.ply")
    else {
        return;
    };
    let run = |flip: bool| {
        let mut c = bin("poisson");
        c.arg(&p).args(["--depth", "7", "-q", "-o", "-"]);
        if flip {
            c.arg("--flip-normals");
        }
        let out = c.output().unwrap();
        assert!(out.status.success());
        parse_mesh("<stdout>", &out.stdout).unwrap()
    };
    let (a, b) = (run(true), run(false));
    assert!(signed_volume(&a) > 0.0 && signed_volume(&b) < 0.0);
    assert!(a.vertices.len() > 10_000);
}
