//! Tests of the tetrahedralisation against its definition: every tet
//! positive, no input point strictly inside any circumsphere (exact
//! `insphere` against all points), the tets glued face to face with a convex
//! boundary (so they tile the hull, whose volume is checked where it is
//! known), every distinct point a vertex and no duplicate used.

use std::collections::HashMap;

use rand::{RngExt, SeedableRng};
use robust::Coord3D;

use super::{
    PROGRESS_STEP, estimated_bytes, tetrahedralize, tetrahedralize_with_progress,
    tetrahedralize_within,
};

fn c(p: [f64; 3]) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

fn orient(a: [f64; 3], b: [f64; 3], cc: [f64; 3], d: [f64; 3]) -> f64 {
    robust::orient3d(c(a), c(b), c(cc), c(d))
}

/// Checks the structure of `tets` over `pts` and returns 6 × the total
/// volume (a sum of determinants: exact for small integer coordinates).
/// `all_pairs`: test the empty-sphere property against every point (else
/// only against the neighbours across each face: local Delaunay, which
/// implies global for a triangulation).
fn check(pts: &[[f64; 3]], tets: &[[u32; 4]], all_pairs: bool) -> f64 {
    let n = pts.len();
    // Which index is the first of its group of equal points.
    let mut first: HashMap<[u64; 3], usize> = HashMap::new();
    let mut canonical = vec![0usize; n];
    for (i, p) in pts.iter().enumerate() {
        let k = p.map(|x| (x + 0.0).to_bits());
        canonical[i] = *first.entry(k).or_insert(i);
    }
    let mut used = vec![false; n];
    let mut volume = 0.0;
    let mut faces: HashMap<[u32; 3], Vec<(usize, usize)>> = HashMap::new();
    for (t, v) in tets.iter().enumerate() {
        let q = v.map(|i| pts[i as usize]);
        assert!(
            v.iter().all(|&i| (i as usize) < n),
            "tet {t} {v:?}: index out of range"
        );
        for i in 0..4 {
            for j in 0..i {
                assert_ne!(v[i], v[j], "tet {t} {v:?}: repeated vertex");
            }
        }
        assert!(
            orient(q[0], q[1], q[2], q[3]) > 0.0,
            "tet {t} {v:?} not positive"
        );
        for &i in v {
            assert_eq!(
                canonical[i as usize], i as usize,
                "duplicate point {i} used"
            );
            used[i as usize] = true;
        }
        let d = |k: usize| -> [f64; 3] { std::array::from_fn(|a| q[k][a] - q[0][a]) };
        let (b, cc, dd) = (d(1), d(2), d(3));
        let det = b[0] * (cc[1] * dd[2] - cc[2] * dd[1]) - b[1] * (cc[0] * dd[2] - cc[2] * dd[0])
            + b[2] * (cc[0] * dd[1] - cc[1] * dd[0]);
        volume += -det;
        for i in 0..4 {
            let mut f: Vec<u32> = (0..4).filter(|&j| j != i).map(|j| v[j]).collect();
            f.sort_unstable();
            faces.entry([f[0], f[1], f[2]]).or_default().push((t, i));
        }
        if all_pairs {
            for (i, p) in pts.iter().enumerate() {
                if canonical[i] != i || v.contains(&(i as u32)) {
                    continue;
                }
                let s = robust::insphere(c(q[0]), c(q[1]), c(q[2]), c(q[3]), c(*p));
                assert!(
                    s <= 0.0,
                    "point {i} strictly inside the circumsphere of tet {t} {v:?}"
                );
            }
        }
    }
    for (f, users) in &faces {
        match users.as_slice() {
            [(t, i)] => {
                // A boundary face: a supporting plane of the whole set, the
                // points on its tet's side.
                let v = tets[*t];
                let mut q = v.map(|k| pts[k as usize]);
                for p in pts {
                    q[*i] = *p;
                    assert!(
                        orient(q[0], q[1], q[2], q[3]) >= 0.0,
                        "boundary face {f:?} is not on the convex hull"
                    );
                }
            }
            [(t, i), (u, j)] => {
                // An interior face: the opposite vertices on opposite sides,
                // and neither inside the other's circumsphere.
                let (vt, vu) = (tets[*t], tets[*u]);
                let mut q = vt.map(|k| pts[k as usize]);
                let other = pts[vu[*j] as usize];
                q[*i] = other;
                assert!(
                    orient(q[0], q[1], q[2], q[3]) < 0.0,
                    "face {f:?}: tets overlap"
                );
                let qt = vt.map(|k| pts[k as usize]);
                let s = robust::insphere(c(qt[0]), c(qt[1]), c(qt[2]), c(qt[3]), c(other));
                assert!(s <= 0.0, "face {f:?} is not locally Delaunay");
            }
            more => panic!("face {f:?} shared by {} tets", more.len()),
        }
    }
    for i in 0..n {
        assert_eq!(used[i], canonical[i] == i, "point {i}: used {}", used[i]);
    }
    volume
}

