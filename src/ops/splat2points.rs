//! `splat2points`: a 3DGS or 2DGS scene to an oriented, coloured point cloud
//! for `poisson` — SuGaR's level-set sampling
//! ([`crate::geom::surface_points::levelset`]) or the quick `centers` /
//! `depth` methods ([`crate::geom::surface_points::splat_points`]); for 2DGS
//! surfels, their rendered depth or centres
//! ([`crate::geom::surface_points::surfel_points`]).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use serde_json::json;

use crate::cli::filter2d::Filter2dArgs;
use crate::cli::model_folder::{resolve_model_folder, training_views};
use crate::cli::orbit::{OrbitArgs, SizeFrom, check_image_budget, image_bytes, largest_size};
use crate::cli::{Common, fraction_f32, nonneg_f64, shown, usage};
use crate::geom::scenes::orbit::orbit_rings;
use crate::geom::surface_points::levelset::{DepthSource, LevelsetOptions, to_point_cloud};
use crate::geom::surface_points::splat_points::{PointMethod, splat_to_points};
use crate::geom::surface_points::surfel_points::surfels_to_points;
use crate::io::any::{load_kinds, save_points};
use crate::io::cameras::read_cameras;
use crate::io::ply::Format;
use crate::model::{Camera, OrbitSpec, Scene, SceneKind};
use splatkit_render::gaussian::{Filter2d, Gaussians3};
use splatkit_render::surfel::Surfels2;

/// How points are made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// SuGaR's level-set sampling along camera rays (3D Gaussians only).
    Levelset,
    /// Gaussian centres, normals from the shortest axis.
    Centers,
    /// Back-projected median-depth maps, normals from depth gradients (for
    /// 2DGS surfels: their rendered surface).
    Depth,
}

/// Depth source of the level-set method (where each ray starts; see
/// [`DepthSource`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DepthArg {
    /// Camera-facing ±2σ diamonds in a z-buffer (SuGaR's default).
    Diamonds,
    /// SuGaR's `use_gaussian_depth` mode: the 3DGS-blended view z over a
    /// background of −1 (Σwz − T, pulled toward the camera where the alpha
    /// is below 1); density over the 16 centres nearest the ray's point.
    Gaussian,
    /// The 3DGS alpha-blended median depth where the alpha reaches 0.5 (not
    /// a SuGaR mode).
    Median,
}

impl DepthArg {
    /// The library's depth source.
    pub fn source(self) -> DepthSource {
        match self {
            DepthArg::Diamonds => DepthSource::Diamonds,
            DepthArg::Gaussian => DepthSource::Gaussian,
            DepthArg::Median => DepthSource::Median,
        }
    }
}

/// Arguments of `splat2points`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  # 3DGS model folder: latest iteration, cameras.json
  splat2points output/garden/ -o points.ply
  splat2points scene.ply --cameras sparse/0 --level 0.1,0.3,0.5 \\
      --provenance -o points.ply
  splat2points scene.ply --cameras cameras.json \\
      | poisson - --depth 10 -o mesh.ply
  splat2points scene.ply --cameras cameras.json --method centers \\
      -o centres.ply
  # no cameras: orbit
  splat2points biker.ply --orbit 24 --elevation 30,-20 --size 1024x768 \\
      -o points.ply
  # 2DGS surfels: their rendered depth (--method depth)
  splat2points 2dgs_output/ -o points.ply")]
