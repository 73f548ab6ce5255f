//! `train`: Triangle Splatting ([`crate::train::triangles`]) and 3DGS with
//! SuGaR's coarse regularisation ([`crate::train::gaussians`]) from a DATA
//! folder of photos and cameras ([`crate::io::dataset`]), on the CPU.
//!
//! OUT_DIR receives (all at the end, through a staging folder, so a failed
//! or interrupted run never leaves a half-written folder and a failed
//! `--resume` leaves the old one as it was):
//! - triangles: `point_cloud/iteration_N/point_cloud_state_dict.pt` (the
//!   reference's checkpoint, which its `create_off.py` reads) and
//!   `point_cloud/iteration_N/triangles.ply` (splatkit's soup PLY);
//! - gaussians: `point_cloud/iteration_N/point_cloud.ply` (the standard
//!   3DGS PLY, so `splat2points OUT_DIR` and 3DGS viewers take the folder);
//! - both: `cameras.json` (the training cameras, at the training
//!   resolution), `cfg_args` (3DGS's argparse Namespace), `input.ply` (the
//!   initial points), `metrics.json` (held-out PSNR / SSIM at the start,
//!   every `--eval-every` iterations and at the end, timings, settings) and
//!   `checkpoint/` (`model.ply`, `optimizer.bin` with Adam moments and the
//!   densification statistics, `state.json`) that `--resume OUT_DIR`
//!   continues from bit for bit.
//!
//! Initial points: the data's (COLMAP `points3D`, a 3DGS folder's
//! `input.ply`); otherwise `--init-points` random points (default 100,000)
//! uniform in a cube about the point the training cameras look at (the
//! least-squares meeting point of their optical axes; half-size half their
//! mean distance to it), grey (127/255, what 3DGS's and Triangle
//! Splatting's readers make of their random colours), from `--seed` — the
//! references' rule for synthetic scenes (a fixed ±1.3 cube), made
//! scale-free.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::{Value, json};

use crate::cli::{Common, shown, usage};
use crate::io::StagedDir;
use crate::io::any::{
    load_gaussians_finite, load_soup_finite, save_gaussians, save_points, save_soup,
};
use crate::io::cameras::gs_json::write_gs_json;
use crate::io::checkpoint;
use crate::io::dataset::{Dataset, DatasetOptions, MaskMode, load_dataset};
use crate::io::detect::FileFormat;
use crate::model::rng::seeded;
use crate::model::{Camera, PointCloud, TriangleSoup, rig};
use crate::train::gaussians::init::{grey_seeds, init_gaussians, random_points};
use crate::train::gaussians::{GaussianParams, GaussianTrainer, Regularize};
use crate::train::photometric::Eval;
use crate::train::session::{self, Event, Outcome};
use crate::train::trainer::Trainer;
use crate::train::triangles::init::{InitParams, init_triangles};
use crate::train::triangles::{Preset, TriangleParams, TriangleTrainer};

/// Arguments of `train`.
#[derive(Args, Debug, Clone)]
pub struct TrainArgs {
    #[command(subcommand)]
    pub model: TrainModel,
}

/// Which model to train.
#[derive(Subcommand, Debug, Clone)]
pub enum TrainModel {
    /// Triangle Splatting (MCMC densification; optional game-engine phase).
    #[command(after_help = "Examples:
  train triangles scene/ -o run/ --outdoor --iterations 30000 \\
      --max-shapes 500000
  train triangles dtu_scan24/ -o run/ --indoor --downscale 4 \\
      --max-shapes 200000
  train triangles scene/ -o run/ --game-engine
  train triangles scene/ -o run/ --iterations 30000 --resume run/
  train triangles scene/ -o run/ --iterations 7000 --schedule reference

Outputs in OUT_DIR: point_cloud/iteration_N/{point_cloud_state_dict.pt,
triangles.ply}, cameras.json, cfg_args, input.ply, metrics.json, checkpoint/.")]
    Triangles(TriangleArgs),
    /// 3DGS, optionally with SuGaR's coarse regularisation.
    #[command(after_help = "Examples:
  # vanilla 3DGS, 30000 iterations
  train gaussians scene/ -o run/
  # SuGaR coarse, 15000 iterations
  train gaussians scene/ -o run/ --regularize density
  train gaussians dtu_scan24/ -o run/ --regularize sdf --downscale 4
  train gaussians scene/ -o run/ --iterations 7000 --schedule reference
  splatkit splat2points run/ -o - | splatkit poisson - -o mesh.ply

Outputs in OUT_DIR: point_cloud/iteration_N/point_cloud.ply, cameras.json,
cfg_args, input.ply, metrics.json, checkpoint/.")]
    Gaussians(GaussianArgs),
}

