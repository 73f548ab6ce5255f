//! `splatkit-render`: the rendering pieces shared by every splatkit stage.
//!
//! This crate depends on nothing in the main `splatkit` package. It holds:
//! - the pinhole camera model (OpenCV axes, [`camera`]) and real spherical
//!   harmonics in the 3DGS convention ([`sh`]);
//! - the rasterisers: [`gaussian`] (3DGS semantics) with its backward pass
//!   [`gaussian_grad`], [`triangle`] (Triangle Splatting semantics) with
//!   [`triangle_grad`], and the opaque z-buffer [`mesh`]; all share the tile
//!   binning of [`tiles`] and are deterministic for any thread count;
//! - [`dual`]: forward-mode dual numbers that give the projections' exact
//!   Jacobians from the same generic code as the forward pass (the triangle
//!   backward uses them; the Gaussian backward runs the hand-written reverse
//!   sweep of `gaussian_vjp`, tested equal to them, because the training
//!   loop spends its time there);
//! - [`splats`]: the splat arrays the Gaussian and surfel rasterisers take
//!   and the gradients they return, one type generic over the scale axes;
//! - [`surfel`]: 2DGS's surfel rasteriser (ray–splat intersection, its
//!   depth, normal and distortion maps) with its backward pass
//!   [`surfel_grad`];
//! - [`gaussian_integrate`]: Gaussian Opacity Fields' opacity of 3-D points
//!   (its `integrate` kernel per view and the minimum over views its mesh
//!   extraction takes);
//! - [`depth_normal`]: 2DGS's normals from depth and the depth–normal
//!   consistency loss with its gradients;
//! - [`loss`] (L1, SSIM with gradient, PSNR) and [`optim`] (Adam with
//!   per-group schedules) for photometric training.

pub mod camera;
pub mod depth_normal;
pub mod dual;
pub mod exp_approx;
pub mod gaussian;
pub mod gaussian_grad;
pub mod gaussian_integrate;
pub(crate) mod gaussian_vjp;
pub mod loss;
pub mod mesh;
pub mod optim;
pub mod sh;
pub mod splats;
pub mod surfel;
pub mod surfel_grad;
#[cfg(test)]
mod testutil;
pub mod tiles;
pub mod triangle;
pub mod triangle_grad;
pub mod triangle_stats;

pub use camera::{Camera, CameraModel};