pub struct Splat2PointsArgs {
    /// A 3DGS Gaussian PLY or 2DGS surfel PLY, or a 3DGS / 2DGS model folder
    /// (uses `point_cloud/iteration_*/point_cloud.ply` and `cameras.json`).
    pub scene: PathBuf,
    /// Camera file or folder (default: `cameras.json` of a model folder, or
    /// `--orbit` cameras).
    #[arg(long)]
    pub cameras: Option<PathBuf>,
    /// Output PLY; `-` = stdout.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// How points are made [default: levelset for Gaussians, depth for 2DGS
    /// surfels, which have no level set].
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// Density levels λ (comma-separated; each gives its own points).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0.3",
        allow_hyphen_values = true,
        value_parser = parse_level
    )]
    pub level: Vec<f32>,
    /// Depth at which each ray's samples are centred (levelset): SuGaR's
    /// diamond z-buffer, SuGaR's Gaussian-rasterised depth, or the median
    /// depth.
    #[arg(long, value_enum, default_value = "diamonds")]
    pub depth: DepthArg,
    /// Total point cap over all views, per level.
    #[arg(long, default_value_t = 10_000_000, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=1u64 << 40))]
    pub max_points: usize,
    /// Gaussians (surfels) with opacity at or below this are dropped.
    #[arg(long, default_value_t = 0.5, value_parser = fraction_f32)]
    pub min_opacity: f32,
    /// Hold out every N-th camera (name-sorted, from the first) as 3DGS's
    /// test split does; 0 keeps all (1 would hold out all).
    #[arg(long, default_value_t = 8, value_parser = crate::cli::holdout_every)]
    pub every_nth_test: usize,
    /// Use every camera (same as --every-nth-test 0).
    #[arg(long)]
    pub all_views: bool,
    /// Model iteration to read from a model folder (default: the latest).
    #[arg(long)]
    pub iteration: Option<u64>,
    /// Add `level` and `camera` properties to the points.
    #[arg(long)]
    pub provenance: bool,
    /// Random seed (pixel choice).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Near plane of the renders.
    #[arg(long, default_value_t = 0.2, value_parser = nonneg_f64)]
    pub near: f64,
    /// Cameras made up around the scene instead of a camera file
    /// (`--orbit N`; no views are held out).
    #[command(flatten)]
    pub orbit: OrbitArgs,
    #[command(flatten)]
    pub filter: Filter2dArgs,
    #[command(flatten)]
    pub common: Common,
}

/// A density level λ: a number strictly between 0 and 1 (the density is
/// clamped to [0, 1], so 0 and 1 have no crossing).
fn parse_level(s: &str) -> Result<f32, String> {
    let l: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if l > 0.0 && l < 1.0 {
        Ok(l)
    } else {
        Err(format!("level {s} is not in (0, 1)"))
    }
}

/// How many splats (centres `means`, activated `opacities`) with opacity
/// above `min_opacity` have their centre inside the image of at least one
/// camera, in front of its near plane.
pub fn seen_by_any(
    means: &[[f32; 3]],
    opacities: &[f32],
    cams: &[Camera],
    min_opacity: f32,
    near: f64,
) -> usize {
    use rayon::prelude::*;
    (0..means.len())
        .into_par_iter()
        .filter(|&i| opacities[i] > min_opacity)
        .filter(|&i| {
            let m = means[i];
            let p = glam::DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64);
            cams.iter().any(|c| {
                c.project(p).is_some_and(|(px, z)| {
                    z > near
                        && px.x >= 0.0
                        && px.y >= 0.0
                        && px.x < c.width as f64
                        && px.y < c.height as f64
                })
            })
        })
        .count()
}

/// Bytes per pixel `splat2points` holds for the one view it samples, over
/// its methods (the largest): a Gaussian render (52 of output + 12 of
/// working buffers = 64) for `--depth gaussian|median` and `--method
/// depth`, the per-pixel depth and hit (`Option<(f32, u32)>`, 12), the
/// depth map taken from the render (4), the covered-pixel list (4) and the
/// diamond z-buffer's own depth and hit per pixel (12).
pub const SPLAT2POINTS_BYTES_PER_PIXEL: u64 = 64 + 12 + 4 + 4 + 12;

/// Bytes of `splat2points`'s image buffers for `cams`: the largest view's
/// pixels × [`SPLAT2POINTS_BYTES_PER_PIXEL`] (views are sampled one at a
/// time; the points kept are bounded by `--max-points`, not by the images).
pub fn splat2points_image_bytes(cams: &[Camera]) -> u64 {
    image_bytes(cams, SPLAT2POINTS_BYTES_PER_PIXEL, 0)
}

