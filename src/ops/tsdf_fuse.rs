//! `tsdf-fuse`: depth maps fused into a coloured mesh as 2DGS and Triangle
//! Splatting mesh their scenes ([`crate::geom::meshing::tsdf`]: Open3D's
//! ScalableTSDFVolume and marching cubes, 2DGS's settings and cluster
//! filter).
//!
//! The depth maps are rendered here from a scene (Gaussians, 2DGS surfels,
//! triangle splats or a mesh; [`crate::geom::meshing::tsdf::views`]) or read from files
//! ([`crate::io::depth`]), one per camera, matched by image name. This module
//! only resolves files, flags and progress.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Args;
use serde_json::json;

use crate::cli::filter2d::Filter2dArgs;
use crate::cli::orbit::{SizeFrom, check_image_budget, image_bytes, largest_size};
use crate::cli::{Common, positive_f64, shown, unit_f64, usage};
use crate::geom::meshing::tsdf::{
    BATCH, BlockBounds, BoundedInput, ClusterReport, FuseError, FuseProgress, FusionScene,
    TsdfParams, TsdfVolume, UnboundedInput, ViewMaps, auto_params, camera_sphere, fuse_views,
    fuse_views_unbounded, keep_largest_clusters, render_view,
};
use crate::io::any::{MeshWriteOptions, load_kinds, output_format, save_mesh};
use crate::io::cameras::read_cameras;
use crate::io::depth::{find_depth, find_image, read_depth, read_mask_values, read_rgb8};
use crate::io::detect::FileFormat;
use crate::model::{self, Camera, Mesh, SceneKind, rig};
use splatkit_render::gaussian::Filter2d;

/// Arguments of `tsdf-fuse`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  # 2DGS defaults from the cameras
  tsdf-fuse point_cloud.ply --cameras cameras.json -o fuse.ply
  # 2DGS surfels, as its render.py
  tsdf-fuse 2dgs/point_cloud/iteration_30000/point_cloud.ply \\
      --cameras 2dgs/cameras.json -o fuse.ply
  tsdf-fuse scene.pt --cameras scan24/cameras.npz --masks scan24/mask \\
      --dtu -o fuse_post.ply
  tsdf-fuse --depth renders/ --cameras sparse/0 --color renders/ -o mesh.ply
  render scene.ply --cameras cams.json -o d/ --outputs rgb,depth \\
      && tsdf-fuse --depth d/ --color d/ --cameras cams.json -o m.ply")]