/// What both models take.
#[derive(Args, Debug, Clone)]
pub struct DataArgs {
    /// DATA folder: COLMAP (images/ + sparse/0), 3DGS (cameras.json +
    /// images/), NeRF (transforms_train.json) or DTU (cameras_sphere.npz +
    /// image/ + mask/).
    pub data: PathBuf,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Iterations (default 30000; 15000 for SuGaR's coarse stage). With
    /// the default `--schedule scaled`, every milestone of the reference
    /// schedule (densification start, interval and end, SH bands, learning
    /// rate decay, later phases) is multiplied by N / 30000 (N / 15000 for
    /// SuGaR), so a short run goes through the whole course.
    #[arg(long)]
    pub iterations: Option<u64>,
    /// `scaled`: milestones scaled to --iterations (above); `reference`:
    /// at the reference's iteration numbers whatever --iterations is, as
    /// 3DGS's, Triangle Splatting's and OpenSplat's own iteration counts
    /// behave (a shorter run is the start of the full course).
    #[arg(long, value_enum, default_value_t = ScheduleArg::Scaled)]
    pub schedule: ScheduleArg,
    /// Divide the cameras' resolution by this integer.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64), conflicts_with = "resolution")]
    pub downscale: u32,
    /// Train at about this image width (the integer downscale that brings
    /// the widest camera to at most this).
    #[arg(long, value_name = "WIDTH", value_parser = clap::value_parser!(u32).range(1..))]
    pub resolution: Option<u32>,
    /// Require masks (the data's mask folder); default: use them when present.
    #[arg(long, conflicts_with = "no_masks")]
    pub masks: bool,
    /// Ignore masks even when the data has them.
    #[arg(long)]
    pub no_masks: bool,
    /// White background (also the colour transparent photos are put on).
    #[arg(long)]
    pub white_background: bool,
    /// A random background colour every iteration (photos with an alpha
    /// channel, e.g. NeRF synthetic, are put on it; evaluation uses the
    /// fixed background).
    #[arg(long)]
    pub random_background: bool,
    /// Hold out every N-th view (camera order, from the first); 0 = none
    /// (1 would hold out all).
    #[arg(long, default_value_t = 8, value_parser = crate::cli::holdout_every)]
    pub test_every: usize,
    /// Evaluate the held-out views every N iterations (0: start and end).
    #[arg(long, default_value_t = 1000)]
    pub eval_every: u64,
    /// Print every densification step on stderr (iteration, strategy,
    /// primitives before → after, the counts behind it).
    #[arg(short, long, conflicts_with = "quiet")]
    pub verbose: bool,
    /// Random initial points when the data has none (1 to 2^40; `1e6`
    /// notation accepted); refused beyond the memory budget.
    #[arg(long, default_value_t = 100_000, value_parser = count_arg)]
    pub init_points: usize,
    /// Continue the run saved in this folder (its checkpoint/).
    #[arg(long, value_name = "DIR")]
    pub resume: Option<PathBuf>,
    /// Stop after this iteration and write everything (a planned
    /// interruption: `--resume` then continues the same --iterations run).
    #[arg(long, value_name = "N")]
    pub stop_at: Option<u64>,
    /// Seed of the view order, initialisation and densification.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The highest spherical-harmonics band trained, 0 to 3 (3DGS's and
    /// Triangle Splatting's `--sh_degree`): 0 gives view-independent
    /// colour. The files keep the 3-band layout with the bands above N at
    /// zero, so every reader renders them as degree N.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(0..=3))]
    pub sh_degree: u8,
    #[command(flatten)]
    pub common: Common,
}

/// `train triangles`.
#[derive(Args, Debug, Clone)]
pub struct TriangleArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Indoor preset of the supplement's Table 1.
    #[arg(long, conflicts_with = "outdoor")]
    pub indoor: bool,
    /// Outdoor preset (the default).
    #[arg(long)]
    pub outdoor: bool,
    /// The game-engine variant: the final phase pushes σ → 0 and opacity
    /// → 1 with rising pruning thresholds.
    #[arg(long)]
    pub game_engine: bool,
    /// Most triangles the model may hold (at least 1; the initial triangles,
    /// one per initial point, must fit).
    #[arg(long, default_value_t = 4_000_000,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    pub max_shapes: usize,
    /// Add the dome of extra seeds (outdoor scenes).
    #[arg(long)]
    pub dome: bool,
    /// Draw triangles whose projected inradius is at least this many
    /// pixels, in (0, 1] (Triangle Splatting's kernel: 1). Lower values
    /// help low-resolution photos, where the kernel's rule drops the
    /// triangles seen edge-on at the silhouette; render such a model with
    /// `render --min-inradius` of the same value.
    #[arg(long, default_value_t = 1.0, value_name = "PX",
          value_parser = crate::cli::min_inradius_arg)]
    pub min_inradius: f64,
    /// Weight λ_o of the opacity regulariser λ_o·mean(opacity), the
    /// reference's `--lambda_opacity` (default 0.0055). 0 switches it off:
    /// on low-resolution photos without initial points that trains more,
    /// more opaque triangles that generalise better (docs/train.md,
    /// "Random initial points").
    #[arg(long, value_name = "W", allow_hyphen_values = true,
          value_parser = crate::cli::nonneg_f64)]
    pub lambda_opacity: Option<f64>,
}

