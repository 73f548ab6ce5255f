//! `decimate`: quadric-error decimation of a mesh to a stated face or vertex
//! count ([`crate::geom::mesh_ops::decimate`]), in pipes.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde_json::json;

use crate::cli::{Common, shown};
use crate::geom::mesh_ops::decimate::{Target, decimate};
use crate::io::any::{MeshWriteOptions, load_mesh, output_format, save_mesh};
use crate::io::detect::FileFormat;

/// Arguments of `decimate`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  # SuGaR's coarse-mesh target
  decimate mesh.ply --faces 200000 -o small.ply
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
    /// Target fraction of the faces, in (0, 1].
    #[arg(long, value_parser = crate::cli::unit_f64)]
    pub ratio: Option<f64>,
    #[command(flatten)]
    pub common: Common,
}

/// `decimate` entry point.
pub fn run(args: DecimateArgs) -> anyhow::Result<()> {
    args.common.init()?;
    let format = output_format(&args.output, None, FileFormat::Ply)?;
    args.common.check_output(
        &args.output,
        matches!(format, FileFormat::Ply | FileFormat::Glb),
    )?;
    let target = match (args.faces, args.vertices, args.ratio) {
        (Some(f), _, _) => Target::Faces(f),
        (_, Some(v), _) => Target::Vertices(v),
        (_, _, Some(r)) => Target::Ratio(r),
        _ => anyhow::bail!("give --faces, --vertices or --ratio"),
    };
    // A target of nothing (no face; fewer than 3 vertices hold none) has no
    // decimated mesh to give (the simplifier would stop at whatever it cannot
    // collapse): refused before reading.
    let zero = match target {
        Target::Faces(0) => Some("--faces 0".to_string()),
        Target::Vertices(v) if v < 3 => Some(format!("--vertices {v}")),
        Target::Ratio(0.0) => Some("--ratio 0".to_string()),
        _ => None,
    };
    if let Some(flag) = zero {
        anyhow::bail!(
            "{flag} asks for an empty mesh, which decimation cannot make: nothing written \
             (give a target of at least one face, or three vertices)"
        );
    }
    let mesh = load_mesh(&args.input, "decimate")?;
    // The engine's working set beside the mesh: quadrics, f64 positions,
    // face lists, the ranked edges (4.37M faces peaked at 1.19 GB with the
    // mesh itself, ~270 bytes a face).
    crate::io::budget::check(
        &format!(
            "decimating {} ({} faces)",
            shown(&args.input, false),
            mesh.faces.len()
        ),
        (mesh.faces.len() as u64).saturating_mul(300),
    )?;
    let (out, report) = decimate(&mesh, target)
        .with_context(|| format!("decimating {}", shown(&args.input, false)))?;
    if out.faces.is_empty() {
        anyhow::bail!(
            "decimating {} to {} left no face: nothing written (ask for more faces or \
             vertices)",
            shown(&args.input, false),
            match target {
                Target::Faces(f) => format!("--faces {f}"),
                Target::Vertices(v) => format!("--vertices {v}"),
                Target::Ratio(r) => format!("--ratio {r}"),
            }
        );
    }
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
