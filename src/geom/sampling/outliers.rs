//! Statistical outlier removal with Open3D's `remove_statistical_outlier`
//! semantics (what SuGaR runs before Poisson, with k = 20, ratio = 20):
//!
//! - for every point, the mean Euclidean distance to its k nearest points,
//!   the point itself included (Open3D's k-NN query returns it at distance 0);
//! - the mean m and the sample standard deviation s (Bessel's n − 1) of those
//!   means over all points;
//! - a point is kept when its mean distance is strictly below m + ratio·s.

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use crate::{Error, Result};

/// Keep-mask of [`statistical_outliers`], and the threshold used.
#[derive(Clone, Debug)]
pub struct OutlierResult {
    /// true = keep.
    pub keep: Vec<bool>,
    /// The distance threshold m + ratio·s (world units).
    pub threshold: f64,
}

/// Flags statistical outliers. Positions must be finite. With fewer than
/// two points, or k = 0, every point is kept.
pub fn statistical_outliers(
    points: &[[f32; 3]],
    k: usize,
    std_ratio: f64,
) -> Result<OutlierResult> {
    if points.len() < 2 || k == 0 {
        return Ok(OutlierResult {
            keep: vec![true; points.len()],
            threshold: f64::INFINITY,
        });
    }
    if std_ratio.is_nan() || std_ratio < 0.0 {
        return Err(Error::invalid(format!(
            "outlier std ratio must be ≥ 0 (got {std_ratio})"
        )));
    }
    let p64: Vec<[f64; 3]> = points
        .iter()
        .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64])
        .collect();
    let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&p64)
        .map_err(|e| Error::invalid(format!("k-d tree construction failed: {e:?}")))?;
    let kk = std::num::NonZero::new(k.min(points.len())).expect("k > 0");
    let mean_d: Vec<f64> = p64
        .par_iter()
        .with_min_len(1024)
        .map(|q| {
            let nn = tree
                .query(q)
                .nearest_n::<SquaredEuclidean<f64>>(kk)
                .execute();
            nn.iter().map(|r| r.distance.sqrt()).sum::<f64>() / nn.len() as f64
        })
        .collect();
    let n = mean_d.len() as f64;
    let m = mean_d.iter().sum::<f64>() / n;
    let var = mean_d.iter().map(|d| (d - m) * (d - m)).sum::<f64>() / (n - 1.0);
    let threshold = m + std_ratio * var.sqrt();
    Ok(OutlierResult {
        keep: mean_d.iter().map(|&d| d < threshold).collect(),
        threshold,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit grid of 20³ points with three far points: the far points'
    /// mean neighbour distance is ~100× the grid's, so with ratio 2 exactly
    /// they go; with a huge ratio nothing goes.
    #[test]
    fn far_points_are_removed() {
        let mut pts = Vec::new();
        for z in 0..20 {
            for y in 0..20 {
                for x in 0..20 {
                    pts.push([x as f32, y as f32, z as f32]);
                }
            }
        }
        let far = [[500.0, 0.0, 0.0], [0.0, -400.0, 0.0], [300.0, 300.0, 300.0]];
        pts.extend(far);
        let r = statistical_outliers(&pts, 20, 2.0).unwrap();
        let removed: Vec<usize> = (0..pts.len()).filter(|&i| !r.keep[i]).collect();
        assert_eq!(removed, vec![8000, 8001, 8002]);
        let r = statistical_outliers(&pts, 20, 1e6).unwrap();
        assert!(r.keep.iter().all(|&k| k));
    }

    /// Hand-computed: 4 points on a line at 0, 1, 2, 10 with k = 2 (self +
    /// nearest): means 0.5, 0.5, 0.5, 4; m = 1.375, s = 1.75 (n − 1);
    /// threshold with ratio 1 is 3.125, so only the last goes.
    #[test]
    fn threshold_matches_hand_computation() {
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [10.0, 0.0, 0.0],
        ];
        let r = statistical_outliers(&pts, 2, 1.0).unwrap();
        assert!((r.threshold - 3.125).abs() < 1e-12, "{}", r.threshold);
        assert_eq!(r.keep, vec![true, true, true, false]);
    }
}
