//! Surfaces from points or splats.
//!
//! - [`poisson`]: screened Poisson reconstruction (PoissonRecon's rules);
//! - [`tsdf`]: TSDF fusion of rendered or given depth (Open3D's legacy
//!   volume, 2DGS's use of it);
//! - [`marching_cubes`]: the polygon table both extractors share;
//! - [`scene_split`]: SuGaR's foreground / background split and automatic
//!   Poisson depth;
//! - [`soup_mesh`]: a triangle-splat soup as a plain coloured mesh;
//! - [`tetra`]: Gaussian Opacity Fields' marching-tetrahedra extraction.
pub mod marching_cubes;
pub mod poisson;
pub mod scene_split;
pub mod soup_mesh;
pub mod tetra;
pub mod tsdf;
