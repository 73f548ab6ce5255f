//! A training or evaluation view: a camera with its photo and optional mask.

use super::Camera;

/// One view. `image` is row-major linear RGB in [0, 1] (the 8- or 16-bit
/// values / max, no gamma change), `width × height` of the camera.
#[derive(Clone, Debug)]
pub struct View {
    pub camera: Camera,
    pub image: Vec<[f32; 3]>,
    /// Object pixels (true) where a mask was given.
    pub mask: Option<Vec<bool>>,
    /// The image file the view came from, for messages.
    pub source: String,
}
