//! The k-nearest-centre table SuGaR evaluates densities with.

use rayon::prelude::*;

use crate::Result;
use crate::geom::sampling::knn::NnIndex;

/// SuGaR's neighbour count.
pub const SUGAR_K: usize = 16;

/// For every Gaussian, the indices of the `k` nearest Gaussian centres
/// (Euclidean, nearest first, ties by index), **itself included** (at
/// distance 0, so first unless another centre coincides): row `i` is
/// `idx[i·k .. (i+1)·k]`. `k` is the requested count, or the number of
/// Gaussians when there are fewer.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Neighbours {
    pub k: usize,
    pub idx: Vec<u32>,
}

impl Neighbours {
    /// Builds the table over `means` with `geom::sampling::knn` (SuGaR: k = [`SUGAR_K`];
    /// the caller rebuilds it every 500 iterations as the centres move).
    /// Errors on a non-finite mean.
    pub fn build(means: &[[f32; 3]], k: usize) -> Result<Self> {
        let pts: Vec<[f64; 3]> = means.iter().map(|m| m.map(f64::from)).collect();
        let index = NnIndex::new(&pts)?;
        let k = k.min(pts.len());
        let rows: Vec<Vec<usize>> = pts.par_iter().map(|p| index.k_nearest(p, k)).collect();
        let idx = rows.into_iter().flatten().map(|i| i as u32).collect();
        Ok(Neighbours { k, idx })
    }

    /// The neighbours of Gaussian `i`.
    pub fn of(&self, i: usize) -> &[u32] {
        &self.idx[i * self.k..(i + 1) * self.k]
    }

    /// Number of Gaussians the table covers.
    pub fn len(&self) -> usize {
        self.idx.len().checked_div(self.k).unwrap_or(0)
    }

    /// True when it covers no Gaussian.
    pub fn is_empty(&self) -> bool {
        self.idx.is_empty()
    }
}
