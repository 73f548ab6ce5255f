//! `poisson`: oriented points → watertight mesh by screened Poisson
//! reconstruction ([`crate::geom::meshing::poisson`]), with SuGaR's pre- and
//! post-processing around it.
//!
//! The pipeline (outliers, split, per-part reconstruction, trimming) is
//! [`crate::geom::meshing::poisson::pipeline`]; this module resolves files and flags.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde_json::json;

use crate::cli::{Common, fraction_f64, nonneg_f64, positive_f64, shown};
use crate::geom::meshing::poisson::pipeline::{
    PipelineOptions, PipelineOutput, run_pipeline_with_progress,
};
use crate::geom::meshing::poisson::{PoissonParams, STAGES};
use crate::geom::meshing::scene_split::{Aabb, SceneSplit};
use crate::io::any::{MeshWriteOptions, load_points, save_mesh};
use crate::io::detect::FileFormat;

/// Arguments of `poisson`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  # depth 8, Open3D / PoissonRecon defaults
  poisson points.ply -o mesh.ply
  # SuGaR's settings
  poisson points.ply --depth 10 --trim-quantile 0.1 -o mesh.ply
  splat2points scene.ply --cameras cameras.json \\
      | poisson - --depth 10 -o - | clean - -o mesh.ply
  poisson scan.ply --flip-normals --depth 9 --json=stats.json -o mesh.ply")]
pub struct PoissonArgs {
    /// Oriented point cloud PLY (x y z nx ny nz, optional red green blue); `-` = stdin.
    #[arg(default_value = "-")]
    pub input: PathBuf,
    /// Output mesh PLY (binary, per-vertex normals, colours, `density`); `-` = stdout.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// Finest octree depth, 2 to 16 (a cell is cube side / 2^depth) [default: 8; 10 with --sugar].
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=16))]
    pub depth: Option<u32>,
    /// Depth up to which the octree is complete, 0 to 16 (capped at the depth).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(0..=16))]
    pub full_depth: u32,
    /// Samples per node of the density estimate (larger = smoother in sparse areas).
    #[arg(long, default_value_t = 1.5, value_parser = positive_f64)]
    pub samples_per_node: f64,
    /// Screening weight (0 = unscreened Poisson; pymeshlab uses 4).
    #[arg(long, default_value_t = 2.0, value_parser = nonneg_f64)]
    pub point_weight: f64,
    /// Cube side over the largest bounding-box extent of the points.
    #[arg(long, default_value_t = 1.1, value_parser = positive_f64)]
    pub scale: f64,
    /// Gauss–Seidel sweeps per level.
    #[arg(long, default_value_t = 8, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=1000))]
    pub iters: usize,
    /// Place iso-vertices by linear instead of quadratic interpolation.
    #[arg(long)]
    pub linear_fit: bool,
    /// Extract on the uniform grid of the finest depth instead of the adaptive
    /// octree (PoissonRecon's way): finer triangles where the solve is coarse.
    #[arg(long)]
    pub uniform_extraction: bool,
    /// Finest cell width in world units (sets the depth; overrides --depth).
    #[arg(long, value_name = "W", value_parser = positive_f64)]
    pub width: Option<f64>,
    /// Negate every input normal (for scans whose normals point inward).
    #[arg(long)]
    pub flip_normals: bool,
    /// SuGaR's coarse-mesh settings: depth 10, --trim-quantile 0.1,
    /// --outlier-k 20 --outlier-std 20 (each overridable).
    #[arg(long)]
    pub sugar: bool,
    /// Remove vertices whose density is below this quantile of all densities,
    /// with their faces. Off by default; --sugar sets 0.1 (SuGaR's).
    #[arg(long, value_name = "Q", value_parser = fraction_f64)]
    pub trim_quantile: Option<f64>,
    /// Keep only the surface where density ≥ DENSITY, clipping faces along the
    /// iso-line (PoissonRecon's SurfaceTrimmer --trim; typical 5–7). Off by
    /// default.
    #[arg(long, value_name = "DENSITY", value_parser = nonneg_f64)]
    pub trim: Option<f64>,
    /// Split foreground / background by these cameras (any camera format or a
    /// 3DGS model folder) and reconstruct each part separately.
    #[arg(long, value_name = "CAMS")]
    pub split_by_cameras: Option<PathBuf>,
    /// Foreground cube half-side over the largest camera distance from the camera centroid.
    #[arg(long, default_value_t = 1.1, value_parser = positive_f64)]
    pub fg_factor: f64,
    /// Background extent (L∞, around the camera centroid) over the foreground half-side; farther points are dropped.
    #[arg(long, default_value_t = 4.0, value_parser = positive_f64)]
    pub bg_factor: f64,
    /// Foreground box in absolute coordinates (replaces the camera cube).
    #[arg(
        long,
        value_name = "MINX,MINY,MINZ,MAXX,MAXY,MAXZ",
        allow_hyphen_values = true,
        value_parser = parse_bbox
    )]
    pub bbox: Option<String>,
    /// Reconstruct the foreground only (needs --split-by-cameras or --bbox).
    #[arg(long)]
    pub foreground_only: bool,
    /// Choose the depth per part from point spacing (Frosting's rule, at most 10).
    #[arg(long, conflicts_with = "width")]
    pub auto_depth: bool,
    /// Statistical outlier removal before reconstruction: neighbours K. Off
    /// by default (and with 0); --sugar sets 20.
    #[arg(long, value_name = "K")]
    pub outlier_k: Option<usize>,
    /// Statistical outlier removal: standard-deviation ratio R, used only
    /// when the removal is on (--outlier-k or --sugar) [default: 20].
    #[arg(long, value_name = "R", value_parser = positive_f64)]
    pub outlier_std: Option<f64>,
    /// Write the mesh even when no face is left (trimming removed them all,
    /// or every part was skipped), instead of failing with exit 1.
    #[arg(long)]
    pub allow_empty: bool,
    #[command(flatten)]
    pub common: Common,
}

