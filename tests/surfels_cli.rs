//! 2DGS surfels through the commands: `tsdf-fuse` of a generated surfel
//! sphere lands on the sphere; `info`, `render`, `tsdf-fuse` and
//! `splat2points` on the 2DGS fixture (`testdata/surfels/`, written as
//! 2DGS's `save_ply` does); and the common wrong-kind error from commands
//! that do not take surfels.

mod common;

use std::path::{Path, PathBuf};

use splatkit::io::any::{load_mesh, save_surfels};
use splatkit::model::Mesh;
use splatkit::testing::{cameras_around, surfel_sphere};

const FIXTURE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/testdata/surfels/point_cloud.ply"
);

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Cameras all around the unit sphere, written as a 3DGS cameras.json.
fn write_cameras(dir: &Path, n: usize, size: u32, f: f64) -> PathBuf {
    let p = dir.join("cameras.json");
    splatkit::io::cameras::write_gs_json(&p, &cameras_around(n, 3.5, size, f)).unwrap();
    p
}

/// RMS and max of | |v| − r | over the mesh's vertices.
fn radial_error(m: &Mesh, r: f64) -> (f64, f64) {
    let e: Vec<f64> = m
        .vertices
        .iter()
        .map(|v| (glam::DVec3::from(v.map(f64::from)).length() - r).abs())
        .collect();
    let rms = (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
    (rms, e.iter().cloned().fold(0.0, f64::max))
}

fn ok(o: &std::process::Output) {
    assert!(
        o.status.success(),
        "exit {:?}: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// 6,000 surfels (σ = 0.04 and 0.032) tangent to the unit sphere, rendered
/// by `tsdf-fuse` from 80 cameras all around (192², f = 206) with 2DGS's
/// surfel depth at its default ratio 0 (the mean depth) and at ratio 1
/// (the median), fused with voxel 0.02 and 2DGS's cluster filter
/// (`--keep-clusters 1`): the mesh's vertices lie on the sphere within 0.1
/// voxel RMS and 0.5 voxel at most (the issue's target is 0.1 voxel).
///
/// Measured (the output is deterministic): 0.080 voxel RMS, max 0.34
/// (ratio 0); 0.087, max 0.36 (ratio 1). The same fusion of the exact
/// sphere mesh gives 0.056 RMS, the floor of the TSDF itself (nearest-pixel
/// depth lookup on a slope, marching cubes). With 20 cameras the figures
/// are 0.136 / 0.143 (exact mesh 0.098), which is why 80 are used: the
/// excess over the mesh comes from the silhouettes, where a disc seen
/// edge-on still covers pixels through its low-pass term, and more views
/// outvote those samples in each voxel's weighted average. With the
/// sphere's own masks (as 2DGS's DTU runs use) 20 cameras give 0.116 /
/// 0.131. The flat discs themselves stand off the sphere by d²/2r at
/// distance d from their centre (≤ 0.0008 within one σ, 0.04 voxel).
#[test]
fn tsdf_fuse_of_a_surfel_sphere_lands_on_the_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("surfels.ply");
    save_surfels(&ply, &surfel_sphere(6000, 1.0, 0.04, 7)).unwrap();
    let cams = write_cameras(dir.path(), 80, 192, 206.0);
    let voxel = 0.02;
    for ratio in ["0", "1"] {
        let out = dir.path().join(format!("fused_{ratio}.ply"));
        let json = dir.path().join(format!("r_{ratio}.json"));
        let o = common::run(
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
                "--depth-ratio",
                ratio,
                "--keep-clusters",
                "1",
                "-o",
                s(&out),
                &format!("--json={}", s(&json)),
            ],
            None,
        );
        ok(&o);
        let m = load_mesh(&out, "test").unwrap();
        let (rms, max) = radial_error(&m, 1.0);
        eprintln!(
            "depth ratio {ratio}: {} vertices, radial error RMS {:.3} voxel, max {:.3} voxel",
            m.vertices.len(),
            rms / voxel,
            max / voxel
        );
        assert!(m.vertices.len() > 10_000, "{} vertices", m.vertices.len());
        assert!(rms < 0.1 * voxel, "RMS {rms} ≥ 0.1 voxel");
        assert!(max < 0.5 * voxel, "max {max} ≥ 0.5 voxel");
        let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert_eq!(
            r["depth_ratio"].as_f64().unwrap(),
            ratio.parse::<f64>().unwrap()
        );
    }
}

/// Without `--depth-ratio`, surfels are fused at 2DGS's default ratio 0
/// (its `render.py` fuses the mean depth unless told otherwise), and `--dtu`
/// gives its DTU scripts' 1.
#[test]
fn tsdf_fuse_of_the_2dgs_fixture_uses_2dgs_depth_ratio() {
    let dir = tempfile::tempdir().unwrap();
    let cams = write_cameras(dir.path(), 8, 96, 80.0);
    for (extra, want) in [(None, 0.0), (Some("--dtu"), 1.0)] {
        let out = dir.path().join("fused.ply");
        let json = dir.path().join("r.json");
        let mut args = vec![
            FIXTURE,
            "--cameras",
            s(&cams),
            "--voxel",
            "0.04",
            "--sdf-trunc",
            "0.16",
            "-o",
            s(&out),
        ];
        let j = format!("--json={}", s(&json));
        args.push(&j);
        args.extend(extra);
        ok(&common::run("tsdf-fuse", &args, None));
        let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert_eq!(r["depth_ratio"].as_f64().unwrap(), want);
        let m = load_mesh(&out, "test").unwrap();
        assert!(m.faces.len() > 100, "{} faces", m.faces.len());
        // 128 discs of σ ≈ 0.2 tangent to the unit sphere: a closed shell near it
        let (rms, _) = radial_error(&m, 1.0);
        assert!(rms < 0.1, "RMS {rms}");
    }
}

/// `info` names the kind, the count and the SH degree of the 2DGS fixture.
#[test]
fn info_describes_the_2dgs_fixture() {
    let o = common::run("info", &[FIXTURE, "--json"], None);
    ok(&o);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v[0]["kind"], "surfels");
    assert_eq!(v[0]["surfels"], 128);
    assert_eq!(v[0]["sh_degree"], 3);
    let o = common::run("info", &[FIXTURE], None);
    ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("kind:       surfels (2DGS surfels)"),
        "{text}"
    );
    assert!(text.contains("surfels:    128"), "{text}");
}

