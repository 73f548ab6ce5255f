//! `export-off`: a triangle soup (or mesh) to OFF for game engines, exactly as
//! Triangle Splatting's `create_off.py` writes it, or to GLB / glTF / PLY / OBJ.
//! The soup-to-mesh conversion (colours, vertex merging) is
//! [`crate::geom::meshing::soup_mesh`]; mesh inputs are written with whatever colours
//! they have.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde_json::json;

use crate::cli::{Common, shown};
use crate::geom::meshing::soup_mesh::{ExportParams, soup_to_mesh};
use crate::io::any::{MeshWriteOptions, open, output_format, save_mesh};
use crate::io::detect::FileFormat;
use crate::io::off::OffWriteOptions;
use crate::model::{Scene, SceneKind};

/// Command-line arguments of `export-off`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  export-off point_cloud_state_dict.pt -o scene.off          # byte-compatible with create_off.py
  export-off scene.pt --format glb -o scene.glb --alpha
  prune-triangles scene.pt --game-engine -o - | export-off - -o solid.off")]
pub struct ExportOffArgs {
    /// Input: Triangle Splatting checkpoint (.pt), soup PLY, or a mesh (PLY/OBJ/OFF/GLB); `-` = stdin.
    pub input: PathBuf,
    /// Output file; `-` = stdout (OFF unless --format).
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// Output format, overriding the extension.
    #[arg(long, value_parser = ["off", "glb", "gltf", "ply", "obj"])]
    pub format: Option<String>,
    /// Keep three vertices per triangle instead of merging identical ones.
    #[arg(long)]
    pub no_dedup: bool,
    /// Put colours on vertices (corners of each face get its colour) instead of faces.
    #[arg(long)]
    pub per_vertex_colors: bool,
    /// Write alpha = trunc(opacity·255) instead of 255.
    #[arg(long)]
    pub alpha: bool,
    /// Colour from the DC term only (view-independent).
    #[arg(long)]
    pub dc_only: bool,
    /// Eye position for view-dependent colour, "x,y,z" (default: the origin, as create_off.py).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_xyz)]
    pub view_from: Option<[f32; 3]>,
    /// Write the output even when the input holds no triangle (an empty
    /// file), instead of failing with exit 1: after `prune-triangles
    /// --allow-empty` in batch jobs.
    #[arg(long)]
    pub allow_empty: bool,
    #[command(flatten)]
    pub common: Common,
}

fn parse_xyz(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|t| t.trim().parse::<f32>().map_err(|e| format!("'{t}': {e}")))
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!("expected three finite numbers 'x,y,z', got '{s}'")),
    }
}

/// Runs the command.
pub fn run(args: ExportOffArgs) -> anyhow::Result<()> {
    args.common.init()?;
    crate::cli::check_output_file(&args.output, "-o")?;
    args.common.check_stdout_free(&args.output)?;
    let explicit = args.format.as_deref().map(|f| match f {
        "glb" => FileFormat::Glb,
        "gltf" => FileFormat::Gltf,
        "ply" => FileFormat::Ply,
        "obj" => FileFormat::Obj,
        _ => FileFormat::Off,
    });
    let format = output_format(&args.output, explicit, FileFormat::Off)?;
    if !matches!(
        format,
        FileFormat::Off | FileFormat::Glb | FileFormat::Gltf | FileFormat::Ply | FileFormat::Obj
    ) {
        anyhow::bail!(
            "export-off writes off, glb, gltf, ply or obj, not {}",
            format.name()
        );
    }
    if matches!(format, FileFormat::Glb | FileFormat::Ply) {
        crate::cli::check_binary_stdout(&args.output)?;
    }
    let params = ExportParams {
        dedup: !args.no_dedup,
        per_vertex_colors: args.per_vertex_colors,
        alpha: args.alpha,
        dc_only: args.dc_only,
        view_from: args.view_from.unwrap_or([0.0; 3]),
    };
    let scene = open(&args.input)?
        .decode_kinds("export-off", &[SceneKind::TriangleSoup, SceneKind::Mesh])?;
    let (mesh, from_soup) = match scene {
        Scene::TriangleSoup(s) => (soup_to_mesh(&s, &params), true),
        Scene::Mesh(m) => (m, false),
        _ => unreachable!("decode_kinds returns an accepted kind"),
    };
    if mesh.faces.is_empty() && !args.allow_empty {
        anyhow::bail!(
            "{}: holds no triangles, so the {} output would be empty; nothing written (--allow-empty \
             writes it)",
            shown(&args.input, false),
            format.name().to_uppercase()
        );
    }
    // OFF from a soup: create_off.py's layout (face colours, or vertex
    // colours in Python repr floats); from a mesh: COFF when it has colours.
    let off = if from_soup && !params.per_vertex_colors {
        Some(OffWriteOptions {
            face_alpha: params.alpha,
            ..OffWriteOptions::triangle_splatting()
        })
    } else if from_soup {
        Some(OffWriteOptions {
            float_style: crate::io::off::FloatStyle::PythonRepr,
            ..OffWriteOptions::for_mesh(&mesh)
        })
    } else {
        None
    };
    save_mesh(&args.output, &mesh, format, &MeshWriteOptions { off })
        .with_context(|| format!("writing {}", shown(&args.output, true)))?;
    args.common.say(format!(
        "export-off: wrote {} vertices, {} faces as {} to {}",
        mesh.vertices.len(),
        mesh.faces.len(),
        format.name(),
        shown(&args.output, true)
    ));
    args.common.emit_json(&json!({
        "input": shown(&args.input, false),
        "output": shown(&args.output, true),
        "format": format.name(),
        "vertices": mesh.vertices.len(),
        "faces": mesh.faces.len(),
        "from_soup": from_soup,
    }))
}
