//! `splat2points` as a binary on the generated Gaussian torus: a 3DGS model
//! folder (latest iteration, cameras.json), the test-view holdout, the
//! `level`/`camera` provenance properties, every method's points near the
//! true surface with outward normals, and a pipe into `poisson`.

use assert_cmd::Command;
use glam::DVec3;
use splatkit::geom::scenes::orbit::{OrbitRing, orbit_cameras};
use splatkit::geom::scenes::synthetic::Torus;
use splatkit::io::ply::{Format, gaussians::write_gaussians, points::parse_points};

const T: Torus = Torus {
    major: 1.0,
    minor: 0.35,
};

fn bin(name: &str) -> Command {
    Command::cargo_bin(name).expect("binary built")
}

/// Fails the test with the command's stderr (labelled `what`) unless it
/// succeeded; returns its stdout.
fn stdout_of(out: std::process::Output, what: &str) -> Vec<u8> {
    assert!(
        out.status.success(),
        "{what}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// Writes a 3DGS model folder: iteration_100 (a decoy) and iteration_7000.
fn model_folder(dir: &std::path::Path) {
    let g = T.gaussians(120, 42, 0.004, 50, 1);
    for it in [100, 7000] {
        let d = dir.join(format!("point_cloud/iteration_{it}"));
        std::fs::create_dir_all(&d).unwrap();
        let mut f = std::fs::File::create(d.join("point_cloud.ply")).unwrap();
        let g = if it == 100 {
            T.gaussians(10, 5, 0.004, 0, 1)
        } else {
            g.clone()
        };
        write_gaussians(&mut f, &g, Format::BinaryLittleEndian).unwrap();
    }
    let mut cams = orbit_cameras(
        &T.mesh(32, 12).vertices,
        &OrbitRing {
            views: 8,
            width: 128,
            height: 128,
            fov_deg: 50.0,
            elevation_deg: 35.0,
            radius: Some(3.6),
            up: DVec3::Y,
        },
    )
    .unwrap();
    cams.extend(
        orbit_cameras(
            &T.mesh(32, 12).vertices,
            &OrbitRing {
                views: 8,
                width: 128,
                height: 128,
                fov_deg: 50.0,
                elevation_deg: -35.0,
                radius: Some(3.6),
                up: DVec3::Y,
            },
        )
        .unwrap()
        .into_iter()
        .enumerate()
        .map(|(k, mut c)| {
            c.name = format!("below_{k:03}");
            c
        }),
    );
    splatkit::io::cameras::write_gs_json(&dir.join("cameras.json"), &cams).unwrap();
}

/// Points of every method lie near the torus with outward normals. Bounds:
/// level set ≤ 0.03 from the surface (offset ≈ 0.006, plus the flat
/// Gaussians' sagitta); centres ≤ 1e-4 (they are on it); depth-map points
/// ≤ 0.05 (median depth of overlapping splats). Normals: ≥ 95% within 25°
/// of the outward normal, none inward by more than 90° for the level set.
#[test]
fn methods_sample_the_surface() {
    let dir = tempfile::tempdir().unwrap();
    model_folder(dir.path());
    for (method, bound) in [("levelset", 0.03), ("centers", 1e-4), ("depth", 0.05)] {
        let out = bin("splat2points")
            .arg(dir.path())
            .args([
                "--method",
                method,
                "--max-points",
                "40000",
                "--provenance",
                "-q",
            ])
            .output()
            .unwrap();
        let out = stdout_of(out, method);
        let pc = parse_points("pts", &out).unwrap();
        assert!(pc.len() > 1000, "{method}: {} points", pc.len());
        let normals = pc.normals.as_ref().unwrap();
        let mut off = 0;
        for (p, n) in pc.positions.iter().zip(normals) {
            let p = p.map(f64::from);
            let d = T.distance(p);
            assert!(d <= bound, "{method}: point {p:?} is {d} from the torus");
            // outward normal of the torus at p
            let ring = (p[0] * p[0] + p[2] * p[2]).sqrt();
            let c = [p[0] / ring * T.major, 0.0, p[2] / ring * T.major];
            let o = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let l = (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt();
            let cos = (o[0] * n[0] as f64 + o[1] * n[1] as f64 + o[2] * n[2] as f64) / l;
            if cos < 25f64.to_radians().cos() {
                off += 1;
            }
            if method == "levelset" {
                assert!(cos > 0.0, "inward normal at {p:?}");
            }
        }
        assert!(
            off * 20 <= pc.len(),
            "{method}: {off} of {} normals beyond 25°",
            pc.len()
        );
        if method != "centers" {
            let names: Vec<&str> = pc.extras.item.iter().map(|p| p.name.as_str()).collect();
            assert!(
                names.contains(&"level") && names.contains(&"camera"),
                "{names:?}"
            );
        }
    }
}

/// `--depth median` and `--depth gaussian` (SuGaR's Gaussian-rasterised
/// depth, blended over a background of −1) are both accepted, give
/// different point sets from the same seed (the rays start at other depths
/// and the Gaussian mode takes its density neighbours around the ray's
/// point), and both stay on the torus (the same 0.03 bound as the default:
/// the depth only chooses where a ray's samples lie, the point is still the
/// density crossing). The JSON names the depth source.
#[test]
fn median_and_gaussian_depths_differ() {
    let dir = tempfile::tempdir().unwrap();
    model_folder(dir.path());
    let mut sets = Vec::new();
    for depth in ["median", "gaussian"] {
        let json = dir.path().join(format!("{depth}.json"));
        let out = bin("splat2points")
            .arg(dir.path())
            .args(["--depth", depth, "--max-points", "20000", "-q"])
            .arg(format!("--json={}", json.display()))
            .output()
            .unwrap();
        let out = stdout_of(out, depth);
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert_eq!(v["depth"], depth, "{v}");
        let pc = parse_points("pts", &out).unwrap();
        assert!(pc.len() > 500, "{depth}: {} points", pc.len());
        for p in &pc.positions {
            let d = T.distance(p.map(f64::from));
            assert!(d <= 0.03, "{depth}: point {p:?} is {d} from the torus");
        }
        sets.push(pc.positions);
    }
    assert_ne!(sets[0], sets[1], "same points for both depths");
}

/// The holdout drops every 8th name-sorted view (2 of 16), `--all-views`
/// keeps them, `--iteration` picks the decoy; the output pipes into poisson.
#[test]
fn holdout_iteration_and_pipe() {
    let dir = tempfile::tempdir().unwrap();
    model_folder(dir.path());
    let json = |extra: &[&str]| -> serde_json::Value {
        let out = bin("splat2points")
            .arg(dir.path())
            .args(["--max-points", "2000", "-q", "-o"])
            .arg(dir.path().join("p.ply"))
            .args(extra)
            .arg("--json")
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let v = json(&[]);
    assert_eq!(
        (v["views"].as_u64(), v["views_total"].as_u64()),
        (Some(14), Some(16))
    );
    assert!(v["scene"].as_str().unwrap().contains("iteration_7000"));
    assert_eq!(json(&["--all-views"])["views"], 16);
    assert_eq!(json(&["--iteration", "100"])["gaussians"], 50);
    let pts = bin("splat2points")
        .arg(dir.path())
        .args(["--max-points", "100000", "-q"])
        .output()
        .unwrap();
    assert!(pts.status.success());
    let mesh = bin("poisson")
        .args(["-", "--depth", "7", "-q", "-o", "-"])
        .write_stdin(pts.stdout)
        .output()
        .unwrap();
    assert!(
        mesh.status.success(),
        "{}",
        String::from_utf8_lossy(&mesh.stderr)
    );
    let m = splatkit::io::ply::mesh::parse_mesh("m", &mesh.stdout).unwrap();
    let mean = m
        .vertices
        .iter()
        .map(|v| T.distance(v.map(f64::from)))
        .sum::<f64>()
        / m.vertices.len() as f64;
    // depth 7: cells of ~0.03; the mesh sits within a cell on average
    assert!(mean < 0.03, "mean vertex distance {mean}");
}

/// A missing camera file or model folder is an error naming it.
#[test]
fn missing_inputs_are_named() {
    let dir = tempfile::tempdir().unwrap();
    bin("splat2points")
        .arg(dir.path())
        .assert()
        .failure()
        .stderr(predicates::str::contains("point_cloud"));
}

/// Bad input gets an error naming what is wrong and a non-zero exit: a PLY
/// without Gaussian properties, levels outside (0, 1), cameras that see
/// nothing of the scene, a camera file together with `--orbit`, a malformed
/// `--size`.
#[test]
fn bad_input_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    model_folder(dir.path());
    let scene = dir
        .path()
        .join("point_cloud/iteration_7000/point_cloud.ply");
    let cams = dir.path().join("cameras.json");
    // exit 1 for bad data, 2 for a bad argument (the CLI convention)
    let fails_with = |code: i32, args: Vec<std::ffi::OsString>, expect: &str| {
        let out = bin("splat2points").args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
        assert!(err.contains(expect), "{args:?}: {err:?} lacks {expect:?}");
        assert!(out.stdout.is_empty(), "{args:?} wrote to stdout");
    };
    let fails = |args, expect: &str| fails_with(1, args, expect);
    let os = |v: &[&str]| v.iter().map(std::ffi::OsString::from).collect::<Vec<_>>();
    // a plain point cloud: no opacity / scales / rotations
    let pts = dir.path().join("plain.ply");
    std::fs::write(
        &pts,
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 1 1\n",
    )
    .unwrap();
    let mut a = os(&["--cameras"]);
    a.push(cams.clone().into());
    a.insert(0, pts.clone().into());
    fails(
        a,
        "plain.ply: element 'vertex' is not a 3DGS Gaussian layout: missing properties",
    );
    for level in ["0", "1", "1.5", "-0.2", "nan"] {
        let mut a = vec![
            scene.clone().into(),
            "--cameras".into(),
            cams.clone().into(),
        ];
        a.extend(os(&["--level", level]));
        fails_with(2, a, "not in (0, 1)");
    }
    // the same orbit, but around a point 100 units away: nothing in view
    let far: Vec<[f32; 3]> = T
        .mesh(32, 12)
        .vertices
        .iter()
        .map(|v| [v[0] + 100.0, v[1], v[2]])
        .collect();
    let away = orbit_cameras(
        &far,
        &OrbitRing {
            views: 8,
            width: 64,
            height: 64,
            fov_deg: 50.0,
            elevation_deg: 35.0,
            radius: Some(3.6),
            up: DVec3::Y,
        },
    )
    .unwrap();
    let away_path = dir.path().join("away.json");
    splatkit::io::cameras::write_gs_json(&away_path, &away).unwrap();
    for method in ["levelset", "centers", "depth"] {
        let mut a = vec![
            scene.clone().into(),
            "--cameras".into(),
            away_path.clone().into(),
        ];
        a.extend(os(&["--all-views", "--method", method]));
        fails(a, "sees any of the");
    }
    let mut a = vec![dir.path().into()];
    a.extend(os(&["--orbit", "4"]));
    fails_with(2, a, "not both");
    let mut a = vec![scene.clone().into()];
    a.extend(os(&["--orbit", "4", "--size", "64by64"]));
    fails_with(2, a, "--size");
    let mut a = vec![
        scene.clone().into(),
        "--cameras".into(),
        cams.clone().into(),
    ];
    a.extend(os(&["--level", "0.3,abc"]));
    fails_with(2, a, "not a number");
    let mut a = vec![scene.clone().into()];
    a.extend(os(&["--level", "0.3"]));
    fails_with(2, a, "--orbit N");
}

/// `--orbit` makes its own cameras (two rings here) when a scene comes
/// without any; the points still lie on the torus (same 0.03 bound as the
/// camera-file run above).
#[test]
fn orbit_cameras_without_a_camera_file() {
    let dir = tempfile::tempdir().unwrap();
    model_folder(dir.path());
    let scene = dir
        .path()
        .join("point_cloud/iteration_7000/point_cloud.ply");
    let json = dir.path().join("run.json");
    let out = bin("splat2points")
        .arg(&scene)
        .args([
            "--orbit",
            "6",
            "--elevation",
            "35,-35",
            "--up",
            "0,1,0",
            "--size",
            "128x128",
            "--max-points",
            "20000",
            "-q",
        ])
        .arg(format!("--json={}", json.display()))
        .output()
        .unwrap();
    let out = stdout_of(out, "orbit");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(v["views"], 12, "two rings of six, none held out: {v}");
    let pc = parse_points("pts", &out).unwrap();
    assert!(pc.len() > 5000, "{} points", pc.len());
    for p in &pc.positions {
        let d = T.distance(p.map(f64::from));
        assert!(d <= 0.03, "point {p:?} is {d} from the torus");
    }
}

/// `scripts/sugar_mesh.sh` runs the whole recipe on a model folder (depth 7
/// and 20k faces to stay quick) and leaves a mesh near the torus: with the
/// 10% density trim and the fg/bg split the vertices stay within 0.03 on
/// average (cells of ~0.03 at depth 7).
#[test]
fn sugar_script_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    model_folder(dir.path());
    let out = dir.path().join("mesh");
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/sugar_mesh.sh");
    let res = std::process::Command::new("bash")
        .arg(&script)
        .arg(dir.path())
        .arg(&out)
        .args(["20000", "0.3", "7"])
        .env("SPLATKIT", env!("CARGO_BIN_EXE_splatkit"))
        .output()
        .unwrap();
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let bytes = std::fs::read(out.join("sugar_coarse_mesh.ply")).unwrap();
    let m = splatkit::io::ply::mesh::parse_mesh("m", &bytes).unwrap();
    assert!(
        m.faces.len() <= 20_000 && m.faces.len() > 5_000,
        "{} faces",
        m.faces.len()
    );
    let mean = m
        .vertices
        .iter()
        .map(|v| T.distance(v.map(f64::from)))
        .sum::<f64>()
        / m.vertices.len() as f64;
    assert!(mean < 0.03, "mean vertex distance {mean}");
}

/// The real captures (biker, 152,746 Gaussians; guitar, 90,854) go through
/// `splat2points --orbit | poisson | clean` at a small scale and come out as
/// meshes that sit on the splats: ≥ 90% of the mesh vertices lie within 3
/// finest cells of an opaque Gaussian centre (a vertex is placed on the
/// level set, at most a few σ from the centres around it), the kept
/// component carries ≥ 20,000 faces, and ≥ 95% of the level-set points lie
/// within 3 cells of the mesh's vertices (the mesh covers the samples).
#[test]
fn real_scenes_become_meshes() {
    use splatkit::geom::sampling::knn::NnIndex;
    for (name, up) in [("biker", "0,-1,0"), ("guitar", "0,-1,0")] {
        let Some(scene) = splatkit::testing::shared_data(&format!(
            "3dgs-playcanvas-{name}/{name}.decoded_sh0.ply"
        )) else {
            return;
        };
        let pts = bin("splat2points")
            .arg(&scene)
            .args([
                "--orbit",
                "8",
                "--elevation",
                "30,-25",
                "--up",
                up,
                "--size",
                "256x192",
                "--max-points",
                "150000",
                "-q",
            ])
            .output()
            .unwrap();
        let pts = stdout_of(pts, name);
        let cloud = parse_points("pts", &pts).unwrap();
        let json = tempfile::NamedTempFile::new().unwrap();
        let raw = bin("poisson")
            .args([
                "-",
                "--depth",
                "8",
                "--trim-quantile",
                "0.1",
                "-q",
                "-o",
                "-",
            ])
            .arg(format!("--json={}", json.path().display()))
            .write_stdin(pts)
            .output()
            .unwrap();
        let raw = stdout_of(raw, name);
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(json.path()).unwrap()).unwrap();
        let cell = report["parts"][0]["poisson"]["cell_size"]
            .as_f64()
            .expect("poisson reports its cell size");
        let clean = bin("clean")
            .args(["-", "--min-component-area", "0.01", "-q", "-o", "-"])
            .write_stdin(raw)
            .output()
            .unwrap();
        let clean = stdout_of(clean, name);
        let m = splatkit::io::ply::mesh::parse_mesh("m", &clean).unwrap();
        assert!(m.faces.len() >= 20_000, "{name}: {} faces", m.faces.len());
        let g = splatkit::io::ply::gaussians::parse_gaussians("g", &std::fs::read(&scene).unwrap())
            .unwrap()
            .to_raster();
        let centres: Vec<[f64; 3]> = (0..g.len())
            .filter(|&i| g.opacities[i] > 0.5)
            .map(|i| g.means[i].map(f64::from))
            .collect();
        let near = |index: &NnIndex, q: &[[f64; 3]]| {
            let d = index.nearest_distances(q);
            d.iter().filter(|&&d| d <= 3.0 * cell).count() as f64 / d.len() as f64
        };
        let verts: Vec<[f64; 3]> = m.vertices.iter().map(|v| v.map(f64::from)).collect();
        let on_splats = near(&NnIndex::new(&centres).unwrap(), &verts);
        let samples: Vec<[f64; 3]> = cloud.positions.iter().map(|v| v.map(f64::from)).collect();
        let covered = near(&NnIndex::new(&verts).unwrap(), &samples);
        eprintln!(
            "{name}: {} points, cell {cell:.4}, {} faces, vertices on splats {on_splats:.3}, samples covered {covered:.3}",
            cloud.len(),
            m.faces.len()
        );
        assert!(
            on_splats >= 0.90,
            "{name}: {on_splats} of the vertices near the splats"
        );
        assert!(
            covered >= 0.95,
            "{name}: {covered} of the samples near the mesh"
        );
    }
}