/// `splat2points` entry point: resolves the scene and its cameras, checks
/// that some camera sees an opaque Gaussian, makes the points
/// ([`splat_to_points`]), writes them and reports.
pub fn run(args: Splat2PointsArgs) -> anyhow::Result<()> {
    args.common.init()?;
    args.common.check_output(&args.output, true)?;
    let t0 = std::time::Instant::now();
    let (scene, cam_path, orbit) = resolve_inputs(&args)?;
    let (g, filtered) = load_splats(&scene)?;
    // a `filter_3D` property (Mip-Splatting, GOF) was baked into the scales
    // and opacities, and picks the Mip filter under `--filter-2d auto`
    let filter_2d = crate::model::filter3d::choose_filter_2d(
        args.filter.choice(),
        args.filter.kernel_size,
        filtered,
    );
    let method = args.method.unwrap_or(match g {
        Splats::Gaussians(_) => Method::Levelset,
        Splats::Surfels(_) => Method::Depth,
    });
    if let (Splats::Surfels(_), Method::Levelset) = (&g, method) {
        return Err(usage(
            "--method levelset needs 3D Gaussians: 2DGS surfels are flat discs with no density \
             level set; use --method depth (their rendered surface, the default) or centers",
        ));
    }
    let views = sample_cameras(&args, g.means(), cam_path.as_deref(), orbit.as_ref())?;
    check_seen(&args, &g, &views, &scene)?;
    let pb = args.common.progress(views.cams.len() as u64, "views");
    let point_method = match method {
        Method::Levelset => PointMethod::Levelset(LevelsetOptions {
            levels: args.level.clone(),
            max_points: args.max_points,
            min_opacity: args.min_opacity,
            depth: args.depth.source(),
            seed: args.seed,
            near: args.near,
            filter_2d,
            ..Default::default()
        }),
        Method::Centers => PointMethod::Centers {
            min_opacity: args.min_opacity,
            near: args.near,
        },
        Method::Depth => PointMethod::Depth {
            max_points: args.max_points,
            seed: args.seed,
            near: args.near,
            filter_2d,
        },
    };
    let points = match &g {
        Splats::Gaussians(g) => splat_to_points(g, &views.cams, &point_method, |_| pb.inc(1))?,
        Splats::Surfels(s) => surfels_to_points(s, &views.cams, &point_method, |_| pb.inc(1))?,
    };
    pb.finish_and_clear();
    let n = points.positions.len();
    if n == 0 {
        return Err(no_points_error(&args, method, &scene, &views.source));
    }
    let pc = to_point_cloud(points, args.provenance);
    save_points(&args.output, &pc, Format::BinaryLittleEndian)?;
    report(&args, (method, filter_2d), &scene, &g, &views, n, t0)
}

/// The splats points are made from, activated.
enum Splats {
    Gaussians(Gaussians3),
    Surfels(Surfels2),
}

impl Splats {
    fn means(&self) -> &[[f32; 3]] {
        match self {
            Splats::Gaussians(g) => &g.means,
            Splats::Surfels(s) => &s.means,
        }
    }

    fn opacities(&self) -> &[f32] {
        match self {
            Splats::Gaussians(g) => &g.opacities,
            Splats::Surfels(s) => &s.opacities,
        }
    }

    /// "Gaussians" or "surfels", for messages and the report.
    fn noun(&self) -> &'static str {
        match self {
            Splats::Gaussians(_) => "Gaussians",
            Splats::Surfels(_) => "surfels",
        }
    }
}