/// `render` on the 2DGS fixture writes colour, depth, alpha and normal
/// images; the depth of the central pixel of each view is the distance to
/// the sphere's front (3.5 − 1 = 2.5) within the discs' stand-off (a disc
/// hit at distance d from its centre lies d²/2 off the unit sphere: 0.08 at
/// d = 0.4, beyond 2σ of these discs).
#[test]
fn render_draws_the_2dgs_fixture() {
    let dir = tempfile::tempdir().unwrap();
    let cams = write_cameras(dir.path(), 4, 64, 60.0);
    let out = dir.path().join("r");
    ok(&common::run(
        "render",
        &[FIXTURE, "--cameras", s(&cams), "-o", s(&out)],
        None,
    ));
    for k in 0..4 {
        for suffix in [
            ".png",
            "_depth.npy",
            "_depth.png",
            "_alpha.png",
            "_normal.png",
        ] {
            assert!(
                out.join(format!("v{k:02}{suffix}")).is_file(),
                "v{k:02}{suffix}"
            );
        }
        let d =
            splatkit::io::depth::read_depth(&out.join(format!("v{k:02}_depth.npy")), 1.0).unwrap();
        let c = d.depth[32 * 64 + 32];
        assert!((c - 2.5).abs() < 0.1, "view {k}: centre depth {c}");
    }
}

