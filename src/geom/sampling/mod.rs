//! Point sets: sampling, thinning, neighbours, statistics.
//!
//! - [`sample`]: surface sampling of meshes;
//! - [`downsample`]: greedy radius (Poisson-disk) thinning;
//! - [`voxel`]: Open3D's voxel and uniform downsampling;
//! - [`knn`]: exact nearest-neighbour queries;
//! - [`outliers`]: statistical outlier removal;
//! - [`stats`]: summary statistics of distance sets (Chamfer, F-score).
pub mod downsample;
pub mod knn;
pub mod outliers;
pub mod sample;
pub mod stats;
pub mod voxel;
