//! Oriented, coloured points on the surface of a Gaussian or 2DGS surfel
//! scene (what `splat2points` writes for Poisson).
//!
//! - [`levelset`]: SuGaR's level-set sampling along camera rays;
//! - [`diamond_zbuffer`]: the depth of the camera-facing ±2σ diamonds it
//!   starts from;
//! - [`splat_points`]: the centre and depth alternatives, and the one entry
//!   point over the three methods;
//! - [`surfel_points`]: the depth and centre methods for 2DGS surfels.
pub mod diamond_zbuffer;
pub mod levelset;
pub mod splat_points;
pub mod surfel_points;