/// How milestones follow `--iterations`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ScheduleArg {
    Scaled,
    Reference,
}

/// SuGaR's regularisers on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum RegularizeArg {
    Density,
    Sdf,
    DnConsistency,
}

/// `train gaussians`.
#[derive(Args, Debug, Clone)]
pub struct GaussianArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// SuGaR's coarse stage with this surface regulariser.
    #[arg(long, value_enum)]
    pub regularize: Option<RegularizeArg>,
    /// Regulariser samples per iteration (SuGaR: 1,000,000; 1 to 2^40,
    /// `1e6` notation accepted); refused beyond the memory budget.
    #[arg(long, default_value_t = 50_000, value_parser = count_arg)]
    pub samples: usize,
}

/// The largest count `--init-points` and `--samples` accept (2^40): far
/// beyond any memory, so a larger value is a typo.
pub const MAX_COUNT: u64 = 1 << 40;

/// Bytes of training state per primitive made from an initial point: the
/// parameters of a Gaussian or triangle with SH degree 3 (59 f32), their
/// gradients and two Adam moments (× 4 = 944), the per-view projection and
/// densification statistics (80), and the initial point itself (position,
/// normal, colour: 32 with padding).
pub const BYTES_PER_INIT_POINT: u64 = 944 + 80 + 32;

/// Bytes per regulariser sample of one iteration: the sample (point 12,
/// owner 4, ε 12) and the density terms over SuGaR's 16 neighbours (f64
/// value and f32 weight each, 16 × 12 = 192), plus 64 for the gradient
/// scatter.
pub const BYTES_PER_SAMPLE: u64 = 28 + 192 + 64;

/// Bytes per pixel of one training step's buffers for the view it trains
/// on (beyond the photos, which [`crate::io::dataset::VIEW_BYTES_PER_PIXEL`]
/// counts): the render (52 of output + 12 working), the L1 and SSIM
/// gradients (SSIM in f64 per channel, the three in parallel: two images,
/// five blurred moments, three partials and their blurs, a gradient and a
/// temporary, 15 × 8 = 120 per channel, 360, plus 12 + 12 of f32 results),
/// the backward pass's image gradients (colour 12, alpha 4, depth 4, normal
/// 12) and the regularisers' depth and normal maps (48).
pub const TRAIN_BYTES_PER_PIXEL: u64 = 64 + 384 + 32 + 48;

/// Parses a count flag: a whole number from 1 to [`MAX_COUNT`], written
/// plainly or in `1e6` notation (clap value parser: exit 2 otherwise).
fn count_arg(s: &str) -> Result<usize, String> {
    let t = s.trim();
    let v = match t.parse::<u64>() {
        Ok(v) => v,
        Err(_) => {
            let f: f64 = t
                .parse()
                .map_err(|_| format!("{s:?} is not a whole number"))?;
            if !(f.is_finite() && f.fract() == 0.0 && f >= 0.0) {
                return Err(format!("{s} is not a whole number"));
            }
            if f > MAX_COUNT as f64 {
                return Err(format!("{s} is more than the limit of {MAX_COUNT} (2^40)"));
            }
            f as u64
        }
    };
    if v == 0 || v > MAX_COUNT {
        return Err(format!("{s} is not in 1..={MAX_COUNT}"));
    }
    usize::try_from(v).map_err(|_| format!("{s} is too large for this machine"))
}

