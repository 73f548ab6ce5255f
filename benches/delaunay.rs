//! `geom::delaunay::tetrahedralize` on generated point sets at real scale
//! (GOF tetrahedralises 9 points per Gaussian: millions of points).
//!
//! Run: `cargo bench --bench delaunay -- CASE N` (one case per process, so
//! that `/usr/bin/time -f "%e s %M KB"` gives its peak memory), or with no
//! arguments every case at 1M points. Cases:
//! - `uniform`: N points uniform in the unit cube;
//! - `grid`: the k × k × k integer grid, k = round(∛N) (every cube's 8
//!   corners co-spherical, every face's 4 co-circular);
//! - `dup`: 0.9·N uniform points and 0.1·N exact duplicates of them;
//! - `degenerate`: 45% a regular grid (massively co-spherical and
//!   co-planar), 45% corners of axis-aligned boxes (each 8 exactly
//!   co-spherical), 10% exact duplicates of those, shuffled;
//! - `gof`: N/9 random Gaussians (log-uniform sizes, random rotations), each
//!   giving its centre and the 8 corners of its 3σ box, as GOF does.
//!
//! Prints the time of the call, the tet count, and tets per point.

use std::time::Instant;

use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use splatkit::geom::delaunay::tetrahedralize;

fn uniform(n: usize, rng: &mut rand_pcg::Pcg64Mcg) -> Vec<[f64; 3]> {
    (0..n)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>()))
        .collect()
}

fn grid(n: usize) -> Vec<[f64; 3]> {
    let k = (n as f64).cbrt().round() as usize;
    let mut v = Vec::with_capacity(k * k * k);
    for x in 0..k {
        for y in 0..k {
            for z in 0..k {
                v.push([x as f64, y as f64, z as f64]);
            }
        }
    }
    v
}

fn dup(n: usize, rng: &mut rand_pcg::Pcg64Mcg) -> Vec<[f64; 3]> {
    let mut v = uniform(n * 9 / 10, rng);
    let base = v.len();
    while v.len() < n {
        v.push(v[rng.random_range(0..base)]);
    }
    v
}

fn degenerate(n: usize, rng: &mut rand_pcg::Pcg64Mcg) -> Vec<[f64; 3]> {
    let n_grid = n * 45 / 100;
    let k = (n_grid as f64).cbrt().floor().max(1.0) as usize;
    let mut pts = Vec::with_capacity(n);
    'grid: for x in 0..k + 1 {
        for y in 0..k + 1 {
            for z in 0..k + 1 {
                if pts.len() == n_grid {
                    break 'grid;
                }
                pts.push([
                    x as f64 / k as f64,
                    y as f64 / k as f64,
                    z as f64 / k as f64,
                ]);
            }
        }
    }
    let n_box = (n * 90 / 100 - pts.len()) / 8;
    for _ in 0..n_box {
        let c: [f64; 3] = std::array::from_fn(|_| rng.random::<f64>());
        // Half-sizes on a 1/1024 grid: the corners are exact.
        let h: [f64; 3] = std::array::from_fn(|_| rng.random_range(1..32) as f64 / 1024.0);
        for corner in 0..8 {
            pts.push(std::array::from_fn(|a| {
                if corner >> a & 1 == 1 {
                    c[a] + h[a]
                } else {
                    c[a] - h[a]
                }
            }));
        }
    }
    let base = pts.len();
    while pts.len() < n {
        let p = pts[rng.random_range(0..base)];
        pts.push(p);
    }
    pts.shuffle(rng);
    pts
}

fn gof(n: usize, rng: &mut rand_pcg::Pcg64Mcg) -> Vec<[f64; 3]> {
    let mut pts = Vec::with_capacity(n);
    for _ in 0..n / 9 {
        let c: [f64; 3] = std::array::from_fn(|_| rng.random::<f64>());
        let s: [f64; 3] = std::array::from_fn(|_| 3.0 * 10f64.powf(rng.random_range(-3.5..-2.0)));
        // A random rotation from a random unit quaternion.
        let q: [f64; 4] = std::array::from_fn(|_| rng.random::<f64>() - 0.5);
        let l = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        let r = splatkit_render::gaussian::quat_matrix(q.map(|v| v / l));
        pts.push(c);
        for corner in 0..8 {
            let d: [f64; 3] =
                std::array::from_fn(|a| if corner >> a & 1 == 1 { s[a] } else { -s[a] });
            pts.push(std::array::from_fn(|i| {
                c[i] + r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2]
            }));
        }
    }
    pts
}

fn run(case: &str, n: usize) {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(1);
    let pts = match case {
        "uniform" => uniform(n, &mut rng),
        "grid" => grid(n),
        "dup" => dup(n, &mut rng),
        "degenerate" => degenerate(n, &mut rng),
        "gof" => gof(n, &mut rng),
        other => panic!("unknown case {other} (uniform, grid, dup, degenerate, gof)"),
    };
    let t = Instant::now();
    let tets = tetrahedralize(&pts).expect("tetrahedralize");
    let s = t.elapsed().as_secs_f64();
    println!(
        "delaunay {case:>10} {:>9} points: {s:7.2} s, {:>10} tets ({:.2} per point)",
        pts.len(),
        tets.len(),
        tets.len() as f64 / pts.len() as f64
    );
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    match args.as_slice() {
        [case, n] => run(case, n.parse().expect("N: a point count")),
        [] => {
            for case in ["uniform", "grid", "dup", "degenerate", "gof"] {
                run(case, 1_000_000);
            }
        }
        _ => panic!("usage: delaunay [CASE N]"),
    }
}
