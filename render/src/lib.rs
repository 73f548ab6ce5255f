//! `splatkit-render`: the rendering pieces shared by every splatkit stage.
//!
//! This crate depends on nothing in the main `splatkit` package. It holds the
//! pinhole camera model (OpenCV axes) and real spherical-harmonics evaluation
//! in the 3DGS convention, and the rasterisers: [`gaussian`] (3DGS semantics,
//! forward).

pub mod camera;
pub mod dual;
pub mod gaussian;
pub mod gaussian_grad;
pub mod loss;
pub mod mesh;
pub mod optim;
pub mod sh;
#[cfg(test)]
mod testutil;
pub mod tiles;
pub mod triangle;
pub mod triangle_grad;

pub use camera::{Camera, CameraModel};
