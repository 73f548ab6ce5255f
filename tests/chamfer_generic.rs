//! Generic Chamfer against analytic ground truth: concentric spheres, offset
//! planes, scaled cube corners. Distances are known in closed form because
//! every point's nearest neighbour is its radial / normal partner (the
//! spacing of each cloud is larger than the offset, checked below).

use predicates::prelude::PredicateBooleanExt;
use splatkit::eval::chamfer::{Cloud, GenericParams, SampleMode, chamfer_generic};

fn params(thresholds: &[f64]) -> GenericParams {
    GenericParams {
        sample: SampleMode::Vertices,
        count: 0,
        spacing: 0.2,
        thresholds: thresholds.to_vec(),
        max_dist: None,
        seed: 0,
    }
}

fn fibonacci_sphere(n: usize, r: f64) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let s = (1.0 - z * z).sqrt();
            let t = golden * i as f64;
            [r * s * t.cos(), r * s * t.sin(), r * z]
        })
        .collect()
}

#[test]
fn concentric_spheres() {
    // 800 directions: neighbour spacing ≈ sqrt(4π/800) ≈ 0.125 > offset 0.05,
    // so each point's nearest neighbour on the other sphere is its radial twin.
    let pred = fibonacci_sphere(800, 1.0);
    let gt = fibonacci_sphere(800, 1.05);
    let mut pn = pred.clone();
    for p in &mut pn {
        *p = p.map(|c| c / 1.0);
    }
    let a = Cloud {
        points: pred.clone(),
        normals: Some(pn.clone()),
    };
    let b = Cloud {
        points: gt,
        normals: Some(pn),
    };
    let r = chamfer_generic(&a, &b, &params(&[0.04, 0.06])).unwrap();
    // Closed form: every distance is 0.05 (to f64 rounding of the radii).
    assert!(
        (r.accuracy.mean - 0.05).abs() < 1e-12,
        "{}",
        r.accuracy.mean
    );
    assert!((r.completeness.mean - 0.05).abs() < 1e-12);
    assert!((r.accuracy.max - 0.05).abs() < 1e-12 && (r.accuracy.median - 0.05).abs() < 1e-12);
    assert!((r.chamfer_l1 - 0.05).abs() < 1e-12);
    assert!((r.chamfer_l2 - 0.0025).abs() < 1e-12);
    assert_eq!(
        (
            r.fscores[0].precision,
            r.fscores[0].recall,
            r.fscores[0].fscore
        ),
        (0.0, 0.0, 0.0)
    );
    assert_eq!(
        (
            r.fscores[1].precision,
            r.fscores[1].recall,
            r.fscores[1].fscore
        ),
        (1.0, 1.0, 1.0)
    );
    // Radial normals on both sides: consistency 1.
    assert!((r.normal_consistency.unwrap() - 1.0).abs() < 1e-12);
}

#[test]
fn plane_and_offset_plane_with_a_cap() {
    // Grids of spacing 1 at z = 0 and z = 0.5; two outliers 30 above.
    let grid = |z: f64| -> Vec<[f64; 3]> {
        (0..20)
            .flat_map(|i| (0..20).map(move |j| [i as f64, j as f64, z]))
            .collect()
    };
    let mut pred = grid(0.5);
    pred.push([3.0, 3.0, 30.0]);
    pred.push([4.0, 4.0, 30.0]);
    let gt = grid(0.0);
    let mut p = params(&[0.6]);
    p.max_dist = Some(20.0);
    let r = chamfer_generic(
        &Cloud {
            points: pred,
            normals: None,
        },
        &Cloud {
            points: gt,
            normals: None,
        },
        &p,
    )
    .unwrap();
    // The two outliers (30 away) are discarded from the statistics but count
    // against precision: 400 / 402 below τ.
    assert_eq!(r.discarded, [2, 0]);
    assert!((r.accuracy.mean - 0.5).abs() < 1e-15);
    assert!((r.completeness.mean - 0.5).abs() < 1e-15);
    assert!((r.fscores[0].precision - 400.0 / 402.0).abs() < 1e-15);
    assert_eq!(r.fscores[0].recall, 1.0);
    assert!(r.normal_consistency.is_none());
}

#[test]
fn cube_corners_scaled() {
    let corners = |h: f64| -> Vec<[f64; 3]> {
        (0..8)
            .map(|i| [0, 1, 2].map(|k| if i >> k & 1 == 1 { h } else { -h }))
            .collect()
    };
    // Half-sides 1 and 1.1: each corner moves by 0.1·√3 along its diagonal.
    let r = chamfer_generic(
        &Cloud {
            points: corners(1.0),
            normals: None,
        },
        &Cloud {
            points: corners(1.1),
            normals: None,
        },
        &params(&[0.17, 0.18]),
    )
    .unwrap();
    let want = 0.1 * 3f64.sqrt();
    assert!((r.accuracy.mean - want).abs() < 1e-12 && (r.completeness.mean - want).abs() < 1e-12);
    assert_eq!(r.fscores[0].fscore, 0.0);
    assert_eq!(r.fscores[1].fscore, 1.0);
}

