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
use crate::io::any::{MeshWriteOptions, open, output_format, save_mesh, written_counts};
use crate::io::detect::FileFormat;
use crate::io::gltf::face_colors_to_corners;
use crate::io::off::OffWriteOptions;
use crate::model::{Scene, SceneKind};

/// Command-line arguments of `export-off`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  # byte-compatible with create_off.py
  export-off point_cloud_state_dict.pt -o scene.off
  export-off scene.pt --format glb -o scene.glb --alpha
  # Open3D reads the colours
  export-off scene.pt --off-layout compatible -o scene.off
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
    /// OFF layout: `triangle-splatting` (default; create_off.py's bytes: COFF
    /// header, colours on the faces; Triangle Splatting's tools, MeshLab and
    /// splatkit read its colours, Open3D 0.19 refuses it, trimesh reads the
    /// geometry only) or `compatible` (COFF with `r g b a` on every vertex,
    /// corners un-shared; Open3D reads its colours, trimesh and MeshLab too).
    #[arg(long, value_enum, value_name = "LAYOUT")]
    pub off_layout: Option<OffLayout>,
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

/// The OFF layouts `export-off` writes.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OffLayout {
    /// Triangle Splatting's `create_off.py`: `COFF`, per-face colours.
    TriangleSplatting,
    /// `COFF` with per-vertex `r g b a`, which Open3D requires of `COFF`.
    Compatible,
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
    if args.off_layout.is_some() && format != FileFormat::Off {
        return Err(crate::cli::usage(format!(
            "--off-layout applies to OFF output, not {}",
            format.name()
        )));
    }
    let compatible = args.off_layout == Some(OffLayout::Compatible);
    let params = ExportParams {
        dedup: !args.no_dedup,
        per_vertex_colors: args.per_vertex_colors || compatible,
        alpha: args.alpha,
        dc_only: args.dc_only,
        view_from: args.view_from.unwrap_or([0.0; 3]),
    };
    let scene = open(&args.input)?
        .decode_kinds("export-off", &[SceneKind::TriangleSoup, SceneKind::Mesh])?;
    let (mut mesh, from_soup) = match scene {
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
    // The compatible layout wants colours on the vertices: a mesh with face
    // colours only gets three vertices per face, each with its face's colour.
    if compatible && !from_soup {
        if mesh.vertex_colors.is_none() && mesh.face_colors.is_some() {
            mesh = face_colors_to_corners(&mesh);
        }
        mesh.face_colors = None;
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
    let opts = MeshWriteOptions {
        off,
        gltf_blend: args.alpha,
        double_sided: from_soup,
    };
    save_mesh(&args.output, &mesh, format, &opts)
        .with_context(|| format!("writing {}", shown(&args.output, true)))?;
    // What the file holds (glTF and OBJ un-share vertices for face colours).
    let (vertices, faces) = written_counts(&mesh, format);
    args.common.say(format!(
        "export-off: wrote {} vertices, {} faces as {} to {}",
        vertices,
        faces,
        format.name(),
        shown(&args.output, true)
    ));
    args.common.emit_json(&json!({
        "input": shown(&args.input, false),
        "output": shown(&args.output, true),
        "format": format.name(),
        "vertices": vertices,
        "faces": faces,
        "from_soup": from_soup,
    }))
}