fn mkdir(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))
}

/// `train` entry point.
pub fn run(args: TrainArgs) -> anyhow::Result<()> {
    // every step frees and reallocates the same large buffers
    let _ = crate::cli::memory::keep_freed_memory();
    match args.model {
        TrainModel::Triangles(a) => run_triangles(a),
        TrainModel::Gaussians(a) => run_gaussians(a),
    }
}

/// The loaded data, split and initial points.
struct Prepared {
    data: Dataset,
    train: Vec<usize>,
    test: Vec<usize>,
    points: PointCloud,
    random_init: bool,
    extent: f64,
}

fn prepare(a: &DataArgs) -> anyhow::Result<Prepared> {
    // a flag's size: refused before the data is read
    crate::io::budget::check(
        &format!(
            "--init-points {}: the initial primitives and their training state",
            a.init_points
        ),
        (a.init_points as u64).saturating_mul(BYTES_PER_INIT_POINT),
    )
    .map_err(|e| usage(e.to_string()))?;
    let opts = DatasetOptions {
        downscale: a.downscale,
        resolution: a.resolution,
        masks: if a.masks {
            MaskMode::On
        } else if a.no_masks {
            MaskMode::Off
        } else {
            MaskMode::Auto
        },
        background: if a.white_background {
            [1.0; 3]
        } else {
            [0.0; 3]
        },
        work_bytes_per_pixel: TRAIN_BYTES_PER_PIXEL,
    };
    let data = load_dataset(&a.data, &opts).with_context(|| match a.resolution {
        // the downscale the message may name is the one --resolution implies
        Some(w) => format!("{} at --resolution {w}", a.data.display()),
        None => format!("{} at --downscale {}", a.data.display(), a.downscale),
    })?;
    check_masks_cover(&data)?;
    let (train, test) = session::prepare_split(data.views.len(), a.test_every)
        .map_err(|m| anyhow::anyhow!("{}: {m}", a.data.display()))?;
    let centres: Vec<[f64; 3]> = train
        .iter()
        .map(|&i| data.views[i].camera.center().to_array())
        .collect();
    // 3DGS's getNerfppNorm; 1 when the centres coincide
    let extent = rig::nerfpp_radius(&centres).unwrap_or(1.0);
    let (points, random_init) = match &data.points {
        Some(p) if p.len() >= 2 => (p.clone(), false),
        _ => {
            let cams: Vec<&Camera> = train.iter().map(|&i| &data.views[i].camera).collect();
            let (lo, hi) = init_box(&cams);
            // grey, as 3DGS's and Triangle Splatting's readers make their
            // random points (gaussians::init::grey_seeds)
            let pts = random_points(a.init_points, lo, hi, &mut seeded(a.seed));
            (grey_seeds(&pts), true)
        }
    };
    Ok(Prepared {
        data,
        train,
        test,
        points,
        random_init,
        extent,
    })
}

/// Refuses a view whose mask has no object pixel: its loss and its
/// held-out PSNR / SSIM would be taken over 0 pixels (`null` and 1.0), so
/// the run and its metrics would mean nothing. Names the view and its photo.
fn check_masks_cover(data: &Dataset) -> anyhow::Result<()> {
    for v in &data.views {
        if let Some(m) = &v.mask
            && !m.iter().any(|&b| b)
        {
            bail!(
                "{}: the mask of view {:?} ({}) has no object pixel (all zero): its loss and \
                 metrics would cover 0 pixels (--no-masks ignores the masks)",
                data.root.display(),
                v.camera.name,
                v.source
            );
        }
    }
    Ok(())
}

/// The file the initial points came from, for messages: the data's
/// `input.ply` / `points3D.*`, or `--init-points` random points.
fn points_source(p: &Prepared, a: &DataArgs) -> String {
    if p.random_init {
        return format!("the {} random --init-points", a.init_points);
    }
    let dir = if p.data.cameras_file.is_dir() {
        p.data.cameras_file.clone()
    } else {
        p.data.root.clone()
    };
    ["input.ply", "points3D.bin", "points3D.txt", "points3D.ply"]
        .iter()
        .map(|n| dir.join(n))
        .find(|f| f.is_file())
        .map_or_else(
            || format!("the initial points of {}", p.data.root.display()),
            |f| f.display().to_string(),
        )
}

