//! `decimate`: quadric-error decimation of a mesh to a stated face or vertex
//! count ([`crate::geom::decimate`]), in pipes.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde_json::json;

use crate::cli::{Common, shown};
use crate::geom::decimate::{Target, decimate};
use crate::io::any::{MeshWriteOptions, load_mesh, output_format, save_mesh};
use crate::io::detect::FileFormat;

/// Arguments of `decimate`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  decimate mesh.ply --faces 200000 -o small.ply       # SuGaR's coarse-mesh target
  poisson pts.ply --depth 10 -o - | decimate - --faces 1000000 -o mesh.ply
  decimate mesh.obj --vertices 50000 -o mesh_50k.obj --json=report.json")]
pub struct DecimateArgs {
    /// Input mesh (PLY, OBJ, OFF, glTF/GLB); `-` = stdin.
    #[arg(default_value = "-")]
    pub input: PathBuf,
    /// Output mesh (format from the extension; PLY on stdout); `-` = stdout.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// Target number of faces (Open3D's target_number_of_triangles).
    #[arg(long, conflicts_with_all = ["vertices", "ratio"], required_unless_present_any = ["vertices", "ratio"])]
    pub faces: Option<usize>,
    /// Target number of vertices.
    #[arg(long, conflicts_with = "ratio")]
    pub vertices: Option<usize>,
    /// Target fraction of the faces, in [0, 1].
    #[arg(long)]
    pub ratio: Option<f64>,
    #[command(flatten)]
    pub common: Common,
}

/// `decimate` entry point.
pub fn run(args: DecimateArgs) -> anyhow::Result<()> {
    args.common.init()?;
    crate::cli::check_output_file(&args.output, "-o")?;
    args.common.check_stdout_free(&args.output)?;
    let format = output_format(&args.output, None, FileFormat::Ply)?;
    if matches!(format, FileFormat::Ply | FileFormat::Glb) {
        crate::cli::check_binary_stdout(&args.output)?;
    }
    let target = match (args.faces, args.vertices, args.ratio) {
        (Some(f), _, _) => Target::Faces(f),
        (_, Some(v), _) => Target::Vertices(v),
        (_, _, Some(r)) => Target::Ratio(r),
        _ => anyhow::bail!("give --faces, --vertices or --ratio"),
    };
    let mesh = load_mesh(&args.input, "decimate")?;
    let (out, report) = decimate(&mesh, target)
        .with_context(|| format!("decimating {}", shown(&args.input, false)))?;
    save_mesh(&args.output, &out, format, &MeshWriteOptions::default())?;
    args.common.say(format!(
        "decimate: {} faces / {} vertices -> {} faces / {} vertices (relative error {:.2e})",
        report.faces_before,
        report.vertices_before,
        report.faces_after,
        report.vertices_after,
        report.relative_error
    ));
    args.common.emit_json(&json!({
        "input": shown(&args.input, false),
        "output": shown(&args.output, true),
        "report": report,
    }))?;
    Ok(())
}