/// `--bbox`, checked at parse time (exit 2): six finite numbers, each min
/// below its max; the text is kept and parsed again where it is used.
fn parse_bbox(s: &str) -> Result<String, String> {
    Aabb::parse(s)
        .map(|_| s.to_string())
        .map_err(|e| e.to_string())
}

/// Bytes per octree node of the complete levels, an estimate: the cell
/// key and its hash slots, one row of the 27-neighbour system (values and
/// column indices) and the multigrid vectors (solution, right-hand side,
/// residual, weights) come to about 400–500 bytes.
const BYTES_PER_FULL_NODE: u64 = 512;

/// Nodes of an octree complete to level `full`: Σ 8^l for l ≤ full.
fn full_nodes(full: u32) -> u64 {
    (0..=full).fold(0u64, |a, l| a.saturating_add(8u64.saturating_pow(l)))
}

/// `poisson` entry point: checks the octree's memory, builds the
/// pipeline's options ([`pipeline_options`]), reads the points, runs
/// [`run_pipeline_with_progress`], writes the mesh (always PLY) and
/// reports.
pub fn run(args: PoissonArgs) -> anyhow::Result<()> {
    args.common.init()?;
    args.common.check_output(&args.output, true)?;
    check_octree_budget(&args)?;
    if args.foreground_only && args.split_by_cameras.is_none() && args.bbox.is_none() {
        anyhow::bail!("--foreground-only needs --split-by-cameras or --bbox");
    }
    let opt = pipeline_options(&args)?;
    let cloud = load_points(&args.input, "poisson")?;
    let parts = if opt.split.is_some() && !opt.foreground_only {
        2
    } else {
        1
    };
    let pb = args
        .common
        .progress((parts * STAGES.len()) as u64, "poisson");
    let out = run_pipeline_with_progress(cloud, &opt, &|part, stage| {
        pb.set_message(format!("{part}: {stage}"));
        pb.inc(1);
    })
    .with_context(|| match args.width {
        // the depth the error may name is the one --width implies
        Some(w) => format!(
            "reconstructing {} with --width {w:?}",
            shown(&args.input, false)
        ),
        None => format!("reconstructing {}", shown(&args.input, false)),
    })?;
    pb.finish_and_clear();
    if out.mesh.faces.is_empty() && !args.allow_empty {
        return Err(empty_mesh_error(&args, &opt, &out));
    }
    // Always PLY: the per-vertex density travels only there.
    save_mesh(
        &args.output,
        &out.mesh,
        FileFormat::Ply,
        &MeshWriteOptions::default(),
    )?;
    report(&args, &out)
}

/// The complete levels of the octree are allocated whatever the points:
/// checked against the memory budget before anything is read (a usage
/// error; the adaptive part grows with the input). With `--width` the
/// depth is known only from the points: not capped.
fn check_octree_budget(args: &PoissonArgs) -> anyhow::Result<()> {
    let depth = match args.width {
        Some(_) => 16,
        None => args.depth.unwrap_or(if args.sugar { 10 } else { 8 }),
    };
    let full = args.full_depth.min(depth);
    crate::io::budget::check(
        &format!(
            "--full-depth {}: the {} nodes of an octree complete to depth {full}",
            args.full_depth,
            full_nodes(full)
        ),
        full_nodes(full).saturating_mul(BYTES_PER_FULL_NODE),
    )
    .map_err(|e| crate::cli::usage(e.to_string()))?;
    Ok(())
}