/// The box random initial points fill: a cube centred on the cameras'
/// focus ([`rig::focus`], what they look at) with half-size half the mean
/// camera distance to it (the unit cube about a NeRF-synthetic object seen
/// from 4 units, the unit sphere of a NeuS-normalised DTU scan). Cameras
/// all looking the same way (no focus) fall back to the bounding box of
/// their centres.
fn init_box(cams: &[&Camera]) -> ([f64; 3], [f64; 3]) {
    use glam::DVec3;
    let Some(f) = rig::focus(cams.iter().copied()) else {
        let centres: Vec<[f64; 3]> = cams.iter().map(|c| c.center().to_array()).collect();
        return bounding_box(&centres);
    };
    let h = 0.5 * f.mean_distance;
    (
        (f.point - DVec3::splat(h)).to_array(),
        (f.point + DVec3::splat(h)).to_array(),
    )
}

fn bounding_box(centres: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in centres {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    // a flat rig (all cameras in a plane) still gets a volume
    let span = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max).max(1e-3);
    for k in 0..3 {
        if hi[k] - lo[k] < 0.5 * span {
            let m = 0.5 * (hi[k] + lo[k]);
            lo[k] = m - 0.25 * span;
            hi[k] = m + 0.25 * span;
        }
    }
    (lo, hi)
}

/// The checkpoint read for `--resume`, which must be of a `train {kind}`
/// run (`kind` is "triangles" or "gaussians").
fn read_checkpoint(dir: &Path, kind: &str) -> anyhow::Result<checkpoint::Saved> {
    let saved = checkpoint::read(dir)?;
    let got = saved
        .state
        .get("model")
        .and_then(Value::as_str)
        .unwrap_or("");
    if got != kind {
        bail!(
            "{}: the checkpoint is of a {} run, not `train {kind}` (resume with the same model)",
            dir.display(),
            if got.is_empty() { "non-`train`" } else { got }
        );
    }
    Ok(saved)
}

/// The training session of `t` ([`session::run`]), with a progress bar.
fn train_loop(
    t: &mut dyn Trainer,
    p: &Prepared,
    a: &DataArgs,
    iterations: u64,
    evals: Vec<Eval>,
    label: &'static str,
) -> anyhow::Result<Outcome> {
    let views = session::Views {
        all: &p.data.views,
        train: &p.train,
        test: &p.test,
    };
    let schedule = session::Schedule {
        iterations,
        stop_at: a.stop_at,
        eval_every: a.eval_every,
    };
    let mut bar = a.common.loop_bar(label);
    let r = session::run(t, views, schedule, evals, label, &mut |e| match e {
        Event::Start { start, end } => bar.start(end - start),
        Event::Step { iteration, .. } => bar.step(iteration, || e.status()),
        Event::Edit(edit) if a.verbose => bar.println(&edit.to_string()),
        Event::Edit(_) | Event::Eval(_) => {}
    });
    bar.finish();
    Ok(r?)
}

/// cfg_args as 3DGS writes it (a Python Namespace repr).
fn cfg_args(a: &DataArgs, sh_degree: usize) -> String {
    let py = |b: bool| if b { "True" } else { "False" };
    format!(
        "Namespace(data_device='cpu', eval={}, images='images', model_path={:?}, resolution={}, \
         sh_degree={sh_degree}, source_path={:?}, white_background={})",
        py(a.test_every > 0),
        a.output.display().to_string(),
        a.resolution.map_or(-1, |w| w as i64),
        a.data.display().to_string(),
        py(a.white_background)
    )
}

