//! `tetra-mesh`: Gaussian Opacity Fields' marching-tetrahedra extraction
//! ([`crate::geom::meshing::tetra`]) of a 3DGS scene (plain or with
//! Mip-Splatting / GOF's `filter_3D`) seen from its cameras. This module only
//! resolves files, flags, budget checks and progress.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Args;
use serde_json::json;

use crate::cli::model_folder::{resolve_model_folder, training_views};
use crate::cli::{Common, nonneg_f64, shown, usage};
use crate::geom::delaunay::estimated_bytes;
use crate::geom::meshing::tetra::extract::{Stage, TetraOptions, TetraReport, extract};
use crate::io::any::{MeshWriteOptions, load_kinds, output_format, save_mesh};
use crate::io::budget;
use crate::io::cameras::read_cameras;
use crate::io::detect::FileFormat;
use crate::model::{Camera, Scene, SceneKind};
use splatkit_render::gaussian::Gaussians3;
use splatkit_render::gaussian_integrate::IntegrateSettings;

/// Arguments of `tetra-mesh`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  # GOF model folder: latest iteration, cameras.json
  tetra-mesh output/garden/ -o mesh.ply
  # GOF's extract_mesh.py defaults
  tetra-mesh point_cloud.ply --cameras cameras.json -o mesh.ply
  # GOF's --filter_mesh
  tetra-mesh scene.ply --cameras sparse/0 --filter-mesh -o mesh.ply
  tetra-mesh scene.ply --cameras cams.json --cameras-subset 20 \\
      --iterations 6 -o quick.ply
  tetra-mesh scene.ply --cameras cams.json -o mesh.ply \\
      && chamfer mesh.ply gt.ply --json

GOF's rules (docs/gof_extraction.md): points = the 8 corners of each
Gaussian's ±3σ box and its centre, kept where a camera sees them; their
Delaunay tetrahedralisation; per point the opacity accumulated along each
camera's ray up to it, minimum over the views, alpha = 1 − that; marching
tetrahedra on alpha = --level; --iterations halvings of each cut edge.
Gaussians carrying `filter_3D` are used with the filter applied, as GOF does.")]
pub struct TetraMeshArgs {
    /// A 3DGS / GOF / Mip-Splatting Gaussian PLY, or a model folder (uses
    /// `point_cloud/iteration_*/point_cloud.ply` and `cameras.json`).
    pub scene: PathBuf,
    /// Camera file or folder (COLMAP, cameras.json, transforms.json,
    /// cameras.npz); default: a model folder's `cameras.json`.
    #[arg(long)]
    pub cameras: Option<PathBuf>,
    /// Output mesh (PLY, OBJ, OFF, glTF/GLB by extension); `-` = PLY on stdout.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// The opacity level meshed (GOF: 0.5).
    #[arg(long, default_value_t = 0.5, value_parser = open_unit_f32)]
    pub level: f32,
    /// Binary-search steps on each cut edge (GOF: 8; 0 = edge midpoints).
    #[arg(long, default_value_t = 8, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(0..=64))]
    pub iterations: usize,
    /// Use N of the cameras, evenly spaced in name order (default: all
    /// training views). Fewer views are faster; each view can only remove
    /// opacity from a point, so fewer views give a fuller (never thinner) surface.
    #[arg(long, value_name = "N", value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    pub cameras_subset: Option<usize>,
    /// GOF's `--filter_mesh`: drop the vertices of cut edges longer than the
    /// summed 3σ scales of their two points (long edges span empty space).
    #[arg(long)]
    pub filter_mesh: bool,
    /// No vertex colours (GOF's meshes have none unless `--texture_mesh`).
    #[arg(long)]
    pub no_color: bool,
    /// Near limit of the tetra points' frustum test, camera z (GOF `--near`).
    #[arg(long, default_value_t = 0.02, value_parser = nonneg_f64)]
    pub near: f64,
    /// Far limit of the tetra points' frustum test, camera z (GOF `--far`).
    #[arg(long, default_value_t = 1e6, value_parser = nonneg_f64)]
    pub far: f64,
    /// The 2-D Mip filter's kernel size in pixels² (GOF's `--kernel_size`;
    /// GOF trains with 0.1, the default 0 leaves it out).
    #[arg(long, default_value_t = 0.0, value_parser = nonneg_f64)]
    pub kernel_size: f64,
    /// White background for the colours (GOF `--white_background`).
    #[arg(long)]
    pub white_background: bool,
    /// Hold out every N-th camera (name-sorted, from the first) as GOF's
    /// training split does with `--eval`; 0 keeps all.
    #[arg(long, default_value_t = 0, value_parser = crate::cli::holdout_every)]
    pub every_nth_test: usize,
    /// Model iteration to read from a model folder (default: the latest).
    #[arg(long)]
    pub iteration: Option<u64>,
    /// Prepare each view again at every field evaluation instead of keeping
    /// all views' binned Gaussians (less memory, slower).
    #[arg(long)]
    pub low_memory: bool,
    #[command(flatten)]
    pub common: Common,
}

