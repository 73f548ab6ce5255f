//! `bake-texture`: SuGaR's textured-mesh export (V2 semantics). The colours
//! of a 3DGS scene (SH DC, black background), rendered from the training
//! cameras, are averaged into a trivial per-triangle atlas on the mesh
//! ([`crate::geom::mesh_ops::texture_bake`] holds the atlas and the rules); the result
//! is an OBJ with its MTL and PNG. This module only resolves files, flags,
//! progress and the report.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde_json::json;

use crate::cli::orbit::{SizeFrom, check_image_budget, image_bytes, largest_size};
use crate::cli::{Common, positive_f64, shown, usage};
use crate::geom::mesh_ops::texture_bake::{self, BakeParams, BakeStats, DEFAULT_SQUARE};
use crate::io::any::{MeshWriteOptions, load_gaussians, load_mesh, save_mesh};
use crate::io::cameras::read_cameras;
use crate::io::detect::FileFormat;
use crate::model::{Camera, Gaussians, Mesh};

/// Arguments of `bake-texture`.
#[derive(Args, Debug, Clone)]
#[command(
    after_help = "Writes NAME.obj, NAME.mtl and NAME.png (all three, or none on failure).

Examples:
  bake-texture sugarfine.ply point_cloud.ply --cameras cameras.json \\
      -o textured.obj
  bake-texture mesh.obj refined.ply --cameras sparse/0 \\
      -o textured.obj --square-size 10
  bake-texture mesh.ply gaussians.ply --cameras transforms.json \\
      -o t.obj --json=bake.json
  # look at it
  render textured.obj --cameras cameras.json --shading none -o views/"
)]
pub struct BakeTextureArgs {
    /// The mesh to texture (PLY, OBJ, OFF, glTF/GLB): SuGaR's refined mesh.
    pub mesh: PathBuf,
    /// The 3DGS Gaussians PLY whose colours are baked; bound to the mesh's
    /// faces face-major (n per face) or by a `face_index` property, for the
    /// colour of faces no camera sees.
    pub gaussians: PathBuf,
    /// Camera file or folder (COLMAP, cameras.json, transforms.json,
    /// cameras.npz): the views rendered and averaged.
    #[arg(long)]
    pub cameras: PathBuf,
    /// Output OBJ; the MTL and PNG get the same name with .mtl and .png.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Texels per side of the square holding each pair of triangles (SuGaR
    /// V2: 8; V1: 10). At least 4.
    #[arg(long, default_value_t = DEFAULT_SQUARE,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(4..=256))]
    pub square_size: usize,
    /// Largest texture side accepted, texels: a larger atlas is refused
    /// before anything is allocated, as is one beyond the memory budget
    /// (baking and writing take about 28 bytes per texel).
    #[arg(long, default_value_t = 16384, value_name = "N",
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    pub max_texture: usize,
    /// Near plane (camera z) of the mesh and Gaussian renders.
    #[arg(long, default_value_t = 0.2, value_parser = positive_f64)]
    pub near: f64,
    #[command(flatten)]
    pub common: Common,
}

/// `bake-texture` entry point: checks the three outputs, reads the mesh,
/// the Gaussians and the cameras within the memory budget
/// ([`load_inputs`]), bakes ([`texture_bake::bake_texture`]), writes the
/// OBJ with its MTL and PNG, and reports.
pub fn run(args: BakeTextureArgs) -> anyhow::Result<()> {
    args.common.init()?;
    check_outputs(&args)?;
    let t0 = std::time::Instant::now();
    let params = BakeParams {
        square: args.square_size,
        near: args.near,
        max_texture: args.max_texture,
    };
    let (mesh, gaussians, cams) = load_inputs(&args, &params)?;
    let pb = args.common.progress(cams.len() as u64, "bake-texture");
    let (textured, stats) =
        texture_bake::bake_texture(&mesh, &gaussians, &cams, &params, |_| pb.inc(1)).with_context(
            || {
                format!(
                    "baking {} with {}",
                    shown(&args.mesh, false),
                    shown(&args.gaussians, false)
                )
            },
        )?;
    pb.finish_and_clear();
    save_mesh(
        &args.output,
        &textured,
        FileFormat::Obj,
        &MeshWriteOptions::default(),
    )
    .with_context(|| format!("writing {}", args.output.display()))?;
    report(&args, &stats, t0.elapsed().as_secs_f64())
}

