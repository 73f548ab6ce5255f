//! `splatkit-render`: the rendering pieces shared by every splatkit stage.
//!
//! This crate depends on nothing in the main `splatkit` package. It holds the
//! pinhole camera model (OpenCV axes) and real spherical-harmonics evaluation
//! in the 3DGS convention; rasterisers arrive with the issues that need them.

pub mod camera;
pub mod sh;

pub use camera::{Camera, CameraModel};