/// A level strictly between 0 and 1 (clap value parser).
fn open_unit_f32(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(format!("{v} is not strictly between 0 and 1"))
    }
}

/// Bytes per tetra point the extraction holds beside the
/// tetrahedralisation's own ([`estimated_bytes`]): the point (12), scale (4)
/// and value (4), the f64 copy (24), and the cut's edges and search state.
const BYTES_PER_POINT: u64 = 12 + 4 + 4 + 24 + 64;

/// Runs `tetra-mesh`.
pub fn run(args: TetraMeshArgs) -> anyhow::Result<()> {
    args.common.init()?;
    let format = output_format(&args.output, None, FileFormat::Ply)?;
    args.common.check_output(&args.output, true)?;
    if args.far <= args.near {
        return Err(usage(format!(
            "--far {} must be beyond --near {}",
            args.far, args.near
        )));
    }
    let t0 = std::time::Instant::now();
    let (scene, cam_path) = if args.scene.is_dir() {
        let (p, c) = resolve_model_folder(&args.scene, args.iteration)?;
        (p, Some(c))
    } else {
        (args.scene.clone(), None)
    };
    let cam_path = args
        .cameras
        .clone()
        .or(cam_path)
        .ok_or_else(|| usage("give --cameras, or a model folder holding cameras.json"))?;
    let g = load_gaussians(&scene)?;
    let cams = cameras(&args, &cam_path)?;
    // Memory: 9 points per Gaussian at most, and the kept views.
    let n_points = (g.len() as u64).saturating_mul(9);
    budget::check(
        &format!(
            "{}: the tetrahedralisation of up to {n_points} points",
            shown(&scene, false)
        ),
        n_points
            .saturating_mul(BYTES_PER_POINT)
            .saturating_add(estimated_bytes(n_points as usize)),
    )?;
    let opts = TetraOptions {
        level: args.level,
        steps: args.iterations,
        near: args.near,
        far: args.far,
        filter: args.filter_mesh,
        colors: !args.no_color,
        integrate: IntegrateSettings {
            background: if args.white_background {
                [1.0; 3]
            } else {
                [0.0; 3]
            },
            kernel_size: args.kernel_size as f32,
            // pixel passes kept between the search's evaluations: a
            // quarter of the budget, shared by the views
            cache_bytes: (budget::usable_bytes() / 4 / cams.len().max(1) as u64) as usize,
        },
        keep_views: !args.low_memory && views_fit(&g, &cams),
        max_bytes: budget::usable_bytes(),
    };
    let pb = args
        .common
        .progress(5 + args.iterations as u64 + opts.colors as u64, "stages");
    let (mesh, report) = extract(&g, &cams, &opts, |stage| {
        pb.set_message(match stage {
            Stage::Points => "tetra points".to_string(),
            Stage::Delaunay => "tetrahedralisation".to_string(),
            Stage::Field => "opacity field".to_string(),
            Stage::Marching => "marching tetrahedra".to_string(),
            Stage::Search(k, n) => format!("binary search {}/{n}", k + 1),
            Stage::Colors => "colours".to_string(),
        });
        pb.inc(1);
    })
    .with_context(|| format!("tetra-mesh of {}", shown(&scene, false)))?;
    pb.finish_and_clear();
    if mesh.faces.is_empty() {
        bail!(
            "{}: the opacity field never crosses --level {} at the {} tetra points ({} views): \
             nothing to mesh (are the cameras the scene's training views?)",
            shown(&scene, false),
            args.level,
            report.points,
            cams.len()
        );
    }
    save_mesh(&args.output, &mesh, format, &MeshWriteOptions::default())?;
    emit(&args, &scene, &cam_path, cams.len(), &report, t0)
}

