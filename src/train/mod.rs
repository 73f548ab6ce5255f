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

/// The SH degree a trainer renders at `iteration`: one band more every
/// `per_band` iterations (the references' 1,000, scaled with the schedule),
/// never above the model's stored degree nor the `--sh-degree` cap.
pub(crate) fn sh_band(iteration: u64, per_band: u64, model_degree: usize, cap: usize) -> usize {
    ((iteration / per_band.max(1)) as usize)
        .min(model_degree)
        .min(cap)
}

/// Whether `sh_degree` is the default 3 (left out of the settings, so a
/// checkpoint written before the setting existed still resumes).
pub(crate) fn is_three(v: &usize) -> bool {
    *v == 3
}

#[cfg(test)]
mod tests {
    /// One band per `per_band` iterations, capped by the model's degree and
    /// by `--sh-degree`; a zero interval counts as 1 (no division by zero).
    #[test]
    fn sh_band_steps_and_caps() {
        assert_eq!(super::sh_band(0, 1000, 3, 3), 0);
        assert_eq!(super::sh_band(999, 1000, 3, 3), 0);
        assert_eq!(super::sh_band(2999, 1000, 3, 3), 2);
        assert_eq!(super::sh_band(50_000, 1000, 3, 3), 3);
        assert_eq!(super::sh_band(50_000, 1000, 3, 1), 1);
        assert_eq!(super::sh_band(50_000, 1000, 0, 3), 0);
        assert_eq!(super::sh_band(2, 0, 3, 3), 2);
    }
}