/// `-o` names an OBJ (not stdout); it and the MTL and PNG written beside
/// it can be created, and none of them is an input. Before any work.
fn check_outputs(args: &BakeTextureArgs) -> anyhow::Result<()> {
    if args.output.as_os_str() == "-" {
        return Err(usage(
            "-o: bake-texture writes three files (OBJ, MTL, PNG) and cannot write to stdout",
        ));
    }
    crate::cli::check_output_file(&args.output, "-o")?;
    let is_obj = args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    if !is_obj {
        return Err(usage(format!(
            "-o {}: the output is an OBJ (with its MTL and PNG): name it NAME.obj",
            args.output.display()
        )));
    }
    // The MTL and PNG written beside the OBJ are outputs too (checked
    // before any work, like -o: writable, and none of them an input).
    for ext in ["mtl", "png"] {
        crate::cli::check_output_file(
            &args.output.with_extension(ext),
            &format!("-o {} (its {})", args.output.display(), ext.to_uppercase()),
        )?;
    }
    Ok(())
}

/// The mesh, the Gaussians and the cameras, each refused as soon as it
/// is read when it cannot be baked: a texture larger than
/// `--max-texture` or the memory budget (from the mesh's face count), no
/// Gaussian, no camera, or render buffers beyond the budget.
fn load_inputs(
    args: &BakeTextureArgs,
    params: &BakeParams,
) -> anyhow::Result<(Mesh, Gaussians, Vec<Camera>)> {
    let mesh = load_mesh(&args.mesh, "bake-texture")
        .with_context(|| format!("reading {}", shown(&args.mesh, false)))?;
    // Refused here, before the Gaussians are read or anything allocated.
    texture_bake::check_texture_size(mesh.faces.len(), params)
        .with_context(|| format!("baking {}", shown(&args.mesh, false)))?;
    // The atlas the mesh's face count and --square-size make, within the
    // memory budget (the views are added once the cameras are read).
    let side = texture_bake::Atlas::side_for(mesh.faces.len(), args.square_size);
    let atlas_what = format!(
        "{}: the {side}x{side} texture atlas of its {} faces at --square-size {}",
        shown(&args.mesh, false),
        mesh.faces.len(),
        args.square_size
    );
    crate::io::budget::check(
        &atlas_what,
        texture_bake::bake_bytes(mesh.faces.len(), args.square_size, 0),
    )?;
    let gaussians = load_gaussians(&args.gaussians, "bake-texture")
        .with_context(|| format!("reading {}", shown(&args.gaussians, false)))?;
    // its renders use 3DGS's rules only: a Mip-Splatting / GOF model would
    // be drawn without its filters
    crate::model::filter3d::refuse_filter_3d(&gaussians, "bake-texture")
        .map_err(|e| e.in_file(shown(&args.gaussians, false)))?;
    // No colour to bake: the texture would be the background only.
    if gaussians.is_empty() {
        anyhow::bail!(
            "{}: holds no Gaussians: there is no colour to bake into {}",
            shown(&args.gaussians, false),
            shown(&args.mesh, false)
        );
    }
    let cams = read_cameras(&args.cameras)
        .with_context(|| format!("reading cameras {}", args.cameras.display()))?;
    if cams.is_empty() {
        anyhow::bail!("{}: holds no cameras", args.cameras.display());
    }
    let largest = image_bytes(&cams, 1, 0);
    check_image_budget(
        SizeFrom::File(&args.cameras),
        &format!(
            "the render buffers of a {} view with {atlas_what}",
            largest_size(&cams)
        ),
        texture_bake::bake_bytes(mesh.faces.len(), args.square_size, largest),
    )?;
    Ok((mesh, gaussians, cams))
}

/// The human summary (stderr) and the JSON report of a written texture;
/// `secs` is the run's seconds so far.
fn report(args: &BakeTextureArgs, stats: &BakeStats, secs: f64) -> anyhow::Result<()> {
    args.common.say(format!(
        "bake-texture: {} faces, {}x{} texture from {} views ({:.1}% of faces seen) into {} ({secs:.1} s)",
        stats.faces,
        stats.texture_size,
        stats.texture_size,
        stats.views,
        100.0 * stats.seen_fraction(),
        args.output.display()
    ));
    args.common.emit_json(&json!({
        "mesh": shown(&args.mesh, false),
        "gaussians": shown(&args.gaussians, false),
        "faces": stats.faces,
        "texture_size": stats.texture_size,
        "square_size": args.square_size,
        "views": stats.views,
        "seen_faces": stats.seen_faces,
        "seen_face_fraction": stats.seen_fraction(),
        "hit_texel_fraction": if stats.owned_texels == 0 { 0.0 } else {
            stats.hit_texels as f64 / stats.owned_texels as f64
        },
        "output": args.output.display().to_string(),
        "files": [
            args.output.display().to_string(),
            args.output.with_extension("mtl").display().to_string(),
            args.output.with_extension("png").display().to_string(),
        ],
        "seconds": secs,
    }))?;
    Ok(())
}
