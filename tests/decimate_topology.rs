//! `decimate` keeps the topology of the mesh: decimating a mesh in which
//! `clean`'s own checks find nothing (no vertices on one point, no
//! degenerate, duplicate or non-manifold faces) gives a mesh in which they
//! find nothing either, with the same pieces and Euler characteristic, at
//! every target (issue 28: after decimating a clean Poisson mesh to 200k
//! faces `clean` found 3 duplicate and 3 non-manifold faces; meshoptimizer,
//! the engine then, does not check the link condition; the engine now is
//! `geom::mesh_ops::edge_collapse`). Checked on generated meshes (a fine UV
//! sphere, a thin torus), on the Stanford bunny (open borders) and a
//! Poisson mesh of the Stanford armadillo, and through the binaries on a
//! Poisson mesh of a real 3DGS capture (the issue's pipeline: `splat2points
//! | poisson | clean | decimate | clean --json`).

use std::path::Path;
use std::process::Command;

use splatkit::geom::mesh_ops::clean::face_components;
use splatkit::geom::mesh_ops::cleanup::{CleanSteps, clean_mesh};
use splatkit::geom::mesh_ops::decimate::{Target, decimate};
use splatkit::geom::meshing::poisson::PoissonParams;
use splatkit::geom::meshing::poisson::pipeline::{PipelineOptions, run_pipeline};
use splatkit::io::any::{load_mesh, load_points};
use splatkit::model::Mesh;
use splatkit::testing::{shared_data, torus_mesh, uv_sphere};

/// What `clean`'s checks find in `m`, in its order: vertices merged (on
/// one point), degenerate faces, duplicate faces, non-manifold faces.
fn defects(m: &Mesh) -> [usize; 4] {
    let r = clean_mesh(&mut m.clone(), &CleanSteps::default());
    [
        r.merged_vertices,
        r.degenerate_faces,
        r.duplicate_faces,
        r.nonmanifold_faces,
    ]
}