pub struct TsdfFuseArgs {
    /// Scene to render depth from: 3DGS Gaussian PLY, 2DGS surfel PLY
    /// (rendered with 2DGS's surfel rasteriser), Triangle Splatting `.pt` or
    /// soup PLY, or a mesh. Leave out with --depth.
    pub scene: Option<PathBuf>,
    /// Camera file or folder (COLMAP, cameras.json, transforms.json,
    /// cameras.npz); one depth map per camera.
    #[arg(long)]
    pub cameras: PathBuf,
    /// Output mesh (PLY, OBJ, OFF, glTF/GLB by extension); `-` = PLY on stdout.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// Folder of depth maps to fuse instead of rendering a scene:
    /// NAME_depth.npy, NAME.npy, NAME_depth.png or NAME.png per camera image NAME.
    #[arg(long, value_name = "DIR")]
    pub depth: Option<PathBuf>,
    /// 16-bit depth PNGs store depth × this.
    #[arg(long, default_value_t = 1000.0, value_parser = positive_f64)]
    pub depth_scale: f64,
    /// Folder of colour images (NAME.png) for --depth; without it the mesh
    /// has no colours.
    #[arg(long, value_name = "DIR")]
    pub color: Option<PathBuf>,
    /// Folder of masks (NAME.png): depth is dropped where the mask (alpha,
    /// or grey / mean RGB) is below 0.5, as 2DGS does with alpha masks.
    #[arg(long, value_name = "DIR")]
    pub masks: Option<PathBuf>,
    /// Rendered depth = (1 − r)·expected + r·median (2DGS `--depth_ratio`)
    /// [default: 0 for 2DGS surfels (2DGS's own default), 1 otherwise and
    /// with --dtu].
    #[arg(long, value_parser = unit_f64)]
    pub depth_ratio: Option<f64>,
    /// Voxel size, scene units [default: depth-trunc / --mesh-res].
    #[arg(long, value_parser = positive_f64)]
    pub voxel: Option<f64>,
    /// SDF truncation, scene units [default: 5 × voxel].
    #[arg(long, value_parser = positive_f64)]
    pub sdf_trunc: Option<f64>,
    /// Depths at or beyond this are dropped [default: 2 × the cameras'
    /// bounding radius, as 2DGS].
    #[arg(long, value_parser = positive_f64)]
    pub depth_trunc: Option<f64>,
    /// Grid resolution the automatic voxel size is derived from.
    #[arg(long, default_value_t = 1024, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=1u64 << 16))]
    pub mesh_res: usize,
    /// The DTU recipe of 2DGS and Triangle Splatting: voxel 0.004, sdf_trunc
    /// 0.016, depth_trunc 3.0, depth ratio 1, one cluster kept (explicit
    /// flags still win).
    #[arg(long)]
    pub dtu: bool,
    /// Keep the K largest connected components (2DGS `--num_cluster`; ties
    /// are kept, components under --min-cluster-faces go). Off by default
    /// (every component kept); --dtu sets 1.
    #[arg(long, value_name = "K", value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    pub keep_clusters: Option<usize>,
    /// With --keep-clusters: components with fewer faces always go.
    #[arg(long, default_value_t = 50)]
    pub min_cluster_faces: usize,
    /// No vertex colours (by default the mesh has the rendered colours, or
    /// --color's).
    #[arg(long)]
    pub no_color: bool,
    /// 2DGS's unbounded variant (`--unbounded`, `fuse_unbounded.ply`): the
    /// TSDF sampled on a --mesh-res grid in contracted space around the
    /// cameras' focus point; for scenes that reach far from the cameras.
    /// --voxel, --sdf-trunc, --depth-trunc and --dtu do not apply.
    #[arg(long)]
    pub unbounded: bool,
    /// With --unbounded: half side R of the contracted box [default: 2DGS's
    /// min(q95 of the scene's contracted points + 0.01, 1.9)].
    #[arg(long, value_parser = positive_f64)]
    pub bound: Option<f64>,
    /// Render at 1/N of the cameras' size (3DGS / 2DGS `-r N`: DTU's
    /// 1600×1200 cameras at `-r 2` give 800×600); intrinsics scale with the
    /// size. Masks of N times the render size are box-averaged to it.
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = clap::builder::RangedU64ValueParser::<u32>::new().range(1..=64))]
    pub downscale: u32,
    /// Near plane of the renders (camera z, scene units): splats and faces
    /// nearer to the camera are not drawn. Unused with --depth.
    #[arg(long, default_value_t = 0.2, value_parser = crate::cli::nonneg_f64)]
    pub near: f64,
    #[command(flatten)]
    pub filter: Filter2dArgs,
    #[command(flatten)]
    pub common: Common,
}

/// Where one camera's depth (and colour, mask) comes from.
struct ViewFiles {
    depth: Option<PathBuf>,
    color: Option<PathBuf>,
    mask: Option<PathBuf>,
}

/// The fusion distances: flags, then the DTU preset, then 2DGS's defaults
/// from the cameras; `max_blocks` from the memory budget less
/// `image_bytes`, and the block bounds of the cameras. A usage error when
/// the blocks one depth sample touches cannot fit the budget.
fn resolve_params(
    args: &TsdfFuseArgs,
    cams: &[Camera],
    image_bytes: u64,
) -> anyhow::Result<(TsdfParams, String, BlockBounds)> {
    let (mut voxel, mut sdf, mut depth) = (args.voxel, args.sdf_trunc, args.depth_trunc);
    let mut how = "flags".to_string();
    if args.dtu {
        voxel = voxel.or(Some(0.004));
        sdf = sdf.or(Some(0.016));
        depth = depth.or(Some(3.0));
        how = "dtu".into();
    }
    let depth_trunc = match depth {
        Some(d) => d,
        None => {
            let s = camera_sphere(cams)?;
            how = format!("cameras (radius {:.6})", s.radius);
            auto_params(s.radius, args.mesh_res).2
        }
    };
    let voxel = voxel.unwrap_or(depth_trunc / args.mesh_res as f64);
    let sdf_trunc = sdf.unwrap_or(5.0 * voxel);
    let mut p = TsdfParams::new(voxel, sdf_trunc, depth_trunc);
    p.validate()?;
    // The blocks that fit the memory budget beside the image buffers.
    let per_block = TsdfVolume::block_bytes(true) as u64 + BLOCK_EXTRA_BYTES;
    let room = crate::io::budget::usable_bytes().saturating_sub(image_bytes);
    p.max_blocks = usize::try_from(room / per_block)
        .unwrap_or(usize::MAX)
        .max(1);
    // One usable depth sample alone allocates `per_sample_min` blocks: when
    // those cannot fit, the flags are refused before anything is rendered.
    let bounds = p.block_bounds(cams);
    crate::io::budget::check(
        &format!(
            "--voxel {voxel} --sdf-trunc {sdf_trunc} (from {how}): the {} TSDF blocks of 16³ voxels \
             that one depth sample touches (2·sdf-trunc spans {:.0} blocks of 16 voxels per axis)",
            bounds.per_sample_min,
            2.0 * sdf_trunc / p.unit_length()
        ),
        bounds
            .per_sample_min
            .saturating_mul(per_block)
            .saturating_add(image_bytes),
    )
    .map_err(|e| usage(e.to_string()))?;
    Ok((p, how, bounds))
}