/// The scene file as activated splats: 3DGS Gaussians, or 2DGS surfels
/// (refused with a NaN or infinite value, naming the surfel and property),
/// and whether a `filter_3D` property was baked into the Gaussians.
fn load_splats(scene: &Path) -> anyhow::Result<(Splats, bool)> {
    let name = shown(scene, false);
    let accepts = [SceneKind::Gaussians, SceneKind::Surfels];
    Ok(
        match load_kinds(scene, "splat2points", &accepts)
            .with_context(|| format!("reading {name}"))?
        {
            Scene::Gaussians(g) => {
                let (g, filtered) =
                    crate::model::filter3d::baked_for_rendering(g).map_err(|e| e.in_file(&name))?;
                (Splats::Gaussians(g.to_raster()), filtered)
            }
            Scene::Surfels(s) => {
                crate::io::ply::surfels::check_finite(&name, &s)?;
                (Splats::Surfels(s.to_raster()), false)
            }
            _ => unreachable!("load_kinds returns an accepted kind"),
        },
    )
}

/// The scene's Gaussian PLY, the camera file (`--cameras`, else a model
/// folder's `cameras.json`) and, without one, the `--orbit` (checked with
/// its image buffers against the memory budget before the scene is read).
fn resolve_inputs(
    args: &Splat2PointsArgs,
) -> anyhow::Result<(PathBuf, Option<PathBuf>, Option<OrbitSpec>)> {
    let (scene, default_cams) = if args.scene.is_dir() {
        let (p, c) = resolve_model_folder(&args.scene, args.iteration)?;
        (p, Some(c))
    } else {
        (args.scene.clone(), None)
    };
    let cam_path = args.cameras.clone().or(default_cams);
    if cam_path.is_some() && args.orbit.orbit.is_some() {
        return Err(usage(
            "give either a camera file (--cameras or a model folder) or --orbit, not both",
        ));
    }
    // The orbit flags are checked before the scene is read.
    let orbit = match (&cam_path, args.orbit.orbit) {
        (None, Some(n)) => Some(args.orbit.spec(n)?),
        _ => None,
    };
    // The orbit's image buffers are a flag's: refused before the scene is read.
    if let Some(spec) = &orbit {
        check_image_budget(
            SizeFrom::Flag(&format!("--size {}", args.orbit.size)),
            "the depth and sampling buffers of one view",
            (u64::from(spec.width) * u64::from(spec.height))
                .saturating_mul(SPLAT2POINTS_BYTES_PER_PIXEL),
        )?;
    }
    Ok((scene, cam_path, orbit))
}

/// The cameras points are made from.
struct Views {
    /// The cameras sampled (the training views of a camera file).
    cams: Vec<Camera>,
    /// The cameras before the test views were held out.
    n_all: usize,
    /// Where they come from, for messages: the camera file, or the orbit.
    source: String,
}

/// The cameras to sample from: the camera file's training views (test
/// views held out unless `--all-views`), or the `orbit` around the
/// Gaussians' centres; each a pinhole, a camera file's largest view within
/// the memory budget.
fn sample_cameras(
    args: &Splat2PointsArgs,
    means: &[[f32; 3]],
    cam_path: Option<&Path>,
    orbit: Option<&OrbitSpec>,
) -> anyhow::Result<Views> {
    let (cams, n_all, cam_source) = match (cam_path, args.orbit.orbit) {
        (Some(p), _) => {
            let all =
                read_cameras(p).with_context(|| format!("reading cameras {}", p.display()))?;
            let n_all = all.len();
            let keep = training_views(
                all,
                if args.all_views {
                    0
                } else {
                    args.every_nth_test
                },
            );
            (keep, n_all, p.display().to_string())
        }
        (None, Some(_)) => {
            let spec = orbit.expect("checked above");
            let cams = orbit_rings(means, spec).with_context(|| {
                format!(
                    "{}: no usable --orbit around this scene (check its coordinates, or give \
                     --radius or --cameras)",
                    shown(&args.scene, false)
                )
            })?;
            let n_all = cams.len();
            (cams, n_all, format!("orbit ({n_all} views)"))
        }
        (None, None) => {
            return Err(usage(
                "give --cameras, a 3DGS model folder holding cameras.json, or --orbit N for made-up views",
            ));
        }
    };
    if cams.is_empty() {
        bail!("no cameras left after holding out test views (use --all-views)");
    }
    for c in &cams {
        c.require_pinhole()
            .map_err(|e| anyhow::anyhow!("camera {:?}: {e}", c.name))?;
    }
    if let Some(p) = cam_path {
        check_image_budget(
            SizeFrom::File(p),
            &format!(
                "the depth and sampling buffers of a {} view",
                largest_size(&cams)
            ),
            splat2points_image_bytes(&cams),
        )?;
    }
    Ok(Views {
        cams,
        n_all,
        source: cam_source,
    })
}