/// Writes the files both models share and the checkpoint; returns the
/// metrics JSON.
fn write_common(
    dir: &Path,
    a: &DataArgs,
    p: &Prepared,
    t: &dyn Trainer,
    f: &Finished,
) -> anyhow::Result<Value> {
    let Finished {
        kind,
        settings,
        outcome: r,
        sh_degree,
        t0,
    } = *f;
    let cams: Vec<Camera> = p.data.views.iter().map(|v| v.camera.clone()).collect();
    write_gs_json(&dir.join("cameras.json"), &cams)?;
    checkpoint::write_bytes(&dir.join("cfg_args"), cfg_args(a, sh_degree).as_bytes())?;
    save_points(
        &dir.join("input.ply"),
        &p.points,
        crate::io::ply::header::Format::BinaryLittleEndian,
    )?;
    let (step, groups) = t.optimizer_state();
    let state = json!({"format": "splatkit-train-checkpoint-1", "model": kind, "iteration": step,
                       "settings": settings, "evals": r.evals});
    checkpoint::write(dir, step, &groups, &state)?;
    let done = r.done(t);
    let v0 = &p.data.views[0].camera;
    let summary = json!({
        "model": kind,
        "data": shown(&a.data, false),
        "data_format": p.data.format,
        "output": shown(&a.output, false),
        "primitives": t.count(),
        "initial_points": p.points.len(),
        "random_init": p.random_init,
        "train_views": p.train.len(),
        "test_views": p.test.len(),
        "width": v0.width,
        "height": v0.height,
        "iterations": t.iteration(),
        "iterations_this_run": done,
        "seconds": t0.elapsed().as_secs_f64(),
        "loop_seconds": r.loop_s,
        "iterations_per_second": r.rate(t),
        "final_loss": r.last_loss,
        "evals": r.evals,
        "settings": settings,
    });
    checkpoint::write_json(&dir.join("metrics.json"), &summary)?;
    Ok(summary)
}

/// What a finished session leaves for [`write_common`].
#[derive(Clone, Copy)]
struct Finished<'a> {
    /// "triangles" or "gaussians".
    kind: &'static str,
    /// The settings a resumed run must match.
    settings: &'a Value,
    outcome: &'a Outcome,
    sh_degree: usize,
    /// When the command started.
    t0: std::time::Instant,
}

/// Refuses a checkpoint already past `--iterations`.
fn check_not_past(t: &dyn Trainer, iterations: u64) -> anyhow::Result<()> {
    if t.iteration() > iterations {
        bail!(
            "the checkpoint is at iteration {} already, past --iterations {iterations}",
            t.iteration()
        );
    }
    Ok(())
}

/// The initial soup of a fresh triangle run (one triangle per point, and
/// the dome's); refused when it exceeds `--max-shapes`.
fn init_soup(args: &TriangleArgs, p: &Prepared) -> anyhow::Result<TriangleSoup> {
    let a = &args.data;
    let init = InitParams {
        dome: args.dome,
        ..Default::default()
    };
    let soup = init_triangles(&p.points, &init, &mut seeded(a.seed))
        .with_context(|| format!("initialising from {}", points_source(p, a)))?;
    if soup.len() > args.max_shapes {
        return Err(crate::cli::usage(format!(
            "--max-shapes {} is below the {} initial triangles (one per point of {}{})",
            args.max_shapes,
            soup.len(),
            points_source(p, a),
            if args.dome {
                " and the --dome seeds"
            } else {
                ""
            }
        )));
    }
    Ok(soup)
}

/// The soup in Triangle Splatting's layout (`point_cloud/iteration_N/`:
/// the state dict and the PLY) and as the checkpoint's model.
fn write_soup(dir: &Path, model: &TriangleSoup, iteration: u64) -> anyhow::Result<()> {
    let it_dir = dir.join(format!("point_cloud/iteration_{iteration}"));
    mkdir(&it_dir)?;
    mkdir(&dir.join(checkpoint::DIR))?;
    save_soup(
        &it_dir.join("point_cloud_state_dict.pt"),
        model,
        FileFormat::TorchPt,
    )?;
    save_soup(&it_dir.join("triangles.ply"), model, FileFormat::Ply)?;
    save_soup(
        &dir.join(checkpoint::DIR).join(checkpoint::MODEL),
        model,
        FileFormat::Ply,
    )?;
    Ok(())
}

fn report(
    a: &DataArgs,
    kind: &str,
    summary: &Value,
    r: &Outcome,
    count: usize,
) -> anyhow::Result<()> {
    let done = summary["iterations_this_run"].as_u64().unwrap_or(0);
    match (r.evals.first(), r.evals.last()) {
        (Some(f), Some(l)) => a.common.say(format!(
            "train {kind}: {count} primitives, {done} iterations in {:.1} s ({:.2} it/s); held-out \
             PSNR {:.2} -> {:.2} dB, SSIM {:.4} -> {:.4} -> {}",
            r.loop_s,
            done as f64 / r.loop_s.max(1e-9),
            f.psnr,
            l.psnr,
            f.ssim,
            l.ssim,
            a.output.display()
        )),
        _ => a.common.say(format!(
            "train {kind}: {count} primitives, {done} iterations in {:.1} s -> {}",
            r.loop_s,
            a.output.display()
        )),
    }
    let mut compact = summary.clone();
    if let Some(o) = compact.as_object_mut() {
        o.remove("settings");
    }
    a.common.emit_json(&compact)
}

