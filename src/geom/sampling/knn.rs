//! Exact nearest-neighbour queries on 3-D points (f64), wrapping kiddo's
//! immutable k-d tree so the rest of the crate does not depend on its API.
//!
//! Distances returned are Euclidean (not squared). Batch queries run on the
//! rayon pool and return results in query order, so they are deterministic
//! whatever the thread count. An index over zero points answers every query
//! with `None` / `f64::INFINITY`.

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use crate::{Error, Result};

/// A static nearest-neighbour index over 3-D points.
pub struct NnIndex {
    tree: Option<ImmutableKdTree<f64, 3>>,
    len: usize,
}

impl NnIndex {
    /// Builds the index. Points must be finite (callers filter NaN/Inf first;
    /// a non-finite point is an error naming its index).
    pub fn new(points: &[[f64; 3]]) -> Result<Self> {
        if let Some(i) = points.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(Error::invalid(format!(
                "point {i} has a non-finite coordinate: {:?}",
                points[i]
            )));
        }
        if points.len() > u32::MAX as usize {
            return Err(Error::invalid(format!(
                "{} points exceed the index limit of {}",
                points.len(),
                u32::MAX
            )));
        }
        let tree = if points.is_empty() {
            None
        } else {
            Some(
                ImmutableKdTree::new_from_slice_parallel(points)
                    .map_err(|e| Error::invalid(format!("k-d tree construction failed: {e:?}")))?,
            )
        };
        Ok(NnIndex {
            tree,
            len: points.len(),
        })
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Nearest point to `q`: (its index, Euclidean distance).
    pub fn nearest(&self, q: &[f64; 3]) -> Option<(usize, f64)> {
        let tree = self.tree.as_ref()?;
        let nn = tree
            .query(q)
            .nearest_one::<SquaredEuclidean<f64>>()
            .execute();
        Some((nn.item as usize, nn.distance.sqrt()))
    }

    /// Distance from each query to its nearest indexed point (∞ when empty),
    /// in query order.
    pub fn nearest_distances(&self, queries: &[[f64; 3]]) -> Vec<f64> {
        self.nearest_all(queries)
            .into_iter()
            .map(|r| r.map_or(f64::INFINITY, |(_, d)| d))
            .collect()
    }

    /// Nearest (index, distance) for each query, in query order.
    pub fn nearest_all(&self, queries: &[[f64; 3]]) -> Vec<Option<(usize, f64)>> {
        queries
            .par_iter()
            .with_min_len(4096)
            .map(|q| self.nearest(q))
            .collect()
    }

    /// Indices of the `k` nearest points to `q` (fewer when the index holds
    /// fewer), nearest first, ties by index.
    pub fn k_nearest(&self, q: &[f64; 3], k: usize) -> Vec<usize> {
        let (Some(tree), Some(kk)) = (&self.tree, std::num::NonZero::new(k.min(self.len))) else {
            return Vec::new();
        };
        let mut v: Vec<(f64, usize)> = tree
            .query(q)
            .nearest_n::<SquaredEuclidean<f64>>(kk)
            .execute()
            .into_iter()
            .map(|r| (r.distance, r.item as usize))
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        v.into_iter().map(|(_, i)| i).collect()
    }

    /// Indices of the points within `radius` of `q` (boundary included),
    /// sorted by index.
    pub fn within(&self, q: &[f64; 3], radius: f64) -> Vec<usize> {
        let Some(tree) = &self.tree else {
            return Vec::new();
        };
        let mut v: Vec<usize> = tree
            .query(q)
            .within::<SquaredEuclidean<f64>>(radius * radius)
            .unsorted()
            .execute()
            .into_iter()
            .map(|r| r.item as usize)
            .collect();
        v.sort_unstable();
        v
    }
}

/// Per point, the mean squared distance to its 3 nearest *other* points
/// (a duplicate counts, at distance 0), clamped at 1e-7: simple-knn's
/// `distCUDA2`, which 3DGS and Triangle Splatting size their initial
/// primitives from. Errors on a non-finite point.
pub fn mean_sq_dist_3nn(points: &[[f64; 3]]) -> Result<Vec<f64>> {
    let index = NnIndex::new(points)?;
    let k = 4.min(points.len());
    Ok(points
        .par_iter()
        .enumerate()
        .map(|(i, q)| {
            let d2: Vec<f64> = index
                .k_nearest(q, k)
                .into_iter()
                .filter(|&j| j != i)
                .take(3)
                .map(|j| (0..3).map(|c| (points[j][c] - q[c]).powi(2)).sum::<f64>())
                .collect();
            (d2.iter().sum::<f64>() / d2.len().max(1) as f64).max(1e-7)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Brute force agrees with the tree on random clouds (with duplicates and
    /// a flat plane, the k-d tree's classic failure cases).
    #[test]
    fn matches_brute_force() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(1);
        let mut pts: Vec<[f64; 3]> = (0..2000)
            .map(|_| {
                [
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    0.0,
                ]
            })
            .collect();
        let dups: Vec<[f64; 3]> = pts[..200].to_vec();
        pts.extend(dups);
        pts.extend((0..500).map(|_| [rng.random(), rng.random(), rng.random()]));
        let idx = NnIndex::new(&pts).unwrap();
        let queries: Vec<[f64; 3]> = (0..300)
            .map(|_| {
                [
                    rng.random_range(-1.5..1.5),
                    rng.random_range(-1.5..1.5),
                    rng.random_range(-0.5..0.5),
                ]
            })
            .collect();
        let d = idx.nearest_distances(&queries);
        for (q, got) in queries.iter().zip(&d) {
            let want = pts
                .iter()
                .map(|p| {
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
                })
                .fold(f64::INFINITY, f64::min);
            assert!(
                (got - want).abs() <= 1e-12 * want.max(1.0),
                "{got} vs {want}"
            );
            let r = want * 1.5 + 0.01;
            let mut brute: Vec<usize> = (0..pts.len())
                .filter(|&i| {
                    let p = pts[i];
                    (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2) <= r * r
                })
                .collect();
            brute.sort_unstable();
            assert_eq!(idx.within(q, r), brute);
        }
    }

    #[test]
    fn empty_and_non_finite() {
        let e = NnIndex::new(&[]).unwrap();
        assert!(e.nearest(&[0.0; 3]).is_none());
        assert_eq!(e.nearest_distances(&[[1.0; 3]]), vec![f64::INFINITY]);
        let err = NnIndex::new(&[[0.0; 3], [f64::NAN, 0.0, 0.0]])
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("point 1"), "{err}");
    }
}
