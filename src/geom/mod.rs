//! Reusable geometry: nearest-neighbour index, surface sampling, point
//! downsampling, rigid/similarity registration, crop volumes.
pub mod crop;
pub mod knn;
pub mod registration;
pub mod voxel;
