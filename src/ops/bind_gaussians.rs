//! `bind-gaussians`: SuGaR's flat Gaussians bound to the triangles of a mesh
//! ([`crate::geom::binding`]), written as a standard 3DGS PLY that carries
//! the binding and the mesh (docs/bind-gaussians.md, docs/formats.md); and
//! rebinding such a file to an edited copy of its mesh.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::{Args, ValueEnum};
use serde_json::json;

use crate::cli::{Common, positive_f64, shown, usage};
use crate::geom::binding::colors::{dc_from_gaussians, dc_from_views};
use crate::geom::binding::rebind::{ScaleRule, rebind};
use crate::geom::binding::{
    BindOptions, THICKNESS_FACTOR, bind, materialize, mean_of, mesh_radius,
};
use crate::io::any::{
    check_finite_mesh, load, load_bound, load_gaussians_finite, load_mesh_finite, save_gaussians,
};
use crate::io::cameras::read_cameras;
use crate::io::ply::bound::{attach, is_bound};
use crate::io::views::{ViewOptions, load_views};
use crate::model::{BoundGaussians, Mesh, Scene};

/// How in-plane scales follow an edit (`--scale-rule`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ScaleRuleArg {
    /// × mean side length after / before (SuGaR supplement §8).
    MeanSide,
    /// SuGaR's current per-axis rule, with the in-plane rotation adjustment.
    Anisotropic,
}

/// Arguments of `bind-gaussians`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  # 1 Gaussian per triangle, vertex colours
  bind-gaussians mesh.ply -o bound.ply
  bind-gaussians mesh.ply --per-triangle 6 \\
      --cameras output/garden/cameras.json -o bound.ply
  bind-gaussians mesh.ply -o bound.ply \\
      --colors-from output/garden/point_cloud/iteration_7000/point_cloud.ply
  bind-gaussians mesh.ply --images garden/images \\
      --cameras garden/sparse/0 -o bound.ply
  bind-gaussians bound.ply --rebind edited_mesh.obj -o bound_edited.ply
  bind-gaussians bound.ply --rebind pose_042.ply --scale-rule anisotropic \\
      -o frame_042.ply

The output opens in any 3DGS viewer (SuperSplat, SIBR) and in `render`; it
also carries the binding (face_index, bary_0..2, complex_re, complex_im) and
the mesh (elements bound_vertex, bound_face), so `--rebind` and `refine` need
nothing else.")]
pub struct BindGaussiansArgs {
    /// A mesh to bind to (PLY, OBJ, OFF, glTF/GLB), or, with --rebind, a bound
    /// Gaussians PLY; `-` = stdin.
    pub input: PathBuf,
    /// Output bound Gaussians (3DGS PLY); `-` = stdout.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Gaussians per triangle: SuGaR's tables exist for 1, 3, 4 and 6.
    #[arg(long, default_value_t = 1, value_name = "N", conflicts_with = "rebind")]
    pub per_triangle: usize,
    /// Standard deviation along the face normal, world units (default:
    /// 1e-6 × the cameras' extent with --cameras, as SuGaR, else 1e-6 × half
    /// the mesh's bounding-box diagonal).
    #[arg(long, value_parser = positive_f64, conflicts_with = "rebind")]
    pub thickness: Option<f64>,
    /// Cameras (any format splatkit reads) whose extent sets the thickness.
    #[arg(long, value_name = "CAMS", conflicts_with = "rebind")]
    pub cameras: Option<PathBuf>,
    /// Take each Gaussian's colour (SH DC) from a 3DGS scene: the source
    /// Gaussian of highest density weight among the 16 nearest centres.
    #[arg(long, value_name = "SCENE.ply", conflicts_with = "rebind")]
    pub colors_from: Option<PathBuf>,
    /// Take each Gaussian's colour from these photos (named like --cameras'
    /// views): the mean of the pixels its mean projects to in the views where
    /// its face is visible (mesh z-buffer); unseen Gaussians keep the mesh colour.
    #[arg(long, value_name = "DIR", requires = "cameras", conflicts_with_all = ["rebind", "colors_from"])]
    pub images: Option<PathBuf>,
    /// With --images: divide the cameras' resolution by this integer (images at
    /// that size, or at the camera's size divided by a divisor of it).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64), requires = "images")]
    pub downscale: u32,
    /// SH degree of the bound model (higher coefficients start at 0).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(0..=3))]
    pub sh_degree: u8,
    /// Rebind INPUT (a bound PLY) to this edited mesh (same faces, moved vertices).
    #[arg(long, value_name = "EDITED_MESH")]
    pub rebind: Option<PathBuf>,
    /// How in-plane scales follow the edit (with --rebind).
    #[arg(long, value_enum, default_value_t = ScaleRuleArg::MeanSide, requires = "rebind")]
    pub scale_rule: ScaleRuleArg,
    #[command(flatten)]
    pub common: Common,
}

