//! An orbit of cameras around a scene, as the `--orbit` flags describe it;
//! `geom::scenes::orbit` places the cameras.

use glam::DVec3;

/// Rings of cameras evenly spaced in azimuth around the centre of a
/// scene's central 96% box, looking at that centre.
#[derive(Clone, Debug, PartialEq)]
pub struct OrbitSpec {
    /// Views per ring (at least 1).
    pub views_per_ring: usize,
    /// Image size in pixels.
    pub width: u32,
    pub height: u32,
    /// Horizontal field of view, degrees, in (0, 180).
    pub fov_deg: f64,
    /// One ring per elevation above the horizon, degrees, in (−90, 90).
    pub elevations_deg: Vec<f64>,
    /// Distance from the centre (`None`: the central box fills the view).
    pub radius: Option<f64>,
    /// World up direction (non-zero).
    pub up: DVec3,
}
