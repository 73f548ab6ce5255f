//! `clean`: mesh clean-up ([`crate::geom::mesh_ops::cleanup`]) in the order SuGaR's V2
//! code runs Open3D's (duplicate vertices, degenerate faces, duplicate
//! faces, non-manifold edges), then unreferenced vertices and the optional
//! connected-component filters.

use std::path::PathBuf;

use clap::Args;
use serde_json::json;

use crate::cli::{Common, shown};
use crate::geom::mesh_ops::clean::ComponentFilter;
use crate::geom::mesh_ops::cleanup::{CleanSteps, clean_mesh};
use crate::io::any::{MeshWriteOptions, load_mesh, output_format, save_mesh};
use crate::io::detect::FileFormat;

/// Arguments of `clean`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  # all default steps
  clean mesh.ply -o clean.ply
  poisson pts.ply -o - | clean - --keep-largest 1 -o object.ply
  clean scan.obj --no-nonmanifold --min-component-faces 100 \\
      -o scan_clean.obj --json=r.json")]
pub struct CleanArgs {
    /// Input mesh (PLY, OBJ, OFF, glTF/GLB); `-` = stdin.
    #[arg(default_value = "-")]
    pub input: PathBuf,
    /// Output mesh (format from the extension; PLY on stdout); `-` = stdout.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// Keep vertices with identical positions apart.
    #[arg(long)]
    pub no_merge: bool,
    /// Keep faces with a repeated vertex or zero area.
    #[arg(long)]
    pub no_degenerate: bool,
    /// Keep faces that repeat another face's vertices.
    #[arg(long)]
    pub no_duplicates: bool,
    /// Keep edges with more than two faces.
    #[arg(long)]
    pub no_nonmanifold: bool,
    /// Keep vertices no face uses.
    #[arg(long)]
    pub no_unreferenced: bool,
    /// Keep only the N connected components with the most faces.
    #[arg(long, value_name = "N")]
    pub keep_largest: Option<usize>,
    /// Drop connected components with fewer faces.
    #[arg(long, value_name = "N")]
    pub min_component_faces: Option<usize>,
    /// Drop connected components with less than this fraction of the total area.
    #[arg(long, value_name = "FRAC", value_parser = crate::cli::unit_f64)]
    pub min_component_area: Option<f64>,
    /// Write the mesh even when no face is left (an empty mesh), instead of
    /// failing with exit 1: for batch jobs where a part may clean away
    /// entirely (all faces degenerate, or removed by the component filters).
    #[arg(long)]
    pub allow_empty: bool,
    #[command(flatten)]
    pub common: Common,
}

/// Which step (and flag) removed the last faces of a mesh that `clean` left
/// empty, for the error message.
fn empty_cause(r: &crate::geom::mesh_ops::cleanup::CleanReport, args: &CleanArgs) -> String {
    if r.faces_before == 0 {
        return "the input has no faces".into();
    }
    if r.degenerate_faces == r.faces_before {
        return format!(
            "all {} faces are degenerate: a repeated vertex, zero area or a non-finite \
             coordinate (--no-degenerate keeps them)",
            r.faces_before
        );
    }
    if r.removed_component_faces > 0 {
        let flags: Vec<String> = [
            args.keep_largest.map(|n| format!("--keep-largest {n}")),
            args.min_component_faces
                .map(|n| format!("--min-component-faces {n}")),
            args.min_component_area
                .map(|f| format!("--min-component-area {f}")),
        ]
        .into_iter()
        .flatten()
        .collect();
        return format!(
            "{} of {} components removed by {}",
            r.removed_components,
            r.components,
            flags.join(", ")
        );
    }
    format!(
        "{} degenerate, {} duplicate and {} non-manifold faces removed of {}",
        r.degenerate_faces, r.duplicate_faces, r.nonmanifold_faces, r.faces_before
    )
}

/// `clean` entry point.
pub fn run(args: CleanArgs) -> anyhow::Result<()> {
    args.common.init()?;
    let format = output_format(&args.output, None, FileFormat::Ply)?;
    args.common.check_output(
        &args.output,
        matches!(format, FileFormat::Ply | FileFormat::Glb),
    )?;
    if args.keep_largest == Some(0) && !args.allow_empty {
        anyhow::bail!(
            "--keep-largest 0 keeps no component: the output would be an empty mesh; \
             nothing written (--allow-empty writes it)"
        );
    }
    let steps = CleanSteps {
        merge: !args.no_merge,
        degenerate: !args.no_degenerate,
        duplicates: !args.no_duplicates,
        nonmanifold: !args.no_nonmanifold,
        unreferenced: !args.no_unreferenced,
        components: ComponentFilter {
            keep_largest: args.keep_largest,
            min_faces: args.min_component_faces,
            min_area_fraction: args.min_component_area,
        },
    };
    let mut mesh = load_mesh(&args.input, "clean")?;
    let r = clean_mesh(&mut mesh, &steps);
    if mesh.faces.is_empty() && !args.allow_empty {
        anyhow::bail!(
            "{}: no face is left after cleaning ({}); nothing written (--allow-empty writes the \
             empty mesh)",
            shown(&args.input, false),
            empty_cause(&r, &args)
        );
    }
    save_mesh(&args.output, &mesh, format, &MeshWriteOptions::default())?;
    args.common.say(format!(
        "clean: {} faces / {} vertices -> {} / {} (merged {}, degenerate {}, duplicate {}, non-manifold {}, unreferenced {}, components removed {} of {})",
        r.faces_before,
        r.vertices_before,
        r.faces_after,
        r.vertices_after,
        r.merged_vertices,
        r.degenerate_faces,
        r.duplicate_faces,
        r.nonmanifold_faces,
        r.unreferenced_vertices,
        r.removed_components,
        r.components
    ));
    args.common.emit_json(&json!({
        "input": shown(&args.input, false),
        "output": shown(&args.output, true),
        "report": r,
    }))?;
    Ok(())
}
