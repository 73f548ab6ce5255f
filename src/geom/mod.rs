//! Geometry on model types, grouped by job (docs/ARCHITECTURE.md, "New
//! geometry"). Nothing here reads or writes files.
//!
//! - [`meshing`]: surfaces from points or splats (screened Poisson, TSDF
//!   fusion, marching cubes, SuGaR's foreground/background split, a
//!   triangle soup as a mesh);
//! - [`surface_points`]: oriented points from Gaussians (SuGaR's level set
//!   and its diamond z-buffer, the centre and depth alternatives);
//! - [`mesh_ops`]: operations on meshes and soups (clean-up, decimation,
//!   density trimming, triangle pruning, texture baking);
//! - [`sampling`]: point sets (surface sampling, downsampling, voxel grids,
//!   nearest neighbours, outlier removal, distance statistics);
//! - [`delaunay`]: 3-D Delaunay tetrahedralisation (GOF's tetrahedral
//!   meshes);
//! - [`binding`]: Gaussians bound to mesh triangles (SuGaR);
//! - [`alignment`]: registration and crop volumes (Tanks and Temples);
//! - [`scenes`]: generated scenes and camera orbits (the demo's built-in
//!   scene, cameras for scenes that come without them).
pub mod alignment;
pub mod binding;
pub mod delaunay;
pub mod mesh_ops;
pub mod meshing;
pub mod sampling;
pub mod scenes;
pub mod surface_points;
