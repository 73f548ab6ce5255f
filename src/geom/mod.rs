//! Reusable geometry: nearest-neighbour index, surface sampling, point
//! downsampling, distance statistics, rigid/similarity registration, crop volumes.
pub mod downsample;
pub mod knn;
pub mod sample;
pub mod stats;