#[test]
fn empty_inputs_are_an_error() {
    let e = chamfer_generic(
        &Cloud::default(),
        &Cloud {
            points: vec![[0.0; 3]],
            normals: None,
        },
        &params(&[]),
    );
    assert!(e.unwrap_err().to_string().contains("0 points"));
}

/// Icosphere of radius 1 (level 5: 20,480 faces, edges ≈ 0.035).
fn icosphere(level: usize) -> splatkit::model::Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let norm = |p: [f64; 3]| {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        p.map(|c| c / l)
    };
    v.iter_mut().for_each(|p| *p = norm(*p));
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut cache = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<[f64; 3]>| {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (v[a as usize], v[b as usize]);
                v.push(norm([0, 1, 2].map(|k| (p[k] + q[k]) / 2.0)));
                (v.len() - 1) as u32
            })
        };
        let mut nf = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
            nf.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = nf;
    }
    splatkit::model::Mesh::new(v.iter().map(|p| p.map(|c| c as f32)).collect(), f)
}

#[test]
fn sphere_mesh_against_a_larger_sphere() {
    // Area samples of a radius-1 icosphere against 200k points on a sphere of
    // radius 1.1: every distance is 0.1 plus the triangle's sag below the
    // sphere (≤ circumradius²/2 ≈ e²/6 ≈ 2e-4) plus the GT spacing effect
    // (≤ δ²/(2·0.1) ≈ 2e-4, δ ≈ 0.0062 half-spacing), so the means lie in
    // [0.1, 0.1 + 5e-4].
    let mesh = icosphere(5);
    let mut p = params(&[0.1, 0.11]);
    p.sample = SampleMode::Area;
    p.count = 200_000;
    let pred = splatkit::eval::chamfer::mesh_cloud(&mesh, &p).unwrap();
    let gt = Cloud {
        points: fibonacci_sphere(200_000, 1.1),
        normals: None,
    };
    let r = chamfer_generic(&pred, &gt, &p).unwrap();
    for (what, m) in [
        ("accuracy", r.accuracy.mean),
        ("completeness", r.completeness.mean),
    ] {
        assert!((0.1..0.1005).contains(&m), "{what} {m}");
    }
    // Nothing is closer than 0.1 − rounding, everything is within 0.11.
    assert!(r.accuracy.min > 0.1 - 1e-6 && r.accuracy.max < 0.101);
    assert_eq!(r.fscores[0].precision, 0.0);
    assert_eq!(r.fscores[1].fscore, 1.0);
}

#[test]
fn cli_drops_nan_points_and_refuses_empty_meshes() {
    use splatkit::io::ply::{Format, mesh::write_mesh, points::write_points};
    use splatkit::model::{Mesh, PointCloud};
    let tmp = tempfile::tempdir().unwrap();
    let a = tmp.path().join("a.ply");
    let b = tmp.path().join("b.ply");
    let pa = PointCloud {
        positions: vec![[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]],
        ..Default::default()
    };
    let pb = PointCloud {
        positions: vec![[0.0, 0.0, 0.5], [1.0, 0.0, 0.5]],
        ..Default::default()
    };
    splatkit::io::write_output(&a, |w| write_points(w, &pa, Format::Ascii)).unwrap();
    splatkit::io::write_output(&b, |w| write_points(w, &pb, Format::Ascii)).unwrap();
    let out = assert_cmd::Command::cargo_bin("chamfer")
        .unwrap()
        .arg(&a)
        .arg(&b)
        .args(["--json", "-q"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["non_finite_dropped"], serde_json::json!([1, 0]));
    assert_eq!(v["accuracy"]["mean"], 0.5);
    let empty = tmp.path().join("empty.ply");
    splatkit::io::write_output(&empty, |w| write_mesh(w, &Mesh::default(), Format::Ascii)).unwrap();
    assert_cmd::Command::cargo_bin("chamfer")
        .unwrap()
        .arg(&empty)
        .arg(&b)
        .assert()
        .code(1)
        .stderr(
            predicates::str::contains("error: prediction ")
                .and(predicates::str::contains("empty.ply: no points to compare")),
        );
    // all points non-finite: said so, on the side they are on
    let nan = tmp.path().join("nan.ply");
    let pc = splatkit::model::PointCloud {
        positions: vec![[f32::NAN, 0.0, 0.0]],
        ..Default::default()
    };
    splatkit::io::any::save(
        &nan,
        &splatkit::model::Scene::PointCloud(pc),
        splatkit::io::detect::FileFormat::Ply,
    )
    .unwrap();
    assert_cmd::Command::cargo_bin("chamfer")
        .unwrap()
        .arg(&b)
        .arg(&nan)
        .assert()
        .code(1)
        .stderr(
            predicates::str::contains("error: ground truth ").and(predicates::str::contains(
                "nan.ply: no points to compare (all 1 are non-finite)",
            )),
        );
}