/// Nothing to sample from, said before any work: no Gaussian (surfel) with
/// opacity above `--min-opacity`, or none of them seen by a camera.
fn check_seen(
    args: &Splat2PointsArgs,
    g: &Splats,
    views: &Views,
    scene: &Path,
) -> anyhow::Result<()> {
    let (cams, cam_source) = (&views.cams, &views.source);
    let noun = g.noun();
    let opaque = g
        .opacities()
        .iter()
        .filter(|&&o| o > args.min_opacity)
        .count();
    if opaque == 0 {
        bail!(
            "{}: none of its {} {noun} has opacity above --min-opacity {}: no points to make",
            shown(scene, false),
            g.means().len(),
            args.min_opacity
        );
    }
    if seen_by_any(g.means(), g.opacities(), cams, args.min_opacity, args.near) == 0 {
        bail!(
            "none of the {} cameras ({cam_source}) sees any of the {opaque} opaque {noun} \
             of {} (check that the cameras belong to this scene: axes, units, world up)",
            cams.len(),
            shown(scene, false)
        );
    }
    Ok(())
}

/// The error of a run that made no point, with the method's likely cause.
fn no_points_error(
    args: &Splat2PointsArgs,
    method: Method,
    scene: &Path,
    cam_source: &str,
) -> anyhow::Error {
    anyhow::anyhow!(
        "{}: no points: {} (cameras {cam_source}); nothing written",
        shown(scene, false),
        match method {
            Method::Levelset => format!(
                "no ray crossed the level(s) --level {} (try a lower --level or --depth median)",
                args.level
                    .iter()
                    .map(|l| l.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            ),
            Method::Centers => "no opaque splat centre is seen by a camera".to_string(),
            Method::Depth => "no view has a pixel with depth".to_string(),
        }
    )
}

/// The human summary (stderr) and the JSON report: `n` points written
/// from `views`, seconds since `t0`.
fn report(
    args: &Splat2PointsArgs,
    (method, filter_2d): (Method, Filter2d),
    scene: &Path,
    g: &Splats,
    views: &Views,
    n: usize,
    t0: std::time::Instant,
) -> anyhow::Result<()> {
    let (n_all, cam_source) = (views.n_all, &views.source);
    let views = views.cams.len();
    let count = g.means().len();
    args.common.say(format!(
        "splat2points: {count} {}, {} of {n_all} views -> {n} points ({method:?}, {:.1} s)",
        g.noun(),
        views,
        t0.elapsed().as_secs_f64()
    ));
    let mut report = json!({
        "scene": shown(scene, false),
        "cameras": cam_source,
        "views": views,
        "views_total": n_all,
        "points": n,
        "method": format!("{method:?}").to_lowercase(),
        "depth": (method == Method::Levelset).then(|| format!("{:?}", args.depth).to_lowercase()),
        "levels": args.level,
        "filter_2d": crate::model::filter3d::filter_2d_label(filter_2d),
        "output": shown(&args.output, true),
        "seconds": t0.elapsed().as_secs_f64(),
    });
    report[g.noun().to_lowercase()] = json!(count);
    args.common.emit_json(&report)?;
    Ok(())
}
