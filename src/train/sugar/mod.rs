//! SuGaR's coarse-stage regularisers (Guédon & Lepetit 2024; notes in
//! `shared/reference/sugar.md` §2) as pure functions on [`Gaussians`], each
//! returning its value and the gradient with respect to the **raw** stored
//! parameters: `means`, `log_scales`, `rotations` (w, x, y, z) as stored
//! (unnormalised; the gradient includes the normalisation) and
//! `opacity_logits`.
//!
//! - [`entropy`]: the opacity entropy of iterations 7000–9000;
//! - [`Neighbours`]: the k = 16 nearest centres of every Gaussian (itself
//!   included), rebuilt by the caller every 500 iterations;
//! - [`visible_candidates`] and [`sample_points`]: the sample set P, points
//!   `p = μ + R(1.5·s ⊙ ε)` around Gaussians near the rendered surface;
//! - [`density_at`]: SuGaR's density d(p) over the owner's neighbours;
//! - [`density_regularizer`] (SuGaR's "density" mode) and
//!   [`sdf_regularizer`] (its "sdf" mode with the normal term);
//! - [`SugarPrune`]: the α < 0.5 prune after iteration 9,000, a densification
//!   [`crate::train::strategy::Strategy`].
//!
//! Conventions: world space in scene units; a Gaussian's axis k is column k
//! of the rotation matrix of its normalised quaternion, with standard
//! deviation `s_k = exp(log_scale_k)`; α = sigmoid(logit); a zero or
//! non-finite stored quaternion counts as the identity, with no gradient.
//! Values are computed and accumulated in f64; gradients are returned in
//! f32. The sample loops run on rayon in fixed chunks of [`CHUNK`] samples
//! whose contributions are added in sample order, so every result is
//! bit-identical for any thread count (and to a sequential loop).

mod density;
mod entropy;
mod geometry;
mod neighbours;
mod prune;
mod regularizers;
mod sampling;
#[cfg(test)]
mod tests;

pub use density::density_at;
pub use entropy::entropy;
pub use neighbours::{Neighbours, SUGAR_K};
pub use prune::SugarPrune;
pub use regularizers::{SdfParams, density_regularizer, sdf_regularizer};
pub use sampling::{Samples, sample_points, visible_candidates};

use crate::model::Gaussians;

/// Samples per work unit of the parallel loops (a constant, so results do
/// not depend on the thread count).
pub const CHUNK: usize = 1024;

/// Gradients with respect to the raw parameters of a [`Gaussians`] set, one
/// entry per Gaussian: `means` (scene units), `log_scales`, `rotations`
/// (the stored, unnormalised (w, x, y, z) quaternion) and `opacity_logits`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawGrads {
    pub means: Vec<[f32; 3]>,
    pub log_scales: Vec<[f32; 3]>,
    pub rotations: Vec<[f32; 4]>,
    pub opacity_logits: Vec<f32>,
}

impl RawGrads {
    /// All-zero gradients for `n` Gaussians.
    pub fn zeros(n: usize) -> Self {
        RawGrads {
            means: vec![[0.0; 3]; n],
            log_scales: vec![[0.0; 3]; n],
            rotations: vec![[0.0; 4]; n],
            opacity_logits: vec![0.0; n],
        }
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    /// `dst += weight · self`, entry by entry (a loss term's weight applied
    /// while summing into the total gradient). Panics on a length mismatch.
    pub fn add_to(&self, dst: &mut RawGrads, weight: f32) {
        assert_eq!(self.len(), dst.len(), "RawGrads length mismatch");
        fn axpy<const N: usize>(d: &mut [[f32; N]], s: &[[f32; N]], w: f32) {
            for (a, b) in d.iter_mut().zip(s) {
                for k in 0..N {
                    a[k] += w * b[k];
                }
            }
        }
        axpy(&mut dst.means, &self.means, weight);
        axpy(&mut dst.log_scales, &self.log_scales, weight);
        axpy(&mut dst.rotations, &self.rotations, weight);
        for (a, b) in dst.opacity_logits.iter_mut().zip(&self.opacity_logits) {
            *a += weight * b;
        }
    }
}

/// Checks the arrays the regularisers read (means, log scales, rotations,
/// opacity logits) have one entry per Gaussian.
fn check(g: &Gaussians) {
    let n = g.means.len();
    assert!(
        g.log_scales.len() == n && g.rotations.len() == n && g.opacity_logits.len() == n,
        "Gaussians arrays disagree in length"
    );
}