/// The scene's Gaussians, activated, with a `filter_3D` applied (GOF's
/// `get_scaling_with_3D_filter` / `get_opacity_with_3D_filter`).
fn load_gaussians(scene: &Path) -> anyhow::Result<Gaussians3> {
    let name = shown(scene, false);
    match load_kinds(scene, "tetra-mesh", &[SceneKind::Gaussians])
        .with_context(|| format!("reading {name}"))?
    {
        Scene::Gaussians(g) => {
            let (g, _) =
                crate::model::filter3d::baked_for_rendering(g).map_err(|e| e.in_file(&name))?;
            if g.is_empty() {
                bail!("{name} holds no Gaussians");
            }
            Ok(g.to_raster())
        }
        _ => unreachable!("load_kinds returns an accepted kind"),
    }
}

/// The training views of the camera file, `--cameras-subset` of them.
fn cameras(args: &TetraMeshArgs, path: &Path) -> anyhow::Result<Vec<Camera>> {
    let all = read_cameras(path).with_context(|| format!("reading cameras {}", path.display()))?;
    let mut cams = training_views(all, args.every_nth_test);
    cams.sort_by(|a, b| a.name.cmp(&b.name));
    if let Some(n) = args.cameras_subset
        && n < cams.len()
    {
        let m = cams.len();
        cams = (0..n).map(|k| cams[k * m / n].clone()).collect();
    }
    if cams.is_empty() {
        bail!("{}: no cameras left", path.display());
    }
    for c in &cams {
        c.require_pinhole()
            .map_err(|e| anyhow::anyhow!("camera {:?}: {e}", c.name))?;
    }
    Ok(cams)
}

/// Whether every view's binned Gaussians fit a quarter of the memory
/// budget: per view about 60 bytes per Gaussian and 8 per tile entry (a
/// Gaussian covers a few tiles), estimated as 100 bytes per Gaussian.
fn views_fit(g: &Gaussians3, cams: &[Camera]) -> bool {
    let bytes = (g.len() as u64)
        .saturating_mul(100)
        .saturating_mul(cams.len() as u64);
    bytes <= budget::usable_bytes() / 4
}

fn emit(
    args: &TetraMeshArgs,
    scene: &Path,
    cam_path: &Path,
    views: usize,
    r: &TetraReport,
    t0: std::time::Instant,
) -> anyhow::Result<()> {
    args.common.say(format!(
        "tetra-mesh: {} Gaussians, {views} views -> {} points, {} tetrahedra -> {} vertices, {} faces ({:.1} s)",
        r.gaussians,
        r.points,
        r.tetrahedra,
        r.vertices,
        r.faces,
        t0.elapsed().as_secs_f64()
    ));
    args.common.emit_json(&json!({
        "scene": shown(scene, false),
        "cameras": cam_path.display().to_string(),
        "views": views,
        "level": args.level,
        "iterations": args.iterations,
        "filter_mesh": args.filter_mesh,
        "gaussians": r.gaussians,
        "points": r.points,
        "tetrahedra": r.tetrahedra,
        "cut_edges": r.cut_edges,
        "vertices": r.vertices,
        "faces": r.faces,
        "seconds": {
            "points": r.seconds_points,
            "delaunay": r.seconds_delaunay,
            "field": r.seconds_field,
            "marching": r.seconds_marching,
            "search": r.seconds_search,
            "total": t0.elapsed().as_secs_f64(),
        },
        "output": shown(&args.output, true),
    }))?;
    Ok(())
}
