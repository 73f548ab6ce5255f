//! Reconstruction of analytic shapes, generated here: the distance from every
//! output vertex to the true surface is closed-form, so accuracy is measured
//! exactly, in units of the finest cell.

use rand::{RngExt, SeedableRng};
use rustc_hash::FxHashMap;

use super::*;

/// A closed analytic surface: points, outward normals, distance function.
pub(crate) enum Shape {
    Sphere {
        r: f64,
    },
    Torus {
        big: f64,
        small: f64,
    },
    /// Axis-aligned box with half-sides.
    Cube {
        half: [f64; 3],
    },
}

impl Shape {
    /// Unsigned distance from p to the surface.
    pub(crate) fn distance(&self, p: [f64; 3]) -> f64 {
        match self {
            Shape::Sphere { r } => ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - r).abs(),
            Shape::Torus { big, small } => {
                let q = (p[0] * p[0] + p[1] * p[1]).sqrt() - big;
                ((q * q + p[2] * p[2]).sqrt() - small).abs()
            }
            Shape::Cube { half } => {
                let q: Vec<f64> = (0..3).map(|k| p[k].abs() - half[k]).collect();
                let outside = q.iter().map(|v| v.max(0.0).powi(2)).sum::<f64>().sqrt();
                let inside = q.iter().cloned().fold(f64::NEG_INFINITY, f64::max).min(0.0);
                (outside + inside).abs()
            }
        }
    }

    /// `n` random area-uniform points with outward normals, positions
    /// perturbed along the normal by N(0, noise²).
    pub(crate) fn sample(&self, n: usize, noise: f64, seed: u64) -> PointCloud {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
        let gauss = move |rng: &mut rand_pcg::Pcg64Mcg| {
            let u: f64 = rng.random::<f64>().max(1e-300);
            let v: f64 = rng.random();
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
        };
        let mut pos = Vec::with_capacity(n);
        let mut nrm = Vec::with_capacity(n);
        while pos.len() < n {
            let (p, nn): ([f64; 3], [f64; 3]) = match self {
                Shape::Sphere { r } => {
                    let z: f64 = rng.random::<f64>() * 2.0 - 1.0;
                    let phi: f64 = rng.random::<f64>() * 2.0 * std::f64::consts::PI;
                    let s = (1.0 - z * z).sqrt();
                    let d = [s * phi.cos(), s * phi.sin(), z];
                    ([d[0] * r, d[1] * r, d[2] * r], d)
                }
                Shape::Torus { big, small } => {
                    let u: f64 = rng.random::<f64>() * 2.0 * std::f64::consts::PI;
                    let v: f64 = rng.random::<f64>() * 2.0 * std::f64::consts::PI;
                    // area element ∝ (R + r cos v): rejection sampling
                    if rng.random::<f64>() * (big + small) > big + small * v.cos() {
                        continue;
                    }
                    let d = [v.cos() * u.cos(), v.cos() * u.sin(), v.sin()];
                    let c = [big * u.cos(), big * u.sin(), 0.0];
                    (
                        [
                            c[0] + small * d[0],
                            c[1] + small * d[1],
                            c[2] + small * d[2],
                        ],
                        d,
                    )
                }
                Shape::Cube { half } => {
                    let areas = [half[1] * half[2], half[0] * half[2], half[0] * half[1]];
                    let t: f64 = rng.random::<f64>() * (areas[0] + areas[1] + areas[2]);
                    let axis = if t < areas[0] {
                        0
                    } else if t < areas[0] + areas[1] {
                        1
                    } else {
                        2
                    };
                    let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
                    let mut p = [0.0; 3];
                    for k in 0..3 {
                        p[k] = (rng.random::<f64>() * 2.0 - 1.0) * half[k];
                    }
                    p[axis] = sign * half[axis];
                    let mut d = [0.0; 3];
                    d[axis] = sign;
                    (p, d)
                }
            };
            let e = if noise > 0.0 {
                noise * gauss(&mut rng)
            } else {
                0.0
            };
            pos.push([
                (p[0] + e * nn[0]) as f32,
                (p[1] + e * nn[1]) as f32,
                (p[2] + e * nn[2]) as f32,
            ]);
            nrm.push([nn[0] as f32, nn[1] as f32, nn[2] as f32]);
        }
        PointCloud {
            positions: pos,
            normals: Some(nrm),
            ..Default::default()
        }
    }
}

