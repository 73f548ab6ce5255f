//! Binary image masks (object / background), row-major.

/// A binary mask, row-major.
#[derive(Clone, Debug)]
pub struct Mask {
    pub width: usize,
    pub height: usize,
    pub bits: Vec<bool>,
}
