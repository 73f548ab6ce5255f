//! One module per command. Each holds the command's pure core (callable from
//! Rust on model types), its clap arguments and `run`, which only resolves
//! files, progress and output.

pub mod bake_texture;
pub mod bind_gaussians;
pub mod chamfer;
pub mod clean;
pub mod convert;
pub mod decimate;
pub mod demo;
pub mod export_off;
pub mod info;
pub mod poisson;
pub mod prune_triangles;
pub mod refine;
pub mod render;
pub mod splat2points;
pub mod tetra_mesh;
pub mod train;
pub mod tsdf_fuse;
