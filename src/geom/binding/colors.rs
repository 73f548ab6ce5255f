//! Colours for freshly bound Gaussians taken from another scene.

use rayon::prelude::*;

use crate::geom::knn::NnIndex;
use crate::model::Gaussians;
use crate::{Error, Result};

/// Neighbours searched for the highest-weight source Gaussian.
pub const NEIGHBOURS: usize = 16;

/// For each point of `at`, the SH DC coefficients of the source Gaussian
/// that contributes most density there: among the [`NEIGHBOURS`] nearest
/// source centres, the one maximising α·exp(−½ dᵀΣ⁻¹d) (the nearest one
/// when every weight underflows). Source values are activated as 3DGS does
/// (sigmoid opacity, exp scales, normalised quaternion).
pub fn dc_from_gaussians(at: &[[f64; 3]], src: &Gaussians) -> Result<Vec<[f32; 3]>> {
    if src.is_empty() {
        return Err(Error::invalid("the colour source holds no Gaussians"));
    }
    let centres: Vec<[f64; 3]> = src.means.iter().map(|m| m.map(f64::from)).collect();
    let index = NnIndex::new(&centres)?;
    Ok(at
        .par_iter()
        .map(|p| {
            let near = index.k_nearest(p, NEIGHBOURS);
            let mut best = (f64::NEG_INFINITY, near[0]);
            for &j in &near {
                let q = src.quat(j).as_dquat();
                let s = src.scales(j).map(|v| (v as f64).max(1e-12));
                let d = glam::DVec3::from_array(std::array::from_fn(|k| p[k] - centres[j][k]));
                let local = q.inverse() * d;
                let m =
                    (local.x / s[0]).powi(2) + (local.y / s[1]).powi(2) + (local.z / s[2]).powi(2);
                let w = (src.opacity(j) as f64).ln() - 0.5 * m;
                if w > best.0 {
                    best = (w, j);
                }
            }
            src.sh_dc[best.1]
        })
        .collect())
}