fn background(a: &DataArgs) -> [f32; 3] {
    if a.white_background {
        [1.0; 3]
    } else {
        [0.0; 3]
    }
}

fn names(p: &Prepared) -> Vec<String> {
    p.data.views.iter().map(|v| v.camera.name.clone()).collect()
}

fn check_resume(ck: &checkpoint::Saved, settings: &Value, dir: &Path) -> anyhow::Result<Vec<Eval>> {
    let name = ck.state_file.display().to_string();
    session::resume_evals(&ck.state, settings, &name).map_err(|e| match e {
        Some(m) => anyhow::anyhow!(m),
        None => anyhow::anyhow!(
            "{}: the checkpoint was made with other settings or data (DATA, --iterations, \
             --downscale/--resolution, masks, --test-every, --white-background, --seed and the \
             model options must match the first run)",
            dir.display()
        ),
    })
}

fn run_triangles(args: TriangleArgs) -> anyhow::Result<()> {
    let a = &args.data;
    a.common.init()?;
    let t0 = std::time::Instant::now();
    let iterations = a.iterations.unwrap_or(30_000);
    let stage = StagedDir::new(&a.output)?;
    let p = prepare(a)?;
    let preset = if args.indoor {
        Preset::Indoor
    } else {
        Preset::Outdoor
    };
    let mut params = TriangleParams::preset(preset, iterations);
    params.game_engine = args.game_engine;
    params.mcmc.max_shapes = args.max_shapes;
    params.min_inradius = args.min_inradius;
    if let Some(w) = args.lambda_opacity {
        params.lambda_opacity = w;
    }
    params.background = background(a);
    params.random_background = a.random_background;
    params.reference_schedule = a.schedule == ScheduleArg::Reference;
    params.sh_degree = a.sh_degree.into();
    params.seed = a.seed;
    let settings = json!({"params": params, "data": shown(&a.data, false), "views": names(&p),
        "test_every": a.test_every, "masks": p.data.views[0].mask.is_some(), "dome": args.dome,
        "init_points": a.init_points});
    let (mut t, evals) = match &a.resume {
        Some(dir) => {
            let ck = read_checkpoint(dir, "triangles")?;
            let evals = check_resume(&ck, &settings, dir)?;
            let soup = load_soup_finite(&ck.model, "train triangles --resume")?;
            let mut t = TriangleTrainer::new(soup, params);
            t.restore(ck.step, ck.groups)
                .map_err(|m| anyhow::anyhow!("{}: {m}", dir.display()))?;
            (t, evals)
        }
        None => (
            TriangleTrainer::new(init_soup(&args, &p)?, params),
            Vec::new(),
        ),
    };
    check_not_past(&t, iterations)?;
    let r = train_loop(&mut t, &p, a, iterations, evals, "train triangles")?;
    let dir = stage.path().to_path_buf();
    let model = t.model();
    write_soup(&dir, &model, t.iteration())?;
    let finished = Finished {
        kind: "triangles",
        settings: &settings,
        outcome: &r,
        sh_degree: model.sh_degree,
        t0,
    };
    let summary = write_common(&dir, a, &p, &t, &finished)?;
    stage.commit()?;
    report(a, "triangles", &summary, &r, model.len())
}