/// Bytes per TSDF block beyond its voxel arrays: its key, index entry,
/// `Block` header and per-batch frame list (about 150), and its share of
/// the extracted mesh (a surface crossing a block gives about 2·16²
/// triangles with their vertices, colours and welding entries): 16 KiB.
pub const BLOCK_EXTRA_BYTES: u64 = 16 << 10;

/// Bytes per pixel of the one view rendered at a time (the splat render's
/// 52 of output + 12 of working buffers, or a mesh z-buffer's 28 + 52), and
/// its mask read as f32 (4).
pub const RENDER_BYTES_PER_PIXEL: u64 = 80 + 4;

/// Bytes per pixel of each view held by the bounded fusion, [`BATCH`] at a
/// time: the depth map (4), colours (3), and the prepared pixel (depth,
/// ray multiplier, colour: 12).
pub const BATCH_VIEW_BYTES_PER_PIXEL: u64 = 4 + 3 + 12;

/// Bytes of `tsdf-fuse`'s image buffers for `cams`: the largest view's
/// pixels × ([`RENDER_BYTES_PER_PIXEL`] + [`BATCH`] ×
/// [`BATCH_VIEW_BYTES_PER_PIXEL`]) for the bounded fusion; with
/// `unbounded`, every view's pixels × the unbounded fusion's
/// `VIEW_BYTES_PER_PIXEL` (all maps are held) + the largest's ×
/// [`RENDER_BYTES_PER_PIXEL`].
pub fn fuse_image_bytes(cams: &[Camera], unbounded: bool) -> u64 {
    if unbounded {
        image_bytes(
            cams,
            RENDER_BYTES_PER_PIXEL,
            crate::geom::meshing::tsdf::unbounded::VIEW_BYTES_PER_PIXEL,
        )
    } else {
        image_bytes(
            cams,
            RENDER_BYTES_PER_PIXEL + BATCH as u64 * BATCH_VIEW_BYTES_PER_PIXEL,
            0,
        )
    }
}

/// `tsdf-fuse` entry point: checks the flags, finds every input, checks
/// the memory budget, fuses ([`fuse`]), filters the clusters, writes the
/// mesh and reports.
pub fn run(args: TsdfFuseArgs) -> anyhow::Result<()> {
    args.common.init()?;
    args.common.check_output(&args.output, true)?;
    let format = output_format(&args.output, None, FileFormat::Ply)?;
    check_flags(&args)?;
    let t0 = std::time::Instant::now();
    let cams = read_fusion_cameras(&args)?;
    let files = find_view_files(&args, &cams)?;
    let (params, how, bounds) = plan(&args, &cams)?;
    let (scene, filter_2d) = load_fusion_scene(&args)?;
    let depth_ratio = default_depth_ratio(&args, scene.as_ref());
    let with_color = !args.no_color
        && match &scene {
            Some(s) => s.has_color(),
            None => args.color.is_some(),
        };
    let setup = FuseSetup {
        cams: &cams,
        files: &files,
        scene: scene.as_ref(),
        params,
        how,
        bounds,
        with_color,
        depth_ratio,
        filter_2d,
    };
    let mut fused = fuse(&args, &setup)?;
    let raw = (fused.mesh.vertices.len(), fused.mesh.faces.len());
    let k = args.keep_clusters.or(args.dtu.then_some(1));
    let clusters = k.map(|k| keep_largest_clusters(&mut fused.mesh, k, args.min_cluster_faces));
    if fused.mesh.faces.is_empty() {
        return Err(empty_mesh_error(&args, &params, cams.len(), raw.1));
    }
    save_mesh(
        &args.output,
        &fused.mesh,
        format,
        &MeshWriteOptions::default(),
    )?;
    report(
        &args,
        &setup,
        &fused,
        raw,
        clusters,
        t0.elapsed().as_secs_f64(),
    )
}

