//! Putting two point sets in one frame and cutting them to a region (the
//! Tanks-and-Temples protocol's steps).
//!
//! - [`registration`]: similarity from correspondences, RANSAC, ICP;
//! - [`crop`]: crop volumes (polygon prisms).
pub mod crop;
pub mod registration;
