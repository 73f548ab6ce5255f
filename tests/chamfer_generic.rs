//! Generic Chamfer against analytic ground truth: concentric spheres, offset
//! planes, scaled cube corners. Distances are known in closed form because
//! every point's nearest neighbour is its radial / normal partner (the
//! spacing of each cloud is larger than the offset, checked below).

use splatkit::ops::chamfer::{Cloud, GenericParams, SampleMode, chamfer_generic};

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
