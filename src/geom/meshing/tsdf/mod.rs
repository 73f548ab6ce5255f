//! TSDF fusion of depth maps into a mesh, as 2DGS and Triangle Splatting
//! mesh their scenes: Open3D's `ScalableTSDFVolume` ([`volume`]), its
//! marching cubes ([`extract`]), 2DGS's cluster filter ([`post`]) and its
//! automatic settings from the cameras ([`bounds`]), and the depth and
//! colour maps rendered from a scene for it ([`views`]); 2DGS's unbounded
//! variant on a contracted grid ([`unbounded`]); the two pipelines of
//! `tsdf-fuse` over views a caller supplies ([`pipeline`]).
//!
//! Pure functions on cameras and depth maps; reading the maps (or rendering
//! them) is the caller's job. Units are the scene's; depth is camera z.

pub mod bounds;
pub mod extract;
pub mod pipeline;
pub mod post;
pub mod unbounded;
pub mod views;
pub mod volume;

#[cfg(test)]
mod tests;

pub use bounds::{CameraSphere, auto_params, camera_sphere};
pub use extract::extract_mesh;
pub use pipeline::{
    BoundedFusion, BoundedInput, FuseError, FuseProgress, UnboundedFusion, UnboundedInput,
    ViewMaps, fuse_views, fuse_views_unbounded,
};
pub use post::{ClusterReport, keep_largest_clusters};
pub use unbounded::{UnboundedParams, UnboundedView, bound_from_points, fuse_unbounded};
pub use views::{FusionScene, FusionView, render_view};
pub use volume::{BATCH, BlockBounds, Frame, IntegrateStats, TsdfParams, TsdfVolume};
