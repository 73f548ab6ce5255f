//! Oriented, coloured points on the surface of a Gaussian scene (what
//! `splat2points` writes for Poisson).
//!
//! - [`levelset`]: SuGaR's level-set sampling along camera rays;
//! - [`diamond_zbuffer`]: the depth of the camera-facing ±2σ diamonds it
//!   starts from;
//! - [`splat_points`]: the centre and depth alternatives, and the one entry
//!   point over the three methods.
pub mod diamond_zbuffer;
pub mod levelset;
pub mod splat_points;
