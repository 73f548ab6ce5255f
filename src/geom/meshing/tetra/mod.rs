//! Gaussian Opacity Fields' surface extraction (Yu et al. 2024, code
//! `autonomousvision/gaussian-opacity-fields`, `extract_mesh.py`): a
//! tetrahedralisation of points taken from the Gaussians, the opacity field
//! at its vertices, marching tetrahedra on the 0.5 level and a binary search
//! along each cut edge.
//!
//! - [`marching`]: marching tetrahedra with GOF's (kaolin's) tables and order;
//! - [`refine`]: the binary search on the cut edges and GOF's edge filter.
pub mod marching;
pub mod refine;