/// `--depth-ratio`, else the DTU recipe's 1, else 2DGS's default for its
/// surfels, 0 (`PipelineParams.depth_ratio`: the mean depth, which its
/// `render.py` fuses unless told otherwise), else 1 (the median depth,
/// Triangle Splatting's and 2DGS's DTU setting).
fn default_depth_ratio(args: &TsdfFuseArgs, scene: Option<&FusionScene>) -> f32 {
    match (args.depth_ratio, args.dtu, scene) {
        (Some(r), _, _) => r as f32,
        (None, true, _) => 1.0,
        (None, false, Some(FusionScene::Surfels(_))) => 0.0,
        _ => 1.0,
    }
}

/// The usage errors among the flags, and a `--depth`, `--color` or
/// `--masks` that is not a folder; before anything is read.
fn check_flags(args: &TsdfFuseArgs) -> anyhow::Result<()> {
    match (&args.scene, &args.depth) {
        (Some(_), Some(_)) => return Err(usage("give a scene or --depth DIR, not both")),
        (None, None) => return Err(usage("give a scene to render, or --depth DIR")),
        _ => {}
    }
    if args.unbounded
        && (args.dtu
            || args.voxel.is_some()
            || args.sdf_trunc.is_some()
            || args.depth_trunc.is_some())
    {
        return Err(usage(
            "--unbounded sets its own grid (--mesh-res, --bound): --dtu, --voxel, --sdf-trunc \
             and --depth-trunc do not apply",
        ));
    }
    if args.bound.is_some() && !args.unbounded {
        return Err(usage("--bound goes with --unbounded"));
    }
    if args.color.is_some() && args.depth.is_none() {
        return Err(usage(
            "--color goes with --depth (a rendered scene has its own colours)",
        ));
    }
    for (flag, dir) in [
        ("--depth", &args.depth),
        ("--color", &args.color),
        ("--masks", &args.masks),
    ] {
        if let Some(d) = dir
            && !d.is_dir()
        {
            bail!("{flag} {}: not a folder", d.display());
        }
    }
    Ok(())
}

/// The cameras of `--cameras`, downscaled by `--downscale` (sizes and
/// intrinsics in pixels of the render), each a pinhole.
fn read_fusion_cameras(args: &TsdfFuseArgs) -> anyhow::Result<Vec<Camera>> {
    let cams: Vec<Camera> = read_cameras(&args.cameras)
        .with_context(|| format!("reading cameras {}", args.cameras.display()))?
        .into_iter()
        .map(|c| rig::downscale(&c, args.downscale))
        .collect();
    for c in &cams {
        c.require_pinhole()
            .map_err(|e| anyhow::anyhow!("camera {:?}: {e}", c.name))?;
    }
    Ok(cams)
}

/// Every camera's depth, colour and mask file, found before any work.
fn find_view_files(args: &TsdfFuseArgs, cams: &[Camera]) -> anyhow::Result<Vec<ViewFiles>> {
    cams.iter()
        .map(|c| -> anyhow::Result<ViewFiles> {
            Ok(ViewFiles {
                depth: args
                    .depth
                    .as_deref()
                    .map(|d| find_depth(d, c))
                    .transpose()?,
                color: args
                    .color
                    .as_deref()
                    .map(|d| find_image(d, "colour image", c))
                    .transpose()?,
                mask: args
                    .masks
                    .as_deref()
                    .map(|d| find_image(d, "mask", c))
                    .transpose()?,
            })
        })
        .collect::<anyhow::Result<_>>()
}