/// Writes `b` as a bound 3DGS PLY.
pub fn save_bound(path: &std::path::Path, b: &BoundGaussians) -> crate::Result<()> {
    save_gaussians(path, &attach(b, materialize(b)))
}

/// Working bytes per pixel of the largest view while colours are taken from
/// the photos (`rgb_from_views`: the mesh z-buffer's depth, face index and
/// barycentrics, at most 32 bytes), on top of the photos themselves
/// (`io::dataset::check_views_budget`).
const BIND_BYTES_PER_PIXEL: u64 = 32;

/// `bind-gaussians` entry point: checks the flags, binds a mesh
/// ([`bind_mesh`]) or rebinds a bound file ([`rebind_file`]), writes the
/// bound PLY and reports.
pub fn run(args: BindGaussiansArgs) -> anyhow::Result<()> {
    args.common.init()?;
    args.common.check_output(&args.output, true)?;
    crate::cli::declare_inputs(&[
        Some(args.input.as_path()),
        args.cameras.as_deref(),
        args.images.as_deref(),
        args.rebind.as_deref(),
        args.colors_from.as_deref(),
    ])?;
    if crate::model::bound::barycentrics(args.per_triangle).is_none() {
        return Err(usage(format!(
            "--per-triangle {}: SuGaR defines Gaussians-per-triangle tables for 1, 3, 4 and 6 only",
            args.per_triangle
        )));
    }
    let t0 = std::time::Instant::now();
    let (b, report) = match &args.rebind {
        Some(edited) => rebind_file(&args, edited)?,
        None => bind_mesh(&args)?,
    };
    save_bound(&args.output, &b)?;
    args.common.say(format!(
        "bind-gaussians: {} Gaussians on {} faces ({} per face) -> {} in {:.2} s",
        b.len(),
        b.mesh.faces.len(),
        b.per_face,
        shown(&args.output, true),
        t0.elapsed().as_secs_f64()
    ));
    args.common.emit_json(&json!({
        "input": shown(&args.input, false),
        "output": shown(&args.output, true),
        "gaussians": b.len(),
        "faces": b.mesh.faces.len(),
        "vertices": b.mesh.vertices.len(),
        "per_face": b.per_face,
        "thickness": (b.log_thickness as f64).exp(),
        "report": report,
    }))?;
    Ok(())
}

/// `--rebind`: the bound Gaussians of the input moved onto the `edited`
/// mesh ([`rebind`] with `--scale-rule`), and the report's `report` entry.
fn rebind_file(
    args: &BindGaussiansArgs,
    edited: &Path,
) -> anyhow::Result<(BoundGaussians, serde_json::Value)> {
    let (b, g) = load_bound(&args.input, "bind-gaussians --rebind")?;
    crate::model::filter3d::refuse_filter_3d(&g, "bind-gaussians --rebind")
        .map_err(|e| e.in_file(shown(&args.input, false)))?;
    let mesh = load_mesh_finite(edited, "bind-gaussians --rebind")?;
    let rule = match args.scale_rule {
        ScaleRuleArg::MeanSide => ScaleRule::MeanSide,
        ScaleRuleArg::Anisotropic => ScaleRule::Anisotropic,
    };
    let out =
        rebind(&b, &mesh, rule).map_err(|m| anyhow::anyhow!("{}: {m}", shown(edited, false)))?;
    let moved = b
        .mesh
        .vertices
        .iter()
        .zip(&mesh.vertices)
        .filter(|(a, b)| a != b)
        .count();
    Ok((
        out,
        json!({"mode": "rebind", "edited_mesh": shown(edited, false),
               "scale_rule": args.scale_rule.to_possible_value().map(|v| v.get_name().to_string()), "moved_vertices": moved}),
    ))
}

