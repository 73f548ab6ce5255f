//! Cameras: the type lives in `splatkit-render` (which cannot depend on this
//! crate) and is re-exported here. See [`splatkit_render::camera`] for the
//! conventions (OpenCV axes, world-to-camera pose in f64, pixel centres at +0.5).

pub use splatkit_render::camera::{Camera, CameraModel};