/// `splat2points` on the 2DGS fixture: the default for surfels is their
/// rendered depth (points on the shell of discs, measured on 4 + 4 orbit
/// views: median 0.026 off the sphere, 97% within 0.1; 99.9% of the normals
/// outward); `--method centers`
/// gives the 128 centres with their disc normals turned outward;
/// `--method levelset` is a usage error (exit 2) saying why.
#[test]
fn splat2points_takes_the_2dgs_fixture() {
    let dir = tempfile::tempdir().unwrap();
    let cams = write_cameras(dir.path(), 8, 96, 80.0);
    let out = dir.path().join("p.ply");
    ok(&common::run(
        "splat2points",
        &[FIXTURE, "--cameras", s(&cams), "--all-views", "-o", s(&out)],
        None,
    ));
    let p = splatkit::io::any::load_points(&out, "test").unwrap();
    assert!(p.positions.len() > 1000, "{} points", p.positions.len());
    // 128 discs of σ ≈ 0.2: a disc hit at distance d from its centre
    // stands d²/2 off the unit sphere (0.08 at 2σ, 0.3 at the 3σ cutoff)
    let n = p.normals.as_ref().unwrap();
    let mut off: Vec<f32> = p
        .positions
        .iter()
        .map(|x| (glam::Vec3::from(*x).length() - 1.0).abs())
        .collect();
    let outward = p
        .positions
        .iter()
        .zip(n)
        .filter(|(x, nn)| glam::Vec3::from(**nn).dot(glam::Vec3::from(**x)) > 0.0)
        .count();
    off.sort_by(f32::total_cmp);
    let frac = |t: f32| off.iter().filter(|&&e| e < t).count() as f64 / off.len() as f64;
    assert!(off[off.len() / 2] < 0.05, "median {}", off[off.len() / 2]);
    assert!(frac(0.1) > 0.95, "{} within 0.1", frac(0.1));
    // the rest: silhouette pixels of discs seen edge-on, whose ray meets
    // the disc's plane far behind (2DGS's kernel gives them that depth)
    assert!(frac(0.35) > 0.99, "{} within 0.35", frac(0.35));
    assert!(
        outward as f64 > 0.99 * off.len() as f64,
        "{outward} of {} normals outward",
        off.len()
    );
    let out = dir.path().join("c.ply");
    ok(&common::run(
        "splat2points",
        &[
            FIXTURE,
            "--cameras",
            s(&cams),
            "--all-views",
            "--method",
            "centers",
            "-o",
            s(&out),
        ],
        None,
    ));
    let p = splatkit::io::any::load_points(&out, "test").unwrap();
    assert_eq!(p.positions.len(), 128);
    for (x, nn) in p.positions.iter().zip(p.normals.as_ref().unwrap()) {
        let (x, nn) = (glam::Vec3::from(*x), glam::Vec3::from(*nn));
        assert!(nn.dot(x.normalize()) > 0.999, "normal {nn} at {x}");
    }
    let o = common::run(
        "splat2points",
        &[
            FIXTURE,
            "--cameras",
            s(&cams),
            "--method",
            "levelset",
            "-o",
            s(&out),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("needs 3D Gaussians"), "{err}");
}

/// Commands that do not take surfels refuse the 2DGS fixture with the
/// common wrong-kind error (exit 1), naming the file and what they take;
/// those that take 3D Gaussians also say what tells surfels apart.
#[test]
fn commands_without_surfels_give_the_wrong_kind_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.ply");
    let o_ = s(&out);
    let cases: [(&str, Vec<&str>, &str); 5] = [
        (
            "poisson",
            vec![FIXTURE, "-o", o_],
            "poisson takes a point cloud or a mesh",
        ),
        ("clean", vec![FIXTURE, "-o", o_], "clean takes a mesh"),
        (
            "chamfer",
            vec![FIXTURE, FIXTURE],
            "chamfer takes a mesh or a point cloud",
        ),
        (
            "prune-triangles",
            vec![FIXTURE, "-o", o_],
            "prune-triangles takes a triangle-splat soup",
        ),
        (
            "bind-gaussians",
            vec![FIXTURE, "--rebind", FIXTURE, "-o", o_],
            "takes Gaussian splats, and this file holds 2DGS surfels (a 2DGS model: two scales",
        ),
    ];
    for (cmd, args, needle) in cases {
        let o = common::run(cmd, &args, None);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{cmd}: {err}");
        assert!(err.contains(needle), "{cmd}: {err}");
        assert!(err.contains("holds 2DGS surfels"), "{cmd}: {err}");
        assert!(err.contains("point_cloud.ply"), "{cmd}: {err}");
        assert!(!out.exists(), "{cmd} wrote an output");
    }
}
