//! Reusable geometry: nearest-neighbour index, surface sampling, point
//! downsampling, distance statistics, rigid/similarity registration, crop volumes.
pub mod binding;
pub mod clean;
pub mod cleanup;
pub mod crop;
pub mod decimate;
pub mod diamond_zbuffer;
pub mod downsample;
pub mod knn;
pub mod levelset;
pub mod marching_cubes;
pub mod orbit;
pub mod outliers;
pub mod poisson;
pub mod prune;
pub mod registration;
pub mod sample;
pub mod scene_split;
pub mod soup_mesh;
pub mod splat_points;
pub mod stats;
pub mod synthetic;
pub mod texture_bake;
pub mod trim;
pub mod tsdf;
pub mod voxel;