/// Edge-use counts: watertight means every undirected edge has exactly two
/// faces, consistently oriented means each directed edge appears once.
pub(crate) fn topology(m: &Mesh) -> (bool, bool, usize) {
    let mut und: FxHashMap<(u32, u32), usize> = FxHashMap::default();
    let mut dir: FxHashMap<(u32, u32), usize> = FxHashMap::default();
    for f in &m.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *und.entry((a.min(b), a.max(b))).or_default() += 1;
            *dir.entry((a, b)).or_default() += 1;
        }
    }
    let watertight = und.values().all(|&c| c == 2);
    let oriented = dir.values().all(|&c| c == 1);
    // components over shared vertices (union-find)
    let mut parent: Vec<u32> = (0..m.vertices.len() as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for f in &m.faces {
        for k in 1..3 {
            let (a, b) = (find(&mut parent, f[0]), find(&mut parent, f[k]));
            parent[a as usize] = b;
        }
    }
    let mut roots: Vec<u32> = m.faces.iter().map(|f| find(&mut parent, f[0])).collect();
    roots.sort_unstable();
    roots.dedup();
    (watertight, oriented, roots.len())
}

/// Signed volume (positive for outward-oriented closed meshes).
pub(crate) use crate::geom::mesh_ops::clean::signed_volume;

fn distances_in_cells(out: &PoissonOutput, shape: &Shape) -> (f64, f64) {
    let cell = out.stats.cell_size;
    let d: Vec<f64> = out
        .mesh
        .vertices
        .iter()
        .map(|v| shape.distance([v[0] as f64, v[1] as f64, v[2] as f64]) / cell)
        .collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let max = d.iter().cloned().fold(0.0, f64::max);
    (mean, max)
}

fn params(depth: u32) -> PoissonParams {
    PoissonParams {
        depth,
        ..Default::default()
    }
}

#[test]
fn sphere_is_accurate_watertight_and_outward() {
    let shape = Shape::Sphere { r: 1.0 };
    let pc = shape.sample(60_000, 0.0, 1);
    let out = reconstruct(&pc, &params(7)).unwrap();
    let (mean, max) = distances_in_cells(&out, &shape);
    let (wt, or, comps) = topology(&out.mesh);
    eprintln!(
        "sphere d7: {:?} mean {mean:.4} max {max:.4} cells, V {} F {}",
        out.stats.seconds,
        out.mesh.vertices.len(),
        out.mesh.faces.len()
    );
    assert!(
        wt && or && comps == 1,
        "watertight {wt} oriented {or} components {comps}"
    );
    assert!(signed_volume(&out.mesh) > 0.0);
    assert!(mean <= 0.1, "mean {mean}");
    assert!(max <= 0.5, "max {max}");
}

/// Closed shapes with and without noise. Bounds in finest-cell units:
/// without noise the iso-surface of the screened solution sits within a few
/// hundredths of a cell of the samples (measured: mean 0.006 torus, 0.018
/// box), so the bound is 0.05 mean, half the 0.1 target; max 0.25
/// (torus, measured 0.04) and 0.5 (box, 0.27: the smooth basis rounds its
/// edges and corners, which are not in the FEM space). With noise σ = 0.25
/// cell along the normal the solution averages the noise: bounds 0.15 mean,
/// 1.0 max (measured 0.04–0.05 and 0.2–0.42).
#[test]
fn closed_shapes_torus_and_box_with_and_without_noise() {
    let shapes = [
        (
            "torus",
            Shape::Torus {
                big: 1.0,
                small: 0.35,
            },
            0.1,
            0.6,
        ),
        (
            "box",
            Shape::Cube {
                half: [1.0, 0.7, 0.5],
            },
            0.05,
            0.5,
        ),
    ];
    for (name, shape, mean_bound, max_bound) in shapes {
        let (mean_bound, max_bound): (f64, f64) = (mean_bound, max_bound);
        for noisy in [false, true] {
            let depth = 7;
            let clean = shape.sample(80_000, 0.0, 3);
            let extent = clean.positions.iter().fold(0.0f64, |m, p| {
                m.max(p.iter().map(|c| c.abs() as f64).fold(0.0, f64::max))
            });
            let cell = 2.0 * extent * 1.1 / (1 << depth) as f64;
            let noise = if noisy { 0.25 * cell } else { 0.0 };
            let pc = shape.sample(80_000, noise, 3);
            let out = reconstruct(&pc, &params(depth)).unwrap();
            let (mean, max) = distances_in_cells(&out, &shape);
            let (wt, or, comps) = topology(&out.mesh);
            eprintln!("{name} noisy={noisy}: mean {mean:.4} max {max:.4} cells");
            assert!(
                wt && or && comps == 1,
                "{name}: watertight {wt} oriented {or} comps {comps}"
            );
            assert!(signed_volume(&out.mesh) > 0.0, "{name}: outward");
            let (mb, xb) = if noisy {
                (0.15, 1.0)
            } else {
                (mean_bound, max_bound)
            };
            assert!(
                mean <= mb && max <= xb,
                "{name} noisy={noisy}: mean {mean} max {max}"
            );
        }
    }
}

