//! The two fusion pipelines of `tsdf-fuse`, on depth maps that the caller
//! supplies one camera at a time (rendered from a scene with
//! [`super::render_view`], or read from files):
//!
//! - [`fuse_views`]: Open3D's `ScalableTSDFVolume` ([`TsdfVolume`]), the
//!   views integrated [`BATCH`] at a time, then marching cubes
//!   ([`extract_mesh`]);
//! - [`fuse_views_unbounded`]: 2DGS's unbounded variant
//!   ([`super::unbounded::fuse_unbounded`]), every map held at once, the
//!   contracted box from `--bound` or from the scene's points.
//!
//! Units are the scene's; depth is camera z, 0 where there is none. Colours
//! are RGB8. The maps are row-major at each camera's size.

use std::time::Instant;

use glam::DVec3;

use super::unbounded::{self, UnboundedParams, UnboundedView, bound_from_points};
use super::{
    BATCH, Frame, FusionScene, IntegrateStats, TsdfParams, TsdfVolume, camera_sphere, extract_mesh,
};
use crate::Error;
use crate::model::{Camera, Mesh, rig};

/// One camera's maps as a view source gives them: depth (camera z, scene
/// units, 0 = none; every value finite and ≥ 0) and colour when there is
/// one.
#[derive(Clone, Debug)]
pub struct ViewMaps {
    pub depth: Vec<f32>,
    pub rgb: Option<Vec<[u8; 3]>>,
}

/// What a fusion pipeline reports as it goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FuseProgress {
    /// This many more views were taken in (loaded, and for the bounded
    /// fusion integrated).
    Views(usize),
    /// Every view was taken in; the mesh is made next.
    ViewsDone,
}

/// Why a fusion pipeline failed.
#[derive(Debug)]
pub enum FuseError<E> {
    /// The caller's view source failed for a camera.
    View(E),
    /// Integrating the batch of views of these cameras (names) failed.
    Batch { cameras: Vec<String>, source: Error },
    /// Any other step failed: the volume, the camera sphere, the grid.
    Fusion(Error),
}

impl<E> From<Error> for FuseError<E> {
    fn from(e: Error) -> Self {
        FuseError::Fusion(e)
    }
}

/// Input of [`fuse_views`]: the cameras in order, the volume's settings
/// (scene units) and whether the volume keeps colour (the views' colours
/// are dropped when it does not).
#[derive(Clone, Copy, Debug)]
pub struct BoundedInput<'a> {
    pub cameras: &'a [Camera],
    pub params: TsdfParams,
    pub with_color: bool,
}

/// Output of [`fuse_views`].
#[derive(Clone, Debug)]
pub struct BoundedFusion {
    /// The extracted mesh (scene units), before any cluster filter.
    pub mesh: Mesh,
    /// What integrating each camera's view did, in camera order.
    pub views: Vec<IntegrateStats>,
    /// Blocks of the volume after the last view.
    pub blocks: usize,
    /// Bytes of the volume's blocks.
    pub volume_bytes: usize,
    /// Seconds of integration and extraction only (what Open3D's timings
    /// cover: not the loading of the views).
    pub fuse_seconds: f64,
}

/// Fuses the views of `input.cameras` into a [`TsdfVolume`] and extracts
/// its mesh. `load(i)` gives the maps of camera `i`; it is called for the
/// cameras of one batch of [`BATCH`], in order, before that batch is
/// integrated, then `progress` gets [`FuseProgress::Views`] with the
/// batch's size; [`FuseProgress::ViewsDone`] comes before the extraction.
pub fn fuse_views<E>(
    input: &BoundedInput,
    mut load: impl FnMut(usize) -> Result<ViewMaps, E>,
    progress: &dyn Fn(FuseProgress),
) -> Result<BoundedFusion, FuseError<E>> {
    let cams = input.cameras;
    let mut vol = TsdfVolume::new(input.params, input.with_color)?;
    let mut views = Vec::with_capacity(cams.len());
    let mut fuse_seconds = 0.0f64;
    let order: Vec<usize> = (0..cams.len()).collect();
    for chunk in order.chunks(BATCH) {
        let mut loaded = Vec::with_capacity(chunk.len());
        for &i in chunk {
            let maps = load(i).map_err(FuseError::View)?;
            loaded.push((maps.depth, if input.with_color { maps.rgb } else { None }));
        }
        let frames: Vec<Frame> = chunk
            .iter()
            .zip(&loaded)
            .map(|(&i, (depth, rgb))| Frame {
                camera: &cams[i],
                depth,
                color: rgb.as_deref(),
            })
            .collect();
        let t = Instant::now();
        let stats = vol
            .integrate_batch(&frames)
            .map_err(|source| FuseError::Batch {
                cameras: chunk.iter().map(|&i| cams[i].name.clone()).collect(),
                source,
            })?;
        fuse_seconds += t.elapsed().as_secs_f64();
        views.extend(stats);
        progress(FuseProgress::Views(chunk.len()));
    }
    progress(FuseProgress::ViewsDone);
    let (blocks, volume_bytes) = (vol.len(), vol.memory_bytes());
    let t = Instant::now();
    let mesh = extract_mesh(&vol);
    fuse_seconds += t.elapsed().as_secs_f64();
    Ok(BoundedFusion {
        mesh,
        views,
        blocks,
        volume_bytes,
        fuse_seconds,
    })
}

