//! Optimisation loops on the `render` crate.
//!
//! - [`refine`]: SuGaR's refinement of Gaussians bound to a mesh (joint Adam
//!   on vertices, complex rotations, in-plane scales, opacities and SH);
//! - [`photometric`]: the photometric loss (0.8·L1 + 0.2·D-SSIM, masks) and
//!   the held-out evaluation (PSNR / SSIM) every loop shares;
//! - [`schedule`]: the seeded view order and the train / test split;
//! - [`sugar`]: SuGaR's coarse-stage regularisers (opacity entropy,
//!   density and SDF regularisers on sampled points) with raw gradients;
//! - [`checkpoint`]: optimiser state on disk, so `--resume` continues bit
//!   for bit;
//! - [`finite`]: the loops' guards against a loss or parameter that becomes
//!   NaN or infinite (what is checked when).

pub mod checkpoint;
pub mod finite;
pub mod gaussians;
pub mod groups;
pub mod photometric;
pub mod refine;
pub mod schedule;
pub mod sugar;
pub mod trainer;
pub mod triangles;