/// Flipping every input normal flips the output orientation (χ changes
/// sides): same surface, negative signed volume.
#[test]
fn flipped_normals_flip_orientation() {
    let shape = Shape::Sphere { r: 1.0 };
    let mut pc = shape.sample(30_000, 0.0, 5);
    let out = reconstruct(&pc, &params(6)).unwrap();
    for n in pc.normals.as_mut().unwrap() {
        *n = [-n[0], -n[1], -n[2]];
    }
    let flipped = reconstruct(&pc, &params(6)).unwrap();
    let (v0, v1) = (signed_volume(&out.mesh), signed_volume(&flipped.mesh));
    assert!(v0 > 0.0 && v1 < 0.0, "{v0} {v1}");
    // Same surface up to solver round-off: volumes agree to 1%.
    assert!((v0 + v1).abs() < 0.01 * v0, "{v0} {v1}");
    let (wt, or, comps) = topology(&flipped.mesh);
    assert!(wt && or && comps == 1);
}

/// Results do not depend on the thread count (fixed reduction orders).
#[test]
fn deterministic_across_thread_counts() {
    let pc = Shape::Torus {
        big: 1.0,
        small: 0.3,
    }
    .sample(20_000, 0.01, 9);
    let run = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| reconstruct(&pc, &params(6)).unwrap())
    };
    let a = run(1);
    // The iso value too, bit for bit, over repeated runs: it was a rayon
    // `reduce` whose pairing follows work stealing, so its last bits changed
    // from run to run even at one thread count (seen: …546 / …548 / …549).
    for n in [3, 2, 3, 2] {
        let b = run(n);
        assert_eq!(
            a.stats.iso_value.to_bits(),
            b.stats.iso_value.to_bits(),
            "{n} threads"
        );
        assert_eq!(a.mesh.vertices, b.mesh.vertices);
        assert_eq!(a.mesh.faces, b.mesh.faces);
        assert_eq!(a.mesh.scalar("density"), b.mesh.scalar("density"));
    }
}

/// Degenerate inputs give errors, never panics or hangs.
#[test]
fn degenerate_inputs_are_clear_errors() {
    let cloud = |pos: Vec<[f32; 3]>, nrm: Vec<[f32; 3]>| PointCloud {
        positions: pos,
        normals: Some(nrm),
        ..Default::default()
    };
    let up = [0.0f32, 0.0, 1.0];
    let cases = [
        (
            "few",
            cloud(
                vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                vec![up; 3],
            ),
            "at least 4",
        ),
        (
            "collinear",
            cloud(
                (0..50).map(|i| [i as f32, 2.0 * i as f32, 0.0]).collect(),
                vec![up; 50],
            ),
            "collinear",
        ),
        (
            "identical",
            cloud(vec![[1.0, 2.0, 3.0]; 10], vec![up; 10]),
            "identical",
        ),
        (
            "zero normals",
            cloud(
                (0..10).map(|i| [i as f32, (i * i) as f32, 0.0]).collect(),
                vec![[0.0; 3]; 10],
            ),
            "at least 4",
        ),
        (
            "nan",
            cloud(vec![[f32::NAN, 0.0, 0.0]; 10], vec![up; 10]),
            "at least 4",
        ),
    ];
    for (name, pc, want) in cases {
        let e = reconstruct(&pc, &params(6)).expect_err(name).to_string();
        assert!(e.contains(want), "{name}: {e}");
    }
    let no_normals = PointCloud {
        positions: vec![[0.0; 3]; 10],
        ..Default::default()
    };
    assert!(
        reconstruct(&no_normals, &params(6))
            .unwrap_err()
            .to_string()
            .contains("no normals")
    );
    // NaN points among good ones are dropped and counted.
    let mut pc = Shape::Sphere { r: 1.0 }.sample(5_000, 0.0, 2);
    pc.positions[7] = [f32::NAN, 0.0, 0.0];
    pc.normals.as_mut().unwrap()[8] = [0.0; 3];
    let out = reconstruct(&pc, &params(5)).unwrap();
    assert_eq!(out.stats.dropped_points, 2);
}

/// The uniform finest-depth extraction (`--uniform-extraction`) meets the
/// same bounds as the octree extraction on the sphere, and has at least as
/// many vertices (it never uses coarser cells).
#[test]
fn uniform_extraction_matches_octree_extraction() {
    let shape = Shape::Sphere { r: 1.0 };
    let pc = shape.sample(30_000, 0.0, 11);
    let mut prm = params(6);
    let oct = reconstruct(&pc, &prm).unwrap();
    prm.uniform_extraction = true;
    let uni = reconstruct(&pc, &prm).unwrap();
    for out in [&oct, &uni] {
        let (mean, max) = distances_in_cells(out, &shape);
        let (wt, or, comps) = topology(&out.mesh);
        assert!(wt && or && comps == 1);
        assert!(mean <= 0.05 && max <= 0.25, "mean {mean} max {max}");
    }
    assert!(uni.mesh.vertices.len() >= oct.mesh.vertices.len());
}

