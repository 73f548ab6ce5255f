//! Operations on meshes and triangle soups.
//!
//! - [`clean`]: the clean-up steps (Open3D's `remove_*` semantics), and
//!   [`cleanup`]: SuGaR's sequence of them as one call;
//! - [`decimate`]: quadric-error decimation to a face or vertex count, with
//!   [`edge_collapse`]: its engine, and [`manifold_check`]: the topology
//!   checks it keeps;
//! - [`trim`]: density trimming of Poisson meshes;
//! - [`prune`]: a triangle soup pruned to its solid, opaque triangles;
//! - [`texture_bake`]: SuGaR's texture atlas from bound Gaussians.
pub mod clean;
pub mod cleanup;
pub mod decimate;
pub mod edge_collapse;
pub mod manifold_check;
pub mod prune;
pub mod texture_bake;
pub mod trim;