/// Input of [`fuse_views_unbounded`]: the cameras in order, whether colours are
/// kept, the grid resolution N (2DGS `--mesh_res`), the half side R of the
/// contracted box (`None`: from the scene's points, else from the depth
/// maps' points, [`bound_from_points`]) and the scene the maps were
/// rendered from, if any.
#[derive(Clone, Copy)]
pub struct UnboundedInput<'a> {
    pub cameras: &'a [Camera],
    pub with_color: bool,
    pub resolution: usize,
    pub bound: Option<f64>,
    pub scene: Option<&'a FusionScene>,
}

/// Output of [`fuse_views_unbounded`].
#[derive(Clone, Debug)]
pub struct UnboundedFusion {
    /// The extracted mesh (scene units), before any cluster filter.
    pub mesh: Mesh,
    /// Pixels with a depth (> 0) in each camera's map, in camera order.
    pub valid_pixels: Vec<usize>,
    /// The cameras' focus point and radius ([`camera_sphere`]): the
    /// contraction's centre and scale.
    pub center: DVec3,
    pub radius: f64,
    /// The half side R of the contracted box used.
    pub bound: f64,
}

/// 2DGS's unbounded fusion of the views of `input.cameras`. `load(i)`
/// gives the maps of camera `i`, for every camera in order, before
/// anything is fused (the grid is filled tile by tile from all of them);
/// `progress` gets [`FuseProgress::Views`]`(1)` after each and
/// [`FuseProgress::ViewsDone`] after the last.
pub fn fuse_views_unbounded<E>(
    input: &UnboundedInput,
    mut load: impl FnMut(usize) -> Result<ViewMaps, E>,
    progress: &dyn Fn(FuseProgress),
) -> Result<UnboundedFusion, FuseError<E>> {
    let cams = input.cameras;
    let mut maps = Vec::with_capacity(cams.len());
    let mut valid_pixels = Vec::with_capacity(cams.len());
    for i in 0..cams.len() {
        let m = load(i).map_err(FuseError::View)?;
        valid_pixels.push(m.depth.iter().filter(|&&z| z > 0.0).count());
        maps.push((m.depth, if input.with_color { m.rgb } else { None }));
        progress(FuseProgress::Views(1));
    }
    progress(FuseProgress::ViewsDone);
    let sphere = camera_sphere(cams)?;
    let bound = match input.bound {
        Some(b) => b,
        None => {
            let pts = match input.scene {
                Some(s) => s.points(),
                None => cams
                    .iter()
                    .zip(&maps)
                    .flat_map(|(c, (d, _))| depth_points(c, d))
                    .collect(),
            };
            bound_from_points(&pts, sphere.center, sphere.radius)
        }
    };
    let uv: Vec<UnboundedView> = cams
        .iter()
        .zip(&maps)
        .map(|(c, (d, rgb))| UnboundedView {
            camera: c,
            depth: d,
            rgb: rgb.as_deref(),
        })
        .collect();
    let up = UnboundedParams {
        center: sphere.center,
        radius: sphere.radius,
        resolution: input.resolution,
        bound,
        max_range: 32.0,
    };
    let mesh = unbounded::fuse_unbounded(&uv, &up)?;
    Ok(UnboundedFusion {
        mesh,
        valid_pixels,
        center: sphere.center,
        radius: sphere.radius,
        bound,
    })
}

/// World points of every 8th pixel (rows and columns) with a depth.
fn depth_points(cam: &Camera, depth: &[f32]) -> Vec<[f32; 3]> {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut out = Vec::new();
    for i in (0..h).step_by(8) {
        for j in (0..w).step_by(8) {
            let z = depth[i * w + j] as f64;
            if z > 0.0 {
                let p = rig::back_project(cam, j, i, z);
                out.push([p.x as f32, p.y as f32, p.z as f32]);
            }
        }
    }
    out
}
