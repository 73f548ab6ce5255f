//! A training or evaluation view: a camera with its photo and optional mask.

use super::Camera;

/// One view. `image` is row-major linear RGB in [0, 1] (the 8- or 16-bit
/// values / max, no gamma change), `width × height` of the camera; see
/// [`View::alpha`] for photos that had an alpha channel.
#[derive(Clone, Debug)]
pub struct View {
    pub camera: Camera,
    pub image: Vec<[f32; 3]>,
    /// Object pixels (true) where a mask was given.
    pub mask: Option<Vec<bool>>,
    /// Per-pixel opacity in [0, 1] (row-major, `width × height`) when the
    /// photo had an alpha channel and was composited onto a background at
    /// load (`image = rgb·a + bg·(1 − a)`), so a trainer can re-composite
    /// onto another (e.g. random) background: `rgb·a = image − bg·(1 − a)`.
    pub alpha: Option<Vec<f32>>,
    /// The image file the view came from, for messages.
    pub source: String,
}