/// Open3D 0.20 on the Stanford bunny scan's 35,947 vertices at depth 9
/// (`testdata/poisson/open3d_bunny_vertices_d9.json`, written by
/// `scripts/make_poisson_fixture.py` from the same input). The samples are
/// sparse there (depth estimates 6–7), so the mesh's resolution follows the
/// density estimate and PoissonRecon's tree: before both were matched to
/// Open3D's code, splatkit gave 25 % more vertices (59,586 against 47,708)
/// and densities 0.06 higher. Tolerances: vertex count within 1 % (measured
/// +0.03 %); at Open3D's vertices that have a splatkit vertex within 0.05
/// cells, 98 % of the densities within 0.01 (measured: 1st–99th percentile
/// of the difference within ±0.002; a few straddle a depth change).
#[test]
fn bunny_scan_matches_open3d_adaptivity() {
    use kiddo::{ImmutableKdTree, SquaredEuclidean};
    let Some(p) = crate::testing::shared_data("scanned-meshes/bun_zipper.ply") else {
        return;
    };
    let text = std::fs::read_to_string(p).unwrap();
    let body = text.split_once("end_header\n").unwrap().1;
    let mut lines = body.lines();
    let v: Vec<[f64; 3]> = lines
        .by_ref()
        .take(35_947)
        .map(|l| {
            let w: Vec<f64> = l
                .split_whitespace()
                .take(3)
                .map(|x| x.parse().unwrap())
                .collect();
            [w[0], w[1], w[2]]
        })
        .collect();
    // Vertex normal: normalised sum of the unit normals of the faces around it.
    let mut vn = vec![[0.0f64; 3]; v.len()];
    for l in lines.take(69_451) {
        let f: Vec<usize> = l
            .split_whitespace()
            .skip(1)
            .map(|x| x.parse().unwrap())
            .collect();
        let (a, b, c) = (v[f[0]], v[f[1]], v[f[2]]);
        let (e1, e2) = (
            [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
            [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
        );
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if l > 0.0 {
            for &i in &f {
                for k in 0..3 {
                    vn[i][k] += n[k] / l;
                }
            }
        }
    }
    let normals = vn
        .iter()
        .map(|n| {
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let s = if l > 0.0 { 1.0 / l } else { 0.0 };
            [(n[0] * s) as f32, (n[1] * s) as f32, (n[2] * s) as f32]
        })
        .collect();
    let pc = PointCloud {
        positions: v.iter().map(|p| p.map(|x| x as f32)).collect(),
        normals: Some(normals),
        ..Default::default()
    };
    let out = reconstruct(&pc, &params(9)).unwrap();

    let fx: serde_json::Value = serde_json::from_str(include_str!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/testdata/poisson/open3d_bunny_vertices_d9.json"
    )))
    .unwrap();
    assert_eq!(
        out.stats.dropped_points as u64,
        fx["zero_normals"].as_u64().unwrap()
    );
    let want = fx["vertices"].as_u64().unwrap() as f64;
    let got = out.mesh.vertices.len() as f64;
    assert!(
        (got / want - 1.0).abs() < 0.01,
        "vertices {got} against Open3D's {want}"
    );

    let dens = out.mesh.scalar("density").unwrap();
    let ours: Vec<[f64; 3]> = out
        .mesh
        .vertices
        .iter()
        .map(|p| p.map(|x| x as f64))
        .collect();
    let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&ours).unwrap();
    let cell = out.stats.cell_size;
    let (mut matched, mut close) = (0usize, 0usize);
    for s in fx["every_97th_vertex_xyz_density"].as_array().unwrap() {
        let s: Vec<f64> = s
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let nn = tree
            .query(&[s[0], s[1], s[2]])
            .nearest_n::<SquaredEuclidean<f64>>(std::num::NonZero::new(1).expect("1 > 0"))
            .execute()[0];
        if nn.distance.sqrt() < 0.05 * cell {
            matched += 1;
            if (dens[nn.item as usize] as f64 - s[3]).abs() < 0.01 {
                close += 1;
            }
        }
    }
    assert!(
        matched >= 300,
        "only {matched} of Open3D's vertices coincide with ours"
    );
    assert!(
        close as f64 >= 0.98 * matched as f64,
        "{close} of {matched} densities within 0.01 of Open3D's"
    );
}