/// Binds Gaussians to the input mesh ([`bind`]: `--per-triangle`, the
/// thickness of [`thickness`], `--sh-degree`), coloured from the mesh,
/// then from `--colors-from`, then from `--images`; and the report's
/// `report` entry.
fn bind_mesh(args: &BindGaussiansArgs) -> anyhow::Result<(BoundGaussians, serde_json::Value)> {
    let mesh = load_mesh_to_bind(args)?;
    let (thickness, thickness_from) = thickness(args, &mesh)?;
    let opts = BindOptions {
        per_face: args.per_triangle,
        thickness: thickness as f32,
        sh_degree: args.sh_degree as usize,
    };
    let mut b = bind(&mesh, &opts, None)
        .map_err(|m| anyhow::anyhow!("{}: {m}", shown(&args.input, false)))?;
    let mut colors = if mesh.vertex_colors.is_some() {
        "mesh vertex colours"
    } else {
        "grey (the mesh has no vertex colours)"
    };
    if let Some(src) = &args.colors_from {
        let g = load_gaussians_finite(src, "bind-gaussians --colors-from")?;
        // the source's weights use its opacities and scales: those its
        // renderer draws when it carries Mip-Splatting's filter_3D
        let g =
            crate::model::filter3d::bake_filter_3d(&g).map_err(|e| e.in_file(shown(src, false)))?;
        let at: Vec<[f64; 3]> = (0..b.len()).map(|i| mean_of(&b, i)).collect();
        b.sh_dc = dc_from_gaussians(&at, &g)
            .with_context(|| format!("colours from {}", shown(src, false)))?;
        colors = "highest-weight source Gaussian";
    }
    if let (Some(dir), Some(cams_path)) = (&args.images, &args.cameras) {
        colors = colour_from_photos(args, &mut b, dir, cams_path)?;
    }
    Ok((
        b,
        json!({"mode": "bind", "thickness": thickness, "thickness_from": thickness_from,
               "colors": colors}),
    ))
}

/// The input's mesh, with finite values: an error for any other scene (a
/// usage error for bound Gaussians, which `--rebind` takes).
fn load_mesh_to_bind(args: &BindGaussiansArgs) -> anyhow::Result<Mesh> {
    let scene = load(&args.input)?;
    let mesh = match scene {
        Scene::Mesh(m) => m,
        Scene::Gaussians(g) if is_bound(&g) => {
            return Err(usage(format!(
                "{} already holds bound Gaussians: give --rebind EDITED_MESH to rebind \
                 them, or bind a mesh",
                shown(&args.input, false)
            )));
        }
        other => anyhow::bail!(
            "{}: bind-gaussians takes a mesh, but the file holds {}",
            shown(&args.input, false),
            other.kind().phrase()
        ),
    };
    // before the thickness is derived from the mesh's extent
    check_finite_mesh(&shown(&args.input, false), &mesh)?;
    Ok(mesh)
}

/// The thickness (world units) and where it came from: `--thickness`,
/// else 1e-6 × the extent of `--cameras`, else 1e-6 × the mesh's
/// bounding radius.
fn thickness(args: &BindGaussiansArgs, mesh: &Mesh) -> anyhow::Result<(f64, String)> {
    Ok(match (args.thickness, &args.cameras) {
        (Some(t), _) => (t, "--thickness".to_string()),
        (None, Some(c)) => {
            let cams = read_cameras(c)?;
            let centres: Vec<[f64; 3]> = cams.iter().map(|c| c.center().to_array()).collect();
            let e = crate::model::rig::nerfpp_radius(&centres).with_context(|| {
                format!(
                    "{}: the cameras share one centre, so they give no extent; give \
                     --thickness",
                    shown(c, false)
                )
            })?;
            (e * THICKNESS_FACTOR, format!("1e-6 × camera extent {e:.6}"))
        }
        (None, None) => {
            let r = mesh_radius(mesh);
            if !(r > 0.0 && r.is_finite()) {
                anyhow::bail!(
                    "{}: the mesh has no extent to derive a thickness from; give --thickness",
                    shown(&args.input, false)
                );
            }
            (
                r * THICKNESS_FACTOR,
                format!("1e-6 × mesh bounding radius {r:.6}"),
            )
        }
    })
}

/// Recolours `b` from the photos in `dir` of the cameras at `cams_path`
/// (name-sorted, downscaled by `--downscale`; [`dc_from_views`]); returns
/// the report's `colors` entry.
fn colour_from_photos(
    args: &BindGaussiansArgs,
    b: &mut BoundGaussians,
    dir: &Path,
    cams_path: &Path,
) -> anyhow::Result<&'static str> {
    let mut cams = read_cameras(cams_path)?;
    cams.sort_by(|a, b| a.name.cmp(&b.name));
    // every photo is held at once: checked before any is decoded
    crate::io::dataset::check_views_budget(cams_path, &cams, args.downscale, BIND_BYTES_PER_PIXEL)?;
    let views = load_views(
        &cams,
        dir,
        &ViewOptions {
            downscale: args.downscale,
            masks: None,
            background: None,
        },
    )?;
    let (dc, unseen) = dc_from_views(b, &views);
    b.sh_dc = dc;
    Ok(if unseen == 0 {
        "photos (every Gaussian seen)"
    } else {
        "photos (unseen Gaussians keep the mesh colour)"
    })
}