/// The fusion's settings within the memory budget, before anything is
/// rendered or read: the image buffers the cameras' sizes make (a file's:
/// exit 1), then the grid the flags make (exit 2). Returns the bounded
/// fusion's parameters (placeholders with `--unbounded`), where they came
/// from, and their block bounds.
fn plan(args: &TsdfFuseArgs, cams: &[Camera]) -> anyhow::Result<(TsdfParams, String, BlockBounds)> {
    let image_bytes = fuse_image_bytes(cams, args.unbounded);
    check_image_budget(
        SizeFrom::File(&args.cameras),
        &format!(
            "the depth maps of {} views (largest {})",
            cams.len(),
            largest_size(cams)
        ),
        image_bytes,
    )?;
    if !args.unbounded {
        return resolve_params(args, cams, image_bytes);
    }
    crate::io::budget::check(
        &format!(
            "--unbounded --mesh-res {}: the contracted grid ({} samples per axis) beside the depth maps",
            args.mesh_res,
            crate::geom::meshing::tsdf::unbounded::samples_per_axis(args.mesh_res)
        ),
        crate::geom::meshing::tsdf::unbounded::grid_bytes(args.mesh_res).saturating_add(image_bytes),
    )
    .map_err(|e| usage(e.to_string()))?;
    let p = TsdfParams::new(1.0, 1.0, 1.0);
    let b = p.block_bounds(&[]);
    Ok((p, "unbounded".to_string(), b))
}

/// The scene to render depth from, if one was given, and the Gaussian
/// rasteriser's 2-D filter; an error when it holds no primitive (every
/// depth map would be empty, so nothing can be fused).
fn load_fusion_scene(args: &TsdfFuseArgs) -> anyhow::Result<(Option<FusionScene>, Filter2d)> {
    let (scene, filter_2d) = match &args.scene {
        Some(p) => {
            let (sc, f) = load_scene(p, &args.filter)?;
            (Some(sc), f)
        }
        None => (None, Filter2d::default()),
    };
    if let (Some(p), Some(sc)) = (&args.scene, &scene) {
        let n = match sc {
            FusionScene::Gaussians(g) => g.len(),
            FusionScene::Surfels(s) => s.len(),
            FusionScene::Triangles(t) => t.len(),
            FusionScene::Mesh(m) => m.faces.len(),
        };
        if n == 0 {
            bail!("{}: holds no primitives: nothing to fuse", shown(p, false));
        }
    }
    Ok((scene, filter_2d))
}

/// Everything [`fuse`] and [`report`] take besides the flags: the
/// cameras and their files, the scene, the bounded fusion's settings
/// ([`plan`]), whether colours are fused, and the depth ratio.
struct FuseSetup<'a> {
    cams: &'a [Camera],
    files: &'a [ViewFiles],
    scene: Option<&'a FusionScene>,
    params: TsdfParams,
    how: String,
    bounds: BlockBounds,
    with_color: bool,
    depth_ratio: f32,
    /// The Gaussian rasteriser's 2-D filter ([`load_scene`]).
    filter_2d: Filter2d,
}

/// What [`fuse`] made: the mesh (scene units, before the cluster filter),
/// the per-view and volume entries of the report, the count of depth
/// values that were not usable, and the seconds of integration and
/// extraction.
struct Fused {
    mesh: Mesh,
    views: Vec<serde_json::Value>,
    volume: serde_json::Value,
    bad_depth: usize,
    fuse_time: f64,
}

/// Fuses every camera's view, rendered or read by [`load_view`], with
/// [`fuse_views_unbounded`] (`--unbounded`) or [`fuse_views`], under a
/// progress bar.
fn fuse(args: &TsdfFuseArgs, s: &FuseSetup) -> anyhow::Result<Fused> {
    let pb = args.common.progress(s.cams.len() as u64, "tsdf-fuse");
    let progress = |p: FuseProgress| match p {
        FuseProgress::Views(n) => pb.inc(n as u64),
        FuseProgress::ViewsDone => pb.finish_and_clear(),
    };
    let mut bad_depth = 0usize;
    let load = |i: usize| -> anyhow::Result<ViewMaps> {
        let (depth, rgb, bad) = load_view(
            args,
            s.scene,
            &s.cams[i],
            &s.files[i],
            s.depth_ratio,
            s.filter_2d,
        )?;
        bad_depth += bad;
        Ok(ViewMaps { depth, rgb })
    };
    let mut fused = if args.unbounded {
        fuse_unbounded(args, s, load, &progress)?
    } else {
        fuse_bounded(s, load, &progress)?
    };
    fused.bad_depth = bad_depth;
    Ok(fused)
}

