//! Gaussian Opacity Fields' surface extraction (Yu et al. 2024, code
//! `autonomousvision/gaussian-opacity-fields`, `extract_mesh.py`,
//! `marching_tetrahedra_with_binary_search`): a tetrahedralisation of points
//! taken from the Gaussians, the opacity field at its vertices, marching
//! tetrahedra on the 0.5 level and a binary search along each cut edge.
//!
//! - [`points`]: the tetrahedralisation's vertices, GOF's
//!   `get_tetra_points` (box corners at ±3σ and the centres) and its
//!   `get_frustum_mask`;
//! - [`marching`]: marching tetrahedra with GOF's (kaolin's) tables and order;
//! - [`refine`]: the binary search on the cut edges and GOF's edge filter;
//! - [`extract`]: the whole extraction, stage by stage.
//!
//! The opacity at those points (GOF's `evaluage_alpha`, sdf = alpha − 0.5)
//! is `splatkit_render::gaussian_integrate`.

pub mod extract;
pub mod marching;
pub mod points;
pub mod refine;

pub use points::{DEFAULT_FAR, DEFAULT_NEAR, TetraPoints, box_points, frustum_mask, tetra_points};