fn run_gaussians(args: GaussianArgs) -> anyhow::Result<()> {
    let a = &args.data;
    a.common.init()?;
    let t0 = std::time::Instant::now();
    let regularize = args.regularize.map(|r| match r {
        RegularizeArg::Density => Regularize::Density,
        RegularizeArg::Sdf => Regularize::Sdf,
        RegularizeArg::DnConsistency => Regularize::DnConsistency,
    });
    let iterations = a
        .iterations
        .unwrap_or(if regularize.is_some() { 15_000 } else { 30_000 });
    if regularize.is_some() {
        // a flag's size: refused before the data is read
        crate::io::budget::check(
            &format!(
                "--samples {}: the regulariser samples of one iteration",
                args.samples
            ),
            (args.samples as u64).saturating_mul(BYTES_PER_SAMPLE),
        )
        .map_err(|e| usage(e.to_string()))?;
    }
    let stage = StagedDir::new(&a.output)?;
    let p = prepare(a)?;
    let mut params = GaussianParams::new(iterations, regularize, p.extent);
    params.samples = args.samples;
    params.background = background(a);
    params.white_background = a.white_background;
    params.random_background = a.random_background;
    params.reference_schedule = a.schedule == ScheduleArg::Reference;
    params.sh_degree = a.sh_degree.into();
    params.seed = a.seed;
    let settings = json!({"params": params, "data": shown(&a.data, false), "views": names(&p),
        "test_every": a.test_every, "masks": p.data.views[0].mask.is_some(),
        "init_points": a.init_points});
    let (mut t, evals) = match &a.resume {
        Some(dir) => {
            let ck = read_checkpoint(dir, "gaussians")?;
            let evals = check_resume(&ck, &settings, dir)?;
            let g = load_gaussians_finite(&ck.model, "train gaussians --resume")?;
            crate::model::filter3d::refuse_filter_3d(&g, "train")
                .map_err(|e| e.in_file(shown(&ck.model, false)))?;
            let mut t = GaussianTrainer::new(g, params);
            t.restore(ck.step, ck.groups)
                .map_err(|m| anyhow::anyhow!("{}: {m}", dir.display()))?;
            (t, evals)
        }
        None => (
            GaussianTrainer::new(
                init_gaussians(&p.points, 3)
                    .with_context(|| format!("initialising from {}", points_source(&p, a)))?,
                params,
            ),
            Vec::new(),
        ),
    };
    check_not_past(&t, iterations)?;
    let r = train_loop(&mut t, &p, a, iterations, evals, "train gaussians")?;
    let dir = stage.path().to_path_buf();
    let it_dir = dir.join(format!("point_cloud/iteration_{}", t.iteration()));
    mkdir(&it_dir)?;
    mkdir(&dir.join(checkpoint::DIR))?;
    save_gaussians(&it_dir.join("point_cloud.ply"), &t.model)?;
    save_gaussians(&dir.join(checkpoint::DIR).join(checkpoint::MODEL), &t.model)?;
    let finished = Finished {
        kind: "gaussians",
        settings: &settings,
        outcome: &r,
        sh_degree: t.model.sh_degree,
        t0,
    };
    let summary = write_common(&dir, a, &p, &t, &finished)?;
    stage.commit()?;
    report(a, "gaussians", &summary, &r, t.model.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Count flags take plain or `1e6` whole numbers from 1 to 2^40.
    #[test]
    fn count_flags_parse() {
        assert_eq!(count_arg("1e12"), Ok(1_000_000_000_000));
        assert_eq!(count_arg(" 500 "), Ok(500));
        assert_eq!(count_arg("1099511627776"), Ok(1 << 40));
        for bad in [
            "0",
            "2e12",
            "1099511627777",
            "1.5",
            "-3",
            "NaN",
            "inf",
            "x",
            "",
        ] {
            assert!(count_arg(bad).is_err(), "{bad}");
        }
    }
    use crate::testing::cameras_around;

    /// Cameras around a point look at it: the box is centred there with
    /// half-size half their distance; all on one side (as DTU's) the centre
    /// is still found, where the box of the centres would miss it.
    #[test]
    fn init_box_is_centred_on_what_the_cameras_see() {
        let cams = cameras_around(20, 4.0, 32, 40.0);
        let refs: Vec<&Camera> = cams.iter().collect();
        let (lo, hi) = init_box(&refs);
        for k in 0..3 {
            assert!(
                (lo[k] + 2.0).abs() < 1e-9 && (hi[k] - 2.0).abs() < 1e-9,
                "{lo:?} {hi:?}"
            );
        }
        let one_side: Vec<&Camera> = cams.iter().filter(|c| c.center().x > 1.0).collect();
        assert!(one_side.len() >= 3);
        let (lo, hi) = init_box(&one_side);
        assert!((0..3).all(|k| lo[k] < 0.0 && hi[k] > 0.0), "{lo:?} {hi:?}");
        let centres: Vec<[f64; 3]> = one_side.iter().map(|c| c.center().to_array()).collect();
        assert!(
            bounding_box(&centres).0[0] > 0.0,
            "the centres' box misses the origin"
        );
    }
}