/// [`fuse_views_unbounded`] on the views `load` gives, with the report's
/// entries (`bad_depth` left 0; `fuse_time` 0, as the unbounded fusion is
/// not timed).
fn fuse_unbounded(
    args: &TsdfFuseArgs,
    s: &FuseSetup,
    load: impl FnMut(usize) -> anyhow::Result<ViewMaps>,
    progress: &dyn Fn(FuseProgress),
) -> anyhow::Result<Fused> {
    let input = UnboundedInput {
        cameras: s.cams,
        with_color: s.with_color,
        resolution: args.mesh_res,
        bound: args.bound,
        scene: s.scene,
    };
    let out = fuse_views_unbounded(&input, load, progress).map_err(|e| fuse_error(e, &s.params))?;
    let views = s
        .cams
        .iter()
        .zip(&out.valid_pixels)
        .map(|(cam, n)| json!({ "camera": cam.name, "valid_pixels": n }))
        .collect();
    let volume = json!({
        "unbounded": true,
        "center": out.center.to_array(),
        "radius": out.radius,
        "bound": out.bound,
        "resolution": args.mesh_res,
        "samples_per_axis": crate::geom::meshing::tsdf::unbounded::samples_per_axis(args.mesh_res),
    });
    Ok(Fused {
        mesh: out.mesh,
        views,
        volume,
        bad_depth: 0,
        fuse_time: 0.0,
    })
}

/// [`fuse_views`] on the views `load` gives, with the report's entries
/// (`bad_depth` left 0).
fn fuse_bounded(
    s: &FuseSetup,
    load: impl FnMut(usize) -> anyhow::Result<ViewMaps>,
    progress: &dyn Fn(FuseProgress),
) -> anyhow::Result<Fused> {
    let input = BoundedInput {
        cameras: s.cams,
        params: s.params,
        with_color: s.with_color,
    };
    let out = fuse_views(&input, load, progress).map_err(|e| fuse_error(e, &s.params))?;
    let views = s
        .cams
        .iter()
        .zip(&out.views)
        .map(|(cam, st)| {
            json!({
                "camera": cam.name,
                "valid_pixels": st.valid_pixels,
                "blocks_touched": st.touched,
            })
        })
        .collect();
    let volume = json!({
        "voxel": s.params.voxel,
        "sdf_trunc": s.params.sdf_trunc,
        "depth_trunc": s.params.depth_trunc,
        "params_from": s.how,
        "blocks": out.blocks,
        "blocks_bound": s.bounds.upper,
        "volume_bytes": out.volume_bytes,
    });
    Ok(Fused {
        mesh: out.mesh,
        views,
        volume,
        bad_depth: 0,
        fuse_time: out.fuse_seconds,
    })
}

/// A fusion pipeline's error as the command reports it: a batch that
/// failed to integrate names its cameras, the flags and the memory budget.
fn fuse_error(e: FuseError<anyhow::Error>, params: &TsdfParams) -> anyhow::Error {
    match e {
        FuseError::View(e) => e,
        FuseError::Fusion(e) => e.into(),
        FuseError::Batch { cameras, source } => Err::<(), _>(source)
            .with_context(|| {
                format!(
                    "fusing cameras {cameras:?} (--voxel {}, --sdf-trunc {}, --depth-trunc {}: at \
                     most {} blocks fit this process's memory budget of {})",
                    params.voxel,
                    params.sdf_trunc,
                    params.depth_trunc,
                    params.max_blocks,
                    crate::io::budget::human_bytes(crate::io::budget::usable_bytes())
                )
            })
            .unwrap_err(),
    }
}

/// The error of a fused mesh with no face left: removed by the cluster
/// filter (`raw_faces` > 0), or never made (the hint names the flags that
/// set the grid).
fn empty_mesh_error(
    args: &TsdfFuseArgs,
    params: &TsdfParams,
    views: usize,
    raw_faces: usize,
) -> anyhow::Error {
    if raw_faces > 0 {
        // the fusion made a surface; the cluster filter removed it all
        return anyhow::anyhow!(
            "the fused mesh is empty after the cluster filter: all {} faces are in \
             clusters of fewer than --min-cluster-faces {} faces; nothing written",
            raw_faces,
            args.min_cluster_faces
        );
    }
    if args.unbounded {
        return anyhow::anyhow!(
            "the fused mesh is empty: the contracted grid has no zero crossing in {} views; \
             check the depth units (--depth-scale) and --bound",
            views
        );
    }
    anyhow::anyhow!(
        "the fused mesh is empty: no surface was seen from both sides within --sdf-trunc \
         ({:.6}) in {} views; check --depth-trunc ({:.6}), the depth units (--depth-scale) \
         and the voxel size ({:.6})",
        params.sdf_trunc,
        views,
        params.depth_trunc,
        params.voxel
    )
}

