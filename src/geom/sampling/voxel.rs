//! Point-cloud downsampling with Open3D's semantics (`PointCloud::
//! VoxelDownSample` and `UniformDownSample`, identical in 0.10 and 0.18 for
//! points).

use rayon::prelude::*;

use crate::{Error, Result};

/// Averages the points in each cell of a voxel grid, like Open3D's
/// `voxel_down_sample(voxel)`.
///
/// The grid is anchored at the cloud's own bounding box:
/// `origin = min_bound − voxel/2` (component-wise minimum over the input),
/// and a point p falls in the voxel `floor((p − origin) / voxel)` (a division,
/// per component, as Open3D computes it). Each non-empty voxel yields the mean
/// of its points: the sum in input order divided by the count.
///
/// Output order: Open3D emits voxels in `std::unordered_map` order, which is
/// unspecified; this function emits them **sorted by voxel index**
/// (lexicographic in x, then y, then z). Compare with Open3D as sets.
///
/// Errors: `voxel` not finite and > 0; a non-finite point (named by index);
/// a grid wider than `i32::MAX` voxels (Open3D's "voxel_size is too small").
/// An empty input gives an empty output.
pub fn voxel_down_sample(points: &[[f64; 3]], voxel: f64) -> Result<Vec<[f64; 3]>> {
    if !(voxel.is_finite() && voxel > 0.0) {
        return Err(Error::invalid(format!(
            "voxel size must be finite and > 0, got {voxel}"
        )));
    }
    if points.is_empty() {
        return Ok(Vec::new());
    }
    if let Some(i) = points.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(Error::invalid(format!(
            "point {i} has a non-finite coordinate: {:?}",
            points[i]
        )));
    }
    let (mut lo, mut hi) = (points[0], points[0]);
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let origin = [
        lo[0] - voxel * 0.5,
        lo[1] - voxel * 0.5,
        lo[2] - voxel * 0.5,
    ];
    let extent = (0..3)
        .map(|k| (hi[k] + voxel * 0.5) - origin[k])
        .fold(0.0f64, f64::max);
    if voxel * f64::from(i32::MAX) < extent {
        return Err(Error::invalid(format!(
            "voxel size {voxel} is too small for a cloud {extent} wide (more than {} voxels per axis)",
            i32::MAX
        )));
    }
    if points.len() > u32::MAX as usize {
        return Err(Error::invalid(format!(
            "{} points exceed the downsampling limit of {}",
            points.len(),
            u32::MAX
        )));
    }
    let index_of = |p: &[f64; 3]| {
        [
            ((p[0] - origin[0]) / voxel).floor() as i32,
            ((p[1] - origin[1]) / voxel).floor() as i32,
            ((p[2] - origin[2]) / voxel).floor() as i32,
        ]
    };
    let mut keyed: Vec<([i32; 3], u32)> = Vec::new();
    points
        .par_iter()
        .enumerate()
        .with_min_len(8192)
        .map(|(i, p)| (index_of(p), i as u32))
        .collect_into_vec(&mut keyed);
    // Stable: points of one voxel stay in input order, so the sums are
    // accumulated in Open3D's order.
    keyed.par_sort_by_key(|&(k, _)| k);
    let mut out = Vec::new();
    let mut start = 0;
    while start < keyed.len() {
        let key = keyed[start].0;
        let mut end = start;
        let mut sum = [0.0f64; 3];
        while end < keyed.len() && keyed[end].0 == key {
            let p = &points[keyed[end].1 as usize];
            sum[0] += p[0];
            sum[1] += p[1];
            sum[2] += p[2];
            end += 1;
        }
        let n = (end - start) as f64;
        out.push([sum[0] / n, sum[1] / n, sum[2] / n]);
        start = end;
    }
    Ok(out)
}

/// Keeps the points with index 0, k, 2k, … (Open3D's
/// `uniform_down_sample(k)`). `k = 0` is an error; `k = 1` returns all points.
pub fn uniform_down_sample(points: &[[f64; 3]], k: usize) -> Result<Vec<[f64; 3]>> {
    if k == 0 {
        return Err(Error::invalid("uniform downsampling rate must be ≥ 1"));
    }
    Ok(points.iter().step_by(k).copied().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use std::collections::BTreeMap;

    /// Independent brute force: a map from voxel index to the list of member
    /// points, with the origin written out from the definition.
    fn brute(points: &[[f64; 3]], v: f64) -> Vec<[f64; 3]> {
        let mut lo = [f64::INFINITY; 3];
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
            }
        }
        let mut cells: BTreeMap<(i64, i64, i64), Vec<[f64; 3]>> = BTreeMap::new();
        for p in points {
            let idx = |k: usize| ((p[k] - (lo[k] - v / 2.0)) / v).floor() as i64;
            cells.entry((idx(0), idx(1), idx(2))).or_default().push(*p);
        }
        cells
            .values()
            .map(|ps| {
                let mut s = [0.0; 3];
                for p in ps {
                    for k in 0..3 {
                        s[k] += p[k];
                    }
                }
                [
                    s[0] / ps.len() as f64,
                    s[1] / ps.len() as f64,
                    s[2] / ps.len() as f64,
                ]
            })
            .collect()
    }

    #[test]
    fn matches_brute_force() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        for (n, v) in [(1usize, 0.1), (50, 0.5), (20000, 0.05), (20000, 0.37)] {
            let pts: Vec<[f64; 3]> = (0..n)
                .map(|_| {
                    [
                        rng.random_range(-1.0..1.0),
                        rng.random_range(2.0..3.0),
                        rng.random_range(-5.0..-4.5),
                    ]
                })
                .collect();
            let got = voxel_down_sample(&pts, v).unwrap();
            // Same operations in the same order: bit-identical.
            assert_eq!(got, brute(&pts, v), "n={n} v={v}");
        }
    }

    /// Hand-checked grid: origin = min − v/2, so with v = 1 and min 0 the
    /// cells are [−0.5, 0.5), [0.5, 1.5), …; a point at exactly 0.5 belongs
    /// to the upper cell.
    #[test]
    fn origin_and_cell_boundaries() {
        let pts = [
            [0.0, 0.0, 0.0],
            [0.4, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [1.4, 0.0, 0.0],
            [3.0, 0.0, 0.0],
        ];
        let got = voxel_down_sample(&pts, 1.0).unwrap();
        assert_eq!(
            got,
            vec![[0.2, 0.0, 0.0], [0.95, 0.0, 0.0], [3.0, 0.0, 0.0]]
        );
    }

    #[test]
    fn errors_and_empty() {
        assert!(voxel_down_sample(&[], 0.1).unwrap().is_empty());
        assert!(voxel_down_sample(&[[0.0; 3]], 0.0).is_err());
        assert!(voxel_down_sample(&[[0.0; 3]], f64::NAN).is_err());
        let e = voxel_down_sample(&[[0.0; 3], [f64::INFINITY, 0.0, 0.0]], 0.1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("point 1"), "{e}");
        assert!(voxel_down_sample(&[[0.0; 3], [1e6, 0.0, 0.0]], 1e-6).is_err());
    }

    #[test]
    fn uniform() {
        let pts: Vec<[f64; 3]> = (0..10).map(|i| [i as f64, 0.0, 0.0]).collect();
        let got = uniform_down_sample(&pts, 3).unwrap();
        let xs: Vec<f64> = got.iter().map(|p| p[0]).collect();
        assert_eq!(xs, vec![0.0, 3.0, 6.0, 9.0]);
        assert_eq!(uniform_down_sample(&pts, 1).unwrap(), pts);
        assert!(uniform_down_sample(&pts, 0).is_err());
    }
}