/// The pipeline's options from the flags and SuGaR's preset (`--sugar`:
/// depth 10, outliers k = 20, trim quantile 0.1); the foreground /
/// background split from `--split-by-cameras` (the cameras are read here)
/// and `--bbox`.
fn pipeline_options(args: &PoissonArgs) -> anyhow::Result<PipelineOptions> {
    let mut split = match &args.split_by_cameras {
        Some(path) => {
            let cams = crate::io::cameras::read_cameras(path)?;
            let centers: Vec<[f64; 3]> = cams.iter().map(|c| c.center().to_array()).collect();
            Some(
                SceneSplit::from_cameras(&centers, args.fg_factor, args.bg_factor)
                    .with_context(|| format!("cameras {}", path.display()))?,
            )
        }
        None => None,
    };
    if let Some(b) = &args.bbox {
        let bbox = Aabb::parse(b)?;
        match &mut split {
            Some(s) => s.foreground = bbox,
            None => {
                split = Some(SceneSplit {
                    foreground: bbox,
                    background: None,
                })
            }
        }
    }
    let outlier_k = args.outlier_k.or(args.sugar.then_some(20));
    let outlier_std = args.outlier_std.unwrap_or(20.0);
    Ok(PipelineOptions {
        params: PoissonParams {
            depth: args.depth.unwrap_or(if args.sugar { 10 } else { 8 }),
            full_depth: args.full_depth,
            samples_per_node: args.samples_per_node,
            point_weight: args.point_weight,
            scale: args.scale,
            iters: args.iters,
            linear_fit: args.linear_fit,
            width: args.width,
            uniform_extraction: args.uniform_extraction,
        },
        flip_normals: args.flip_normals,
        outliers: outlier_k.map(|k| (k, outlier_std)),
        split,
        foreground_only: args.foreground_only,
        auto_depth: args.auto_depth,
        trim_quantile: args.trim_quantile.or(args.sugar.then_some(0.1)),
        trim_threshold: args.trim,
    })
}

/// The error of a reconstruction with no face left, with its cause.
fn empty_mesh_error(
    args: &PoissonArgs,
    opt: &PipelineOptions,
    out: &PipelineOutput,
) -> anyhow::Error {
    let cause = match (opt.trim_threshold, opt.trim_quantile) {
        (Some(t), _) => format!("--trim {t:?} removed every face"),
        (None, Some(q)) => format!("--trim-quantile {q:?} removed every face"),
        _ if !out.skipped.is_empty() => "every part was skipped".to_string(),
        _ => "the reconstruction made no surface: check --scale and the normals".to_string(),
    };
    anyhow::anyhow!(
        "{}: no face is left ({cause}); nothing written (--allow-empty writes the empty mesh)",
        shown(&args.input, false)
    )
}

/// The human summary (stderr: one line per part, the skipped parts, the
/// points dropped beyond the background) and the JSON report.
fn report(args: &PoissonArgs, out: &PipelineOutput) -> anyhow::Result<()> {
    for r in &out.parts {
        let s = &r.poisson;
        args.common.say(format!(
            "poisson[{}]: {} points ({} outliers, {} bad) -> {} samples, depth {}, cell {:.4e}, iso {:.4} -> {} vertices, {} faces{} ({})",
            r.part,
            r.points,
            r.outliers_removed,
            s.dropped_points,
            s.samples,
            s.depth,
            s.cell_size,
            s.iso_value,
            r.vertices,
            r.faces,
            r.trim_threshold
                .map(|t| format!(" after trimming at density {t:.3}"))
                .unwrap_or_default(),
            s.seconds
                .iter()
                .map(|(k, v)| format!("{k} {v:.2}s"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    for (name, n) in &out.skipped {
        args.common.say(format!(
            "warning: {name} skipped: {n} points (fewer than 4)"
        ));
    }
    if out.dropped_far > 0 {
        args.common.say(format!(
            "{} points beyond the background limit were dropped",
            out.dropped_far
        ));
    }
    args.common.emit_json(&json!({
        "output": shown(&args.output, true),
        "vertices": out.mesh.vertices.len(),
        "faces": out.mesh.faces.len(),
        "dropped_far": out.dropped_far,
        "skipped": out.skipped,
        "parts": out.parts,
    }))?;
    Ok(())
}
