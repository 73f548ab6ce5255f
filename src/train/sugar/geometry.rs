//! Activated per-Gaussian geometry (f64) and the conversion of gradients
//! with respect to it into gradients of the raw parameters.

use rayon::prelude::*;
use splatkit_render::dual::{Dual, Real};
use splatkit_render::gaussian::quat_matrix;

use super::RawGrads;
use super::entropy::sigmoid;
use crate::model::Gaussians;

/// One Gaussian's activated values: centre, rotation matrix `r[i][k]`
/// (column k = axis k) of the normalised quaternion, standard deviations,
/// opacity.
#[derive(Clone, Copy, Debug)]
pub(super) struct Geo {
    pub mu: [f64; 3],
    pub r: [[f64; 3]; 3],
    pub s: [f64; 3],
    pub alpha: f64,
}

impl Geo {
    /// Index of the shortest axis (first on ties).
    pub fn kmin(&self) -> usize {
        let s = self.s;
        if s[0] <= s[1] && s[0] <= s[2] {
            0
        } else if s[1] <= s[2] {
            1
        } else {
            2
        }
    }

    /// Axis k (unit, world space).
    pub fn axis(&self, k: usize) -> [f64; 3] {
        [self.r[0][k], self.r[1][k], self.r[2][k]]
    }
}

/// Gradient with respect to a [`Geo`]: layout `[μ (3), R row-major (9), s
/// (3), α (1)]`.
pub(super) type GeoGrad = [f64; 16];
pub(super) const G_MU: usize = 0;
pub(super) const G_R: usize = 3;
pub(super) const G_S: usize = 12;
pub(super) const G_A: usize = 15;

/// Rotation matrix of the stored quaternion (w, x, y, z), normalised inside,
/// generic so that [`Dual`] gives its Jacobian. `None` for a zero or
/// non-finite quaternion.
fn rotation<T: Real>(q: [T; 4]) -> Option<[[T; 3]; 3]> {
    let n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    if !(n2.val() > 0.0 && n2.val().is_finite()) {
        return None;
    }
    let inv = T::cst(1.0) / n2.sqrt();
    Some(quat_matrix(q.map(|v| v * inv)))
}

/// The activated geometry of every Gaussian.
pub(super) fn geometry(g: &Gaussians) -> Vec<Geo> {
    (0..g.means.len())
        .map(|i| {
            let q = g.rotations[i].map(f64::from);
            let r = rotation(q).unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
            Geo {
                mu: g.means[i].map(f64::from),
                r,
                s: g.log_scales[i].map(|v| (v as f64).exp()),
                alpha: sigmoid(g.opacity_logits[i] as f64),
            }
        })
        .collect()
}

/// Raw-parameter gradients from gradients with respect to the activated
/// geometry: `∂/∂log s = s·∂/∂s`, `∂/∂logit = α(1−α)·∂/∂α`, and the
/// quaternion through the Jacobian of `R(q/‖q‖)` (forward-mode duals).
pub(super) fn to_raw(g: &Gaussians, geo: &[Geo], acc: &[GeoGrad]) -> RawGrads {
    type PerGaussian = ([f32; 3], [f32; 3], [f32; 4], f32);
    let per: Vec<PerGaussian> = (0..geo.len())
        .into_par_iter()
        .map(|i| {
            let a = &acc[i];
            let ge = &geo[i];
            let mu = [a[G_MU], a[G_MU + 1], a[G_MU + 2]].map(|v| v as f32);
            let ls: [f32; 3] = std::array::from_fn(|k| (a[G_S + k] * ge.s[k]) as f32);
            let lo = (a[G_A] * ge.alpha * (1.0 - ge.alpha)) as f32;
            let q = g.rotations[i].map(f64::from);
            let qd: [Dual<4>; 4] = std::array::from_fn(|k| Dual::var(q[k], k));
            let mut rq = [0.0f64; 4];
            if let Some(rd) = rotation(qd) {
                for r in 0..3 {
                    for c in 0..3 {
                        let gb = a[G_R + 3 * r + c];
                        for (k, v) in rq.iter_mut().enumerate() {
                            *v += gb * rd[r][c].d[k];
                        }
                    }
                }
            }
            (mu, ls, rq.map(|v| v as f32), lo)
        })
        .collect();
    let mut out = RawGrads::zeros(geo.len());
    for (i, (m, l, r, o)) in per.into_iter().enumerate() {
        out.means[i] = m;
        out.log_scales[i] = l;
        out.rotations[i] = r;
        out.opacity_logits[i] = o;
    }
    out
}