/// (pieces, Euler characteristic V − E + F over the used vertices): what
/// collapses that keep the topology keep.
fn topology(m: &Mesh) -> (usize, i64) {
    let labels = face_components(m);
    let pieces = labels.iter().map(|&l| l as usize + 1).max().unwrap_or(0);
    let mut used = vec![false; m.vertices.len()];
    let mut edges = std::collections::HashSet::new();
    for f in &m.faces {
        for k in 0..3 {
            used[f[k] as usize] = true;
            let (a, b) = (f[k], f[(k + 1) % 3]);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    let v = used.iter().filter(|u| **u).count() as i64;
    (pieces, v - edges.len() as i64 + m.faces.len() as i64)
}

/// `m` as `clean` leaves it (what the issue decimated).
fn cleaned(mut m: Mesh) -> Mesh {
    clean_mesh(&mut m, &CleanSteps::default());
    m
}

/// Decimates `mesh` (in which `clean` finds nothing) to each target and
/// asserts `clean` finds nothing new, that the pieces and the Euler
/// characteristic stay, and that the face budget is met: at most the
/// target, and at least 95 % of it.
fn keeps_topology(name: &str, mesh: &Mesh, targets: &[usize]) {
    assert_eq!(defects(mesh), [0; 4], "{name}: the input is clean");
    let shape = topology(mesh);
    for &t in targets {
        assert!(t < mesh.faces.len(), "{name}: target {t}");
        let (d, r) = decimate(mesh, Target::Faces(t)).unwrap();
        let found = defects(&d);
        eprintln!(
            "{name}: {} -> {} faces (target {t}), clean finds [merged, degenerate, duplicate, \
             non-manifold] = {found:?}",
            mesh.faces.len(),
            d.faces.len()
        );
        assert_eq!(
            found, [0; 4],
            "{name} --faces {t}: clean finds [merged vertices, degenerate, duplicate, \
             non-manifold faces]"
        );
        assert_eq!(
            topology(&d),
            shape,
            "{name} --faces {t}: (pieces, V - E + F)"
        );
        assert_eq!(r.faces_after, d.faces.len());
        assert!(
            d.faces.len() <= t && 100 * d.faces.len() >= 95 * t,
            "{name}: {} faces for a target of {t}",
            d.faces.len()
        );
    }
}

/// Generated meshes, no shared data: a UV sphere of 200k faces (high-valence
/// poles; meshoptimizer left 5 duplicate faces at 20k) and a thin torus
/// (tube radius 1/50 of the ring; meshoptimizer pinched the tube at 100
/// faces: 1 duplicate, 13 non-manifold).
#[test]
fn generated_meshes_keep_topology() {
    keeps_topology("uv sphere", &uv_sphere(224, 1.0), &[20_000, 2_000, 400]);
    keeps_topology(
        "thin torus",
        &torus_mesh(400, 12, 1.0, 0.02),
        &[2_000, 400, 100],
    );
}

/// Real scans: the Stanford bunny as `clean` leaves it (holes: border
/// vertices slide along their borders only) and a depth-8 Poisson mesh of
/// the Stanford armadillo (closed). meshoptimizer left duplicate and
/// non-manifold faces in both (bunny at 5k, armadillo at 50k, 20k, 1k).
#[test]
fn scanned_meshes_keep_topology() {
    if let Some(p) = shared_data("scanned-meshes/bun_zipper.ply") {
        let bunny = cleaned(load_mesh(&p, "test").unwrap());
        keeps_topology("bunny", &bunny, &[20_000, 5_000, 1_000]);
    }
    if let Some(p) = shared_data("scanned-meshes/armadillo_points_normals.ply") {
        let points = load_points(&p, "test").unwrap();
        let opt = PipelineOptions {
            params: PoissonParams {
                depth: 8,
                ..Default::default()
            },
            // Its normals point inward (SOURCE.md).
            flip_normals: true,
            ..Default::default()
        };
        let mesh = cleaned(run_pipeline(points, &opt).unwrap().mesh);
        keeps_topology("armadillo poisson", &mesh, &[50_000, 20_000, 5_000, 1_000]);
    }
}

fn bin(name: &str, args: &[&str]) -> std::process::Output {
    let out = Command::new(assert_cmd::cargo::cargo_bin(name))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{name} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The issue's pipeline through the binaries, on the biker capture: Gaussian
/// centres (a quick `splat2points`), `poisson --depth 9`, `clean`, then
/// `decimate --faces N` and `clean --json`, which must count nothing.
/// meshoptimizer left 165 duplicate and 229 non-manifold faces at 100k here.
#[test]
fn poisson_of_a_real_capture_decimates_clean() {
    let Some(scene) = shared_data("3dgs-playcanvas-biker/biker.decoded_sh0.ply") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (pts, mesh, clean) = (
        dir.path().join("points.ply"),
        dir.path().join("poisson.ply"),
        dir.path().join("clean.ply"),
    );
    bin(
        "splat2points",
        &[
            s(&scene),
            "--method",
            "centers",
            "--orbit",
            "8",
            "-q",
            "-o",
            s(&pts),
        ],
    );
    bin("poisson", &[s(&pts), "--depth", "9", "-q", "-o", s(&mesh)]);
    bin("clean", &[s(&mesh), "-q", "-o", s(&clean)]);
    let shape = topology(&load_mesh(&clean, "test").unwrap());
    for faces in ["100000", "10000", "2000"] {
        let dec = dir.path().join(format!("dec{faces}.ply"));
        bin(
            "decimate",
            &[s(&clean), "--faces", faces, "-q", "-o", s(&dec)],
        );
        let out = bin(
            "clean",
            &[s(&dec), "--json", "-q", "-o", s(&dir.path().join("x.ply"))],
        );
        let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let r = &r["report"];
        eprintln!("biker poisson --faces {faces}: clean reports {r}");
        for key in [
            "merged_vertices",
            "degenerate_faces",
            "duplicate_faces",
            "nonmanifold_faces",
        ] {
            assert_eq!(r[key], 0, "--faces {faces}: {key} in {r}");
        }
        let d = load_mesh(&dec, "test").unwrap();
        assert_eq!(topology(&d), shape, "--faces {faces}: (pieces, V - E + F)");
        // 100k and 10k are reached; at 2k the mesh's ~860 small closed
        // pieces (under 100 faces each) stop at their smallest shapes, so
        // only "no more than before" holds there.
        let t: usize = faces.parse().unwrap();
        if t >= 10_000 {
            assert!(
                d.faces.len() <= t && 100 * d.faces.len() >= 95 * t,
                "--faces {faces}: {} faces",
                d.faces.len()
            );
        }
    }
}

/// The issue's exact pipeline: level-set points of 48 orbit views, Poisson
/// depth 9 (889k faces), `clean`, `decimate --faces 200000`, `clean --json`
/// (meshoptimizer: 62 duplicate, 180 non-manifold faces). Minutes long.
#[test]
#[ignore = "minutes: splat2points level set over 48 views of the biker"]
fn issue_pipeline_levelset_biker_200k() {
    let Some(scene) = shared_data("3dgs-playcanvas-biker/biker.decoded_sh0.ply") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (pts, mesh, clean, dec) = (
        dir.path().join("points.ply"),
        dir.path().join("poisson.ply"),
        dir.path().join("clean.ply"),
        dir.path().join("dec.ply"),
    );
    bin(
        "splat2points",
        &[
            s(&scene),
            "--orbit",
            "24",
            "--elevation",
            "30,-20",
            "-q",
            "-o",
            s(&pts),
        ],
    );
    bin("poisson", &[s(&pts), "--depth", "9", "-q", "-o", s(&mesh)]);
    bin("clean", &[s(&mesh), "-q", "-o", s(&clean)]);
    bin(
        "decimate",
        &[s(&clean), "--faces", "200000", "-q", "-o", s(&dec)],
    );
    let out = bin(
        "clean",
        &[s(&dec), "--json", "-q", "-o", s(&dir.path().join("x.ply"))],
    );
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let r = &r["report"];
    eprintln!("biker level-set poisson --faces 200000: clean reports {r}");
    for key in [
        "merged_vertices",
        "degenerate_faces",
        "duplicate_faces",
        "nonmanifold_faces",
    ] {
        assert_eq!(r[key], 0, "{key} in {r}");
    }
}
