//! Crop volumes: a polygon prism along one coordinate axis, as stored in the
//! Tanks-and-Temples `<Scene>.json` files (Open3D `SelectionPolygonVolume`).
//!
//! This is the data only. Which points a volume contains (Open3D's exact
//! rule) and cropping a cloud are in [`crate::geom::alignment::crop`]; reading and
//! writing the JSON form is in [`crate::io::tnt`].

/// The coordinate axis a crop prism extends along (its "orthogonal axis").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Prism along x; the polygon lives in the (y, z) plane.
    X,
    /// Prism along y; the polygon lives in the (x, z) plane.
    Y,
    /// Prism along z; the polygon lives in the (x, y) plane.
    Z,
}

impl Axis {
    /// The coordinate indices (u, v, w) Open3D uses for this axis: (u, v) is
    /// the polygon plane, w the prism axis. X → (1, 2, 0), Y → (0, 2, 1),
    /// Z → (0, 1, 2).
    pub fn uvw(self) -> (usize, usize, usize) {
        match self {
            Axis::X => (1, 2, 0),
            Axis::Y => (0, 2, 1),
            Axis::Z => (0, 1, 2),
        }
    }

    /// The upper-case letter used in the JSON files ("X", "Y" or "Z").
    pub fn letter(self) -> &'static str {
        match self {
            Axis::X => "X",
            Axis::Y => "Y",
            Axis::Z => "Z",
        }
    }
}

/// A polygon prism: points whose coordinate along `orthogonal_axis` lies in
/// `[axis_min, axis_max]` (both inclusive) and whose projection onto the
/// other two coordinates falls inside `bounding_polygon`.
///
/// Units are those of the point cloud (metres for TnT ground truth).
#[derive(Clone, Debug, PartialEq)]
pub struct CropVolume {
    /// Axis the prism extends along.
    pub orthogonal_axis: Axis,
    /// Lower bound along the axis (inclusive).
    pub axis_min: f64,
    /// Upper bound along the axis (inclusive).
    pub axis_max: f64,
    /// Polygon vertices as full 3-D points (the axis coordinate is ignored);
    /// closed implicitly (last vertex connects to the first). Open3D stores
    /// the TnT polygons this way, and so does this type. Stored as arrays,
    /// like the point clouds it crops, and serialised as such.
    pub bounding_polygon: Vec<[f64; 3]>,
}