/// The human summary (stderr) and the JSON report of a written mesh:
/// `raw` is the fused mesh's (vertices, faces) before the cluster filter,
/// `secs` the run's seconds so far.
fn report(
    args: &TsdfFuseArgs,
    s: &FuseSetup,
    fused: &Fused,
    raw: (usize, usize),
    clusters: Option<ClusterReport>,
    secs: f64,
) -> anyhow::Result<()> {
    let (params, how, volume, mesh) = (&s.params, &s.how, &fused.volume, &fused.mesh);
    let setting = if args.unbounded {
        format!(
            "unbounded, resolution {}, bound {:.3}",
            args.mesh_res, volume["bound"]
        )
    } else {
        format!(
            "voxel {:.6}, sdf_trunc {:.6}, depth_trunc {:.6} ({how}); {} blocks ({:.1} MiB)",
            params.voxel,
            params.sdf_trunc,
            params.depth_trunc,
            volume["blocks"],
            volume["volume_bytes"].as_f64().unwrap_or(0.0) / (1u64 << 20) as f64,
        )
    };
    args.common.say(format!(
        "tsdf-fuse: {} views, {setting} -> {} vertices, {} faces{} ({secs:.1} s)",
        s.cams.len(),
        mesh.vertices.len(),
        mesh.faces.len(),
        clusters
            .map(|c| format!(", {} of {} clusters kept", c.kept, c.clusters))
            .unwrap_or_default(),
    ));
    let mut report = json!({
        "scene": args.scene.as_ref().map(|p| shown(p, false)),
        "depth": args.depth.as_ref().map(|p| p.display().to_string()),
        "cameras": args.cameras.display().to_string(),
        "views": fused.views,
        "depth_ratio": s.depth_ratio,
        "filter_2d": matches!(s.scene, Some(FusionScene::Gaussians(_)))
            .then(|| model::filter3d::filter_2d_label(s.filter_2d)),
        "invalid_depth_pixels": fused.bad_depth,
        "raw_vertices": raw.0,
        "raw_faces": raw.1,
        "vertices": mesh.vertices.len(),
        "faces": mesh.faces.len(),
        "output": args.output.display().to_string(),
        "seconds": secs,
        "fuse_seconds": fused.fuse_time,
    });
    if let (Some(r), Some(v)) = (report.as_object_mut(), volume.as_object()) {
        for (key, val) in v {
            r.insert(key.clone(), val.clone());
        }
    }
    if let Some(c) = clusters {
        report["clusters"] = json!({
            "total": c.clusters,
            "kept": c.kept,
            "threshold_faces": c.threshold,
            "faces_removed": c.faces_removed,
        });
    }
    args.common.emit_json(&report)?;
    Ok(())
}

/// One camera's maps: depth, colour (when there is one), and the count of
/// depth values that were not usable.
type LoadedView = (Vec<f32>, Option<Vec<[u8; 3]>>, usize);

/// One camera's depth (masked; NaN, infinite and negative values set to
/// 0) and colour, rendered from `scene` or read from `f`; the count of
/// values that were not usable depths.
fn load_view(
    args: &TsdfFuseArgs,
    scene: Option<&FusionScene>,
    cam: &Camera,
    f: &ViewFiles,
    depth_ratio: f32,
    filter_2d: Filter2d,
) -> anyhow::Result<LoadedView> {
    let mask = match &f.mask {
        Some(p) => {
            let (mw, mh, m) = read_mask_values(p)?;
            Some(fit_mask(p, cam, mw, mh, m)?)
        }
        None => None,
    };
    let (mut depth, rgb) = match (scene, &f.depth) {
        (Some(s), _) => {
            let v = render_view(s, cam, depth_ratio, args.near, filter_2d, mask.as_deref());
            (v.depth, v.rgb)
        }
        (None, Some(p)) => {
            let d = read_depth(p, args.depth_scale)?;
            check_size(p, "depth map", cam, d.width, d.height)?;
            let rgb = match &f.color {
                Some(cp) => {
                    let (cw, ch, c) = read_rgb8(cp)?;
                    check_size(cp, "colour image", cam, cw, ch)?;
                    Some(c)
                }
                None => None,
            };
            let mut depth = d.depth;
            if let Some(m) = &mask {
                for (z, &a) in depth.iter_mut().zip(m) {
                    if a < 0.5 {
                        *z = 0.0;
                    }
                }
            }
            (depth, rgb)
        }
        (None, None) => unreachable!("a scene or --depth is required"),
    };
    // NaN, infinite and negative depths are missing (documented)
    let mut bad = 0;
    for z in depth.iter_mut() {
        if !(z.is_finite() && *z >= 0.0) {
            *z = 0.0;
            bad += 1;
        }
    }
    Ok((depth, rgb, bad))
}

