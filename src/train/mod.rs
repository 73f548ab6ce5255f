//! Optimisation loops on the `render` crate.
//!
//! - [`refine`]: SuGaR's refinement of Gaussians bound to a mesh (joint Adam
//!   on vertices, complex rotations, in-plane scales, opacities and SH);
//! - [`photometric`]: the photometric loss (0.8·L1 + 0.2·D-SSIM, masks) and
//!   the held-out evaluation (PSNR / SSIM) every loop shares;
//! - [`schedule`]: the seeded view order and the train / test split;
//! - [`sugar`]: SuGaR's coarse-stage regularisers (opacity entropy,
//!   density and SDF regularisers on sampled points) with raw gradients;
//! - [`session`]: the one driver of every trainer (the loop, evaluations,
//!   the finiteness guards, progress events);
//! - [`trainer`]: the interface every model's trainer implements;
//! - [`strategy`]: the densification strategies' interface (3DGS's ADC,
//!   Triangle Splatting's MCMC, SuGaR's prune) and the one path that moves
//!   optimiser moments and statistics with an edited model;
//! - [`groups`]: named per-primitive optimiser groups that follow edits;
//! - [`finite`]: the loops' guards against a loss or parameter that becomes
//!   NaN or infinite (what is checked when).

pub mod finite;
pub mod gaussians;
pub mod groups;
pub mod photometric;
pub mod refine;
pub mod schedule;
pub mod session;
pub mod strategy;
pub mod sugar;
pub mod trainer;
pub mod triangles;

/// Serde default of the trainers' `sh_degree` (the references' 3).
pub(crate) fn three() -> usize {
    3
}

/// Whether `sh_degree` is the default 3 (left out of the settings, so a
/// checkpoint written before the setting existed still resumes).
pub(crate) fn is_three(v: &usize) -> bool {
    *v == 3
}
