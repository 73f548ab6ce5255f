//! Reusable geometry: nearest-neighbour index, surface sampling, point
//! downsampling, rigid/similarity registration, crop volumes.
pub mod knn;
