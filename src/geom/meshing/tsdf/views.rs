//! The depth and colour maps that the meshing pass of 2DGS and Triangle
//! Splatting fuses, rendered from a scene for one camera.
//!
//! - Gaussians, 2DGS surfels and triangle splats are rendered with SH
//!   degree 0 (DC colour only, 2DGS's `active_sh_degree = 0`) on a black
//!   background (surfels with 2DGS's own rasteriser,
//!   [`splatkit_render::surfel`], whose `surf_depth` this is); depth is
//!   `(1 − r)·expected + r·median` ([`RenderOutput::surface_depth`]), r =
//!   `depth_ratio`; colour is `(uint8)(clip(rgb, 0, 1)·255)` (truncation, as
//!   2DGS casts);
//! - meshes: z-buffer depth; colour from vertex colours interpolated at the
//!   hit (unlit), or none when the mesh has no colours;
//! - where `mask` is given, depth is set to 0 where it is < 0.5, as 2DGS does
//!   with the alpha mask of each training image.
//!
//! The maps are row-major, `width × height` of the camera; depth is camera z,
//! 0 where nothing was hit.

use splatkit_render::gaussian::{self, Filter2d, Gaussians3, RasterSettings, RenderOutput};
use splatkit_render::mesh as zbuffer;
use splatkit_render::surfel::{self, SurfelSettings, Surfels2};
use splatkit_render::triangle::{self, Triangles3};

use crate::model::{Camera, Mesh};

/// A scene ready to rasterise for fusion.
pub enum FusionScene {
    /// Gaussians (reduced to SH degree 0 by [`FusionScene::gaussians`]).
    Gaussians(Gaussians3),
    /// 2DGS surfels (give them DC-only: `model::Surfels::to_raster_at(0)`).
    Surfels(Surfels2),
    /// Triangle splats (reduced to SH degree 0 by [`FusionScene::triangles`]).
    Triangles(Triangles3),
    /// An opaque mesh.
    Mesh(Mesh),
}

impl FusionScene {
    /// Gaussians, keeping only their DC colour.
    pub fn gaussians(g: &Gaussians3) -> Self {
        FusionScene::Gaussians(g.dc_only())
    }

    /// Triangle splats, keeping only their DC colour.
    pub fn triangles(t: &Triangles3) -> Self {
        FusionScene::Triangles(t.dc_only())
    }

    /// Points that stand for the scene's extent (Gaussian and surfel means,
    /// triangle corners, mesh vertices), for 2DGS's unbounded box.
    pub fn points(&self) -> Vec<[f32; 3]> {
        match self {
            FusionScene::Gaussians(g) => g.means.clone(),
            FusionScene::Surfels(s) => s.means.clone(),
            FusionScene::Triangles(t) => t.vertices.iter().flatten().copied().collect(),
            FusionScene::Mesh(m) => m.vertices.clone(),
        }
    }

    /// Whether the rendered views carry colour.
    pub fn has_color(&self) -> bool {
        match self {
            FusionScene::Mesh(m) => m.vertex_colors.is_some(),
            _ => true,
        }
    }
}

/// One rendered view.
#[derive(Clone, Debug)]
pub struct FusionView {
    pub depth: Vec<f32>,
    pub rgb: Option<Vec<[u8; 3]>>,
}

/// 2DGS's colour cast: clip to [0, 1], ×255, truncate.
#[inline]
fn cast_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0) as u8
}

fn splat_view(out: &RenderOutput, depth_ratio: f32) -> FusionView {
    FusionView {
        depth: out.surface_depth(depth_ratio),
        rgb: Some(out.rgb.iter().map(|c| c.map(cast_u8)).collect()),
    }
}

/// Renders `scene` from `cam`: surface depth with `depth_ratio` (splats
/// only), colour, and `mask` (row-major values in [0, 1], the camera's size)
/// applied to the depth. `near` is the near plane (2DGS: 0.2); `filter_2d`
/// the Gaussian rasteriser's 2-D filter (3DGS's dilation, or the Mip filter
/// for Mip-Splatting / GOF models).
pub fn render_view(
    scene: &FusionScene,
    cam: &Camera,
    depth_ratio: f32,
    near: f64,
    filter_2d: Filter2d,
    mask: Option<&[f32]>,
) -> FusionView {
    let s = RasterSettings {
        background: [0.0; 3],
        near,
        filter_2d,
        ..Default::default()
    };
    let mut v = match scene {
        FusionScene::Gaussians(g) => splat_view(&gaussian::render(g, cam, &s), depth_ratio),
        FusionScene::Triangles(t) => splat_view(&triangle::render(t, cam, &s), depth_ratio),
        FusionScene::Surfels(sf) => {
            let settings = SurfelSettings {
                background: [0.0; 3],
                near,
                ..SurfelSettings::default()
            };
            splat_view(&surfel::render(sf, cam, &settings), depth_ratio)
        }
        FusionScene::Mesh(m) => {
            let z = zbuffer::render(&m.vertices, &m.faces, cam, near);
            let rgb = m.vertex_colors.as_ref().map(|c| {
                (0..z.depth.len())
                    .map(|i| {
                        let f = z.face[i];
                        if f == zbuffer::NO_FACE {
                            return [0; 3];
                        }
                        let face = m.faces[f as usize];
                        let [u, v] = z.bary[i];
                        let w = [1.0 - u - v, u, v];
                        std::array::from_fn(|k| {
                            let x: f32 = (0..3).map(|j| w[j] * c[face[j] as usize][k] as f32).sum();
                            x.clamp(0.0, 255.0).round() as u8
                        })
                    })
                    .collect()
            });
            FusionView {
                depth: z.depth,
                rgb,
            }
        }
    };
    if let Some(m) = mask {
        for (d, &a) in v.depth.iter_mut().zip(m) {
            if a < 0.5 {
                *d = 0.0;
            }
        }
    }
    v
}