/// A mask at the camera's size: as it is, or box-averaged when it is an
/// integer multiple k of it (k × k pixels per render pixel; 2DGS resizes
/// with PIL's bicubic filter, which agrees except on the mask's edges).
fn fit_mask(
    path: &Path,
    cam: &Camera,
    w: usize,
    h: usize,
    m: Vec<f32>,
) -> anyhow::Result<Vec<f32>> {
    let (cw, ch) = (cam.width as usize, cam.height as usize);
    if (w, h) == (cw, ch) {
        return Ok(m);
    }
    let k = w / cw.max(1);
    if k < 2 || w != k * cw || h != k * ch {
        check_size(path, "mask", cam, w, h)?;
    }
    let norm = 1.0 / (k * k) as f32;
    Ok((0..cw * ch)
        .map(|i| {
            let (x, y) = (i % cw, i / cw);
            let mut s = 0.0f32;
            for dy in 0..k {
                let row = (y * k + dy) * w + x * k;
                s += m[row..row + k].iter().sum::<f32>();
            }
            s * norm
        })
        .collect())
}

fn check_size(path: &Path, what: &str, cam: &Camera, w: usize, h: usize) -> anyhow::Result<()> {
    if (w, h) != (cam.width as usize, cam.height as usize) {
        bail!(
            "{}: {what} is {w}x{h} pixels, but camera {:?} is {}x{}",
            path.display(),
            cam.name,
            cam.width,
            cam.height
        );
    }
    Ok(())
}

/// The scene, through the common loader, ready to render for fusion, and
/// the 2-D filter for Gaussians: a `filter_3D` property (Mip-Splatting,
/// GOF) is baked into the scales and opacities here
/// ([`model::filter3d::baked_for_rendering`]) and picks the Mip filter
/// under `--filter-2d auto`.
fn load_scene(path: &Path, filter: &Filter2dArgs) -> anyhow::Result<(FusionScene, Filter2d)> {
    let accepts = [
        SceneKind::Gaussians,
        SceneKind::Surfels,
        SceneKind::TriangleSoup,
        SceneKind::Mesh,
    ];
    // fusion makes geometry: a NaN or infinite value would silently drop
    // the primitives it touches from the mesh, so it is refused (unlike
    // `render`, which draws what is finite)
    let name = shown(path, false);
    let mut filtered = false;
    let scene = match load_kinds(path, "tsdf-fuse", &accepts)? {
        model::Scene::Gaussians(g) => {
            crate::io::ply::gaussians::check_finite(&name, &g)?;
            let (g, f) = model::filter3d::baked_for_rendering(g).map_err(|e| e.in_file(&name))?;
            filtered = f;
            FusionScene::gaussians(&g.to_raster())
        }
        model::Scene::Surfels(s) => {
            crate::io::ply::surfels::check_finite(&name, &s)?;
            // DC colour only, as 2DGS's meshing pass (active_sh_degree = 0)
            FusionScene::Surfels(s.to_raster_at(0))
        }
        model::Scene::TriangleSoup(t) => {
            crate::io::any::check_finite_soup(&name, &t)?;
            FusionScene::triangles(&t.to_raster())
        }
        model::Scene::Mesh(m) => {
            crate::io::any::check_finite_mesh(&name, &m)?;
            FusionScene::Mesh(m)
        }
        model::Scene::PointCloud(_) => unreachable!("load_kinds returns an accepted kind"),
    };
    let f = model::filter3d::choose_filter_2d(filter.choice(), filter.kernel_size, filtered);
    Ok((scene, f))
}