fn random_points(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    (0..n)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>()))
        .collect()
}

fn grid(k: usize) -> Vec<[f64; 3]> {
    let mut v = Vec::new();
    for x in 0..k {
        for y in 0..k {
            for z in 0..k {
                v.push([x as f64, y as f64, z as f64]);
            }
        }
    }
    v
}

/// Every integer point on the sphere x² + y² + z² = `r2`: an exactly
/// co-spherical set (and many co-planar and co-circular subsets).
fn lattice_sphere(r2: i64) -> Vec<[f64; 3]> {
    let r = (r2 as f64).sqrt() as i64;
    let mut v = Vec::new();
    for x in -r..=r {
        for y in -r..=r {
            let z2 = r2 - x * x - y * y;
            if z2 < 0 {
                continue;
            }
            let z = (z2 as f64).sqrt().round() as i64;
            if z * z == z2 {
                v.push([x as f64, y as f64, z as f64]);
                if z != 0 {
                    v.push([x as f64, y as f64, -z as f64]);
                }
            }
        }
    }
    v
}

#[test]
fn uniform_random_in_a_cube() {
    let mut pts = random_points(1500, 1);
    // The cube's corners make the hull the unit cube (volume 1).
    for k in 0..8 {
        pts.push([(k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64]);
    }
    let tets = tetrahedralize(&pts).unwrap();
    let vol = check(&pts, &tets, true);
    // Rounding of ~10^4 tet volumes of size 1e-4: far below 1e-12.
    assert!((vol / 6.0 - 1.0).abs() < 1e-12, "volume {}", vol / 6.0);
    // A Delaunay tetrahedralisation of uniform points has ≈ 6.5 tets per point.
    assert!(
        (5 * pts.len()..8 * pts.len()).contains(&tets.len()),
        "{}",
        tets.len()
    );
}

#[test]
fn regular_grid_is_massively_degenerate() {
    let pts = grid(6);
    let tets = tetrahedralize(&pts).unwrap();
    let vol = check(&pts, &tets, true);
    // Integer coordinates: every determinant is an exact integer.
    assert_eq!(vol, 6.0 * 125.0);
}

#[test]
fn exactly_cospherical_points() {
    let pts = lattice_sphere(1250);
    assert!(pts.len() > 300, "{} points", pts.len());
    let tets = tetrahedralize(&pts).unwrap();
    check(&pts, &tets, true);
    // With the centre added, every point is co-spherical with every tet's
    // outer face: still a valid triangulation.
    let mut with_centre = pts.clone();
    with_centre.push([0.0; 3]);
    let tets = tetrahedralize(&with_centre).unwrap();
    check(&with_centre, &tets, true);
}

#[test]
fn points_on_a_sphere_and_on_concentric_shells() {
    // Two shells of the same directions: many co-planar quadruples.
    let mut pts = Vec::new();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
    for _ in 0..300 {
        let d: [f64; 3] = std::array::from_fn(|_| rng.random::<f64>() - 0.5);
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        pts.push(d.map(|x| x / l));
        pts.push(d.map(|x| 2.0 * x / l));
    }
    let tets = tetrahedralize(&pts).unwrap();
    check(&pts, &tets, true);
}

#[test]
fn duplicates_are_used_once() {
    let base = random_points(300, 3);
    let mut pts = Vec::new();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(4);
    for _ in 0..1200 {
        pts.push(base[rng.random_range(0..base.len())]);
    }
    // -0.0 equals 0.0.
    pts.push([0.0, 0.5, 0.5]);
    pts.push([-0.0, 0.5, 0.5]);
    let mut g = grid(4);
    g.extend(grid(4));
    pts.extend(g);
    let tets = tetrahedralize(&pts).unwrap();
    check(&pts, &tets, true);
}

#[test]
fn few_or_flat_inputs() {
    assert!(tetrahedralize(&[]).unwrap().is_empty());
    assert!(tetrahedralize(&[[1.0, 2.0, 3.0]; 10]).unwrap().is_empty());
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert!(tetrahedralize(&tri).unwrap().is_empty());
    // Coplanar (a tilted plane, coordinates exact in binary) and collinear
    // sets.
    let plane: Vec<[f64; 3]> = random_points(200, 5)
        .into_iter()
        .map(|p| {
            let (x, y) = ((p[0] * 64.0).floor() / 64.0, (p[1] * 64.0).floor() / 64.0);
            [x, y, 0.5 * x + 0.25 * y]
        })
        .collect();
    assert!(tetrahedralize(&plane).unwrap().is_empty());
    let line: Vec<[f64; 3]> = (0..50)
        .map(|i| [i as f64, 2.0 * i as f64, -(i as f64)])
        .collect();
    assert!(tetrahedralize(&line).unwrap().is_empty());
    // One tet, either orientation of the input.
    for pts in [
        [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        [
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
    ] {
        let tets = tetrahedralize(&pts).unwrap();
        assert_eq!(tets.len(), 1);
        let vol = check(&pts, &tets, true);
        assert_eq!(vol, 1.0);
    }
    // A plane plus one point: a pyramid-like fan.
    let mut cone = plane.clone();
    cone.push([0.5, 0.5, 3.0]);
    let tets = tetrahedralize(&cone).unwrap();
    check(&cone, &tets, true);
    // Collinear and coplanar leading points, then a point off the plane.
    let mut late = line.clone();
    late.extend(plane.iter().take(20));
    late.push([0.3, 0.3, 5.0]);
    let tets = tetrahedralize(&late).unwrap();
    check(&late, &tets, true);
}

#[test]
fn non_finite_coordinates_are_errors_naming_the_point() {
    let mut pts = random_points(20, 6);
    pts[13][1] = f64::NAN;
    let e = tetrahedralize(&pts).unwrap_err().to_string();
    assert!(e.contains("point 13"), "{e}");
    pts[13][1] = 0.0;
    pts[7][2] = f64::NEG_INFINITY;
    let e = tetrahedralize(&pts).unwrap_err().to_string();
    assert!(e.contains("point 7"), "{e}");
}

#[test]
fn power_of_two_scaling_changes_nothing() {
    // Scaling by 2^k is exact, so the output must be the same tets.
    let mut pts = random_points(400, 8);
    pts.extend(grid(3));
    let base = tetrahedralize(&pts).unwrap();
    for k in [-900, -600, 600, 1000] {
        let s = 2f64.powi(k / 2) * 2f64.powi(k - k / 2);
        let scaled: Vec<[f64; 3]> = pts.iter().map(|p| p.map(|x| x * s)).collect();
        assert_eq!(tetrahedralize(&scaled).unwrap(), base, "scale 2^{k}");
    }
}

#[test]
fn extreme_ranges_do_not_break() {
    // Points spread over 1e-300 .. 1e300 in magnitude: a valid result or
    // a clear error, never a panic or a hang.
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
    let pts: Vec<[f64; 3]> = (0..300)
        .map(|_| {
            std::array::from_fn(|_| {
                let e = rng.random_range(-300..300);
                (rng.random::<f64>() - 0.5) * 10f64.powi(e)
            })
        })
        .collect();
    let tets = tetrahedralize(&pts).unwrap();
    assert!(!tets.is_empty());
}

#[test]
fn deterministic_and_local_delaunay_at_20k() {
    let pts = random_points(20_000, 10);
    let a = tetrahedralize(&pts).unwrap();
    check(&pts, &a, false);
    assert_eq!(a, tetrahedralize(&pts).unwrap());
}

#[test]
fn a_grid_of_10k_points() {
    let pts = grid(22);
    let tets = tetrahedralize(&pts).unwrap();
    assert_eq!(check(&pts, &tets, false), 6.0 * 21f64.powi(3));
}

#[test]
fn memory_limit_is_an_error() {
    let pts = random_points(1000, 11);
    let e = tetrahedralize_within(&pts, estimated_bytes(1000) - 1).unwrap_err();
    assert!(e.to_string().contains("limit"), "{e}");
    assert!(tetrahedralize_within(&pts, estimated_bytes(1000)).is_ok());
}

#[test]
fn progress_counts_distinct_points_up_to_the_end() {
    let mut pts = random_points(PROGRESS_STEP + 1000, 12);
    pts.push(pts[0]);
    let mut calls = Vec::new();
    let tets =
        tetrahedralize_with_progress(&pts, u64::MAX, &mut |d, t| calls.push((d, t))).unwrap();
    let n = PROGRESS_STEP + 1000;
    assert_eq!(calls, vec![(PROGRESS_STEP, n), (n, n)]);
    assert_eq!(tets, tetrahedralize(&pts).unwrap());
}
