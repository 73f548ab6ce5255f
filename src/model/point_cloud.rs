//! Oriented, coloured point clouds.

use super::Extras;

/// A point cloud. Positions in world units (f32); normals are unit vectors
/// when present; colours are 8-bit sRGB.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud {
    pub positions: Vec<[f32; 3]>,
    pub normals: Option<Vec<[f32; 3]>>,
    pub colors: Option<Vec<[u8; 3]>>,
    /// Everything else the source file held (extra scalars such as
    /// `confidence`, other elements, comments), row-aligned with `positions`.
    pub extras: Extras,
}

impl PointCloud {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
}
