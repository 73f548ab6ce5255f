//! `poisson`: oriented points → watertight mesh by screened Poisson
//! reconstruction ([`crate::geom::poisson`]), with SuGaR's pre- and
//! post-processing around it.
//!
//! Pipeline of [`run_pipeline`]: drop bad points → optional normal flip →
//! optional statistical outlier removal → optional foreground / background
//! split (cameras or box) → one reconstruction per part (depth fixed, from
//! `--width`, or `--auto-depth`) → optional density trimming per part →
//! parts concatenated.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde_json::json;

use crate::cli::{Common, shown};
use crate::geom::poisson::{PoissonOutput, PoissonParams, PoissonStats, reconstruct};
use crate::io::detect::{FileFormat, PlyKind};
use crate::io::ply::{Format, Header};
use crate::io::read_input;
use crate::model::{Mesh, PointCloud};

/// Arguments of `poisson`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  poisson points.ply -o mesh.ply                       # depth 8, Open3D / PoissonRecon defaults
  poisson points.ply --depth 10 --trim-quantile 0.1 -o mesh.ply   # SuGaR's settings
  splat2points scene.ply --cameras cameras.json | poisson - --depth 10 -o - | clean - -o mesh.ply
  poisson scan.ply --flip-normals --depth 9 --json=stats.json -o mesh.ply")]
pub struct PoissonArgs {
    /// Oriented point cloud PLY (x y z nx ny nz, optional red green blue); `-` = stdin.
    #[arg(default_value = "-")]
    pub input: PathBuf,
    /// Output mesh PLY (binary, per-vertex normals, colours, `density`); `-` = stdout.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// Finest octree depth (a cell is cube side / 2^depth).
    #[arg(long, default_value_t = 8)]
    pub depth: u32,
    /// Depth up to which the octree is complete.
    #[arg(long, default_value_t = 5)]
    pub full_depth: u32,
    /// Samples per node of the density estimate (larger = smoother in sparse areas).
    #[arg(long, default_value_t = 1.5)]
    pub samples_per_node: f64,
    /// Screening weight (0 = unscreened Poisson; pymeshlab uses 4).
    #[arg(long, default_value_t = 2.0)]
    pub point_weight: f64,
    /// Cube side over the largest bounding-box extent of the points.
    #[arg(long, default_value_t = 1.1)]
    pub scale: f64,
    /// Gauss–Seidel sweeps per level.
    #[arg(long, default_value_t = 8)]
    pub iters: usize,
    /// Place iso-vertices by linear instead of quadratic interpolation.
    #[arg(long)]
    pub linear_fit: bool,
    /// Finest cell width in world units (sets the depth; overrides --depth).
    #[arg(long, value_name = "W")]
    pub width: Option<f64>,
    /// Negate every input normal (for scans whose normals point inward).
    #[arg(long)]
    pub flip_normals: bool,
    #[command(flatten)]
    pub common: Common,
}

/// Options of the whole pipeline (everything but file names).
#[derive(Clone, Debug)]
pub struct PipelineOptions {
    pub params: PoissonParams,
    pub flip_normals: bool,
}

/// The result of the pipeline.
#[derive(Clone, Debug)]
pub struct PipelineOutput {
    pub mesh: Mesh,
    /// One entry per reconstructed part.
    pub parts: Vec<(String, PoissonStats)>,
}

/// Runs the pipeline on a point cloud.
pub fn run_pipeline(cloud: PointCloud, opt: &PipelineOptions) -> crate::Result<PipelineOutput> {
    let mut cloud = cloud;
    if opt.flip_normals {
        if let Some(n) = &mut cloud.normals {
            for v in n.iter_mut() {
                *v = [-v[0], -v[1], -v[2]];
            }
        }
    }
    let PoissonOutput { mesh, stats } = reconstruct(&cloud, &opt.params)?;
    Ok(PipelineOutput {
        mesh,
        parts: vec![("all".to_string(), stats)],
    })
}

/// Reads an oriented point cloud PLY.
pub fn load_points(path: &std::path::Path) -> crate::Result<PointCloud> {
    let input = read_input(path)?;
    let name = input.name.clone();
    if FileFormat::detect(path, &input) != Some(FileFormat::Ply) {
        return Err(crate::Error::format(
            &name,
            "poisson reads PLY point clouds",
        ));
    }
    let h = Header::parse(&name, &input)?;
    match PlyKind::of(&h) {
        PlyKind::PointCloud | PlyKind::Mesh => crate::io::ply::points::parse_points(&name, &input),
        other => Err(crate::Error::format(
            &name,
            format!("is a {} PLY, not an oriented point cloud", other.name()),
        )),
    }
}

/// `poisson` entry point.
pub fn run(args: PoissonArgs) -> anyhow::Result<()> {
    args.common.init()?;
    args.common.check_stdout_free(&args.output)?;
    crate::cli::check_binary_stdout(&args.output)?;
    let cloud = load_points(&args.input)?;
    let opt = PipelineOptions {
        params: PoissonParams {
            depth: args.depth,
            full_depth: args.full_depth,
            samples_per_node: args.samples_per_node,
            point_weight: args.point_weight,
            scale: args.scale,
            iters: args.iters,
            linear_fit: args.linear_fit,
            width: args.width,
        },
        flip_normals: args.flip_normals,
    };
    let out = run_pipeline(cloud, &opt)
        .with_context(|| format!("reconstructing {}", shown(&args.input, false)))?;
    crate::io::write_output(&args.output, |w| {
        crate::io::ply::mesh::write_mesh(w, &out.mesh, Format::BinaryLittleEndian)
    })?;
    for (name, s) in &out.parts {
        args.common.say(format!(
            "poisson[{name}]: {} points ({} dropped) -> {} samples, depth {}, cell {:.4e}, iso {:.4} -> {} vertices, {} faces ({})",
            s.input_points,
            s.dropped_points,
            s.samples,
            s.depth,
            s.cell_size,
            s.iso_value,
            s.vertices,
            s.faces,
            s.seconds
                .iter()
                .map(|(k, v)| format!("{k} {v:.2}s"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    args.common.emit_json(&json!({
        "output": shown(&args.output, true),
        "vertices": out.mesh.vertices.len(),
        "faces": out.mesh.faces.len(),
        "parts": out.parts.iter().map(|(n, s)| json!({"part": n, "stats": s})).collect::<Vec<_>>(),
    }))?;
    Ok(())
}
