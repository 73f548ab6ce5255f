//! `refine`: SuGaR's refinement of bound Gaussians and their mesh against
//! photos ([`crate::train::refine`]), with held-out evaluation, checkpoints
//! and exact resume.
//!
//! OUT_DIR receives (all at the end, through a staging folder, so a failed
//! or interrupted run never leaves a half-written folder):
//! - `refined_bound.ply`: the refined bound Gaussians (a 3DGS PLY with the
//!   binding and the refined mesh);
//! - `refined_mesh.ply`: the refined mesh (vertex colours of the input);
//! - `metrics.json`: held-out PSNR / SSIM at the start, every
//!   `--eval-every` iterations and at the end, with the run's settings;
//! - `checkpoint/`: `model.ply` (= refined_bound.ply), `optimizer.bin`
//!   (Adam moments per group) and `state.json` (iteration, settings, views),
//!   which `--resume OUT_DIR` continues from bit for bit.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Args;
use serde_json::{Value, json};

use crate::cli::{Common, shown, usage};
use crate::geom::binding::rebind::{ScaleRule, rebind};
use crate::io::StagedDir;
use crate::io::any::{load_bound, load_mesh_finite, save_gaussians, save_mesh};
use crate::io::cameras::read_cameras;
use crate::io::checkpoint;
use crate::io::dataset::check_views_budget;
use crate::io::detect::FileFormat;
use crate::io::ply::bound::attach;
use crate::io::views::{ViewOptions, load_views};
use crate::model::{BoundGaussians, View};
use crate::train::refine::{Eval, LearningRates, RefineParams, Refiner, spatial_lr_scale};
use crate::train::session::{self, Event, Outcome};
use crate::train::trainer::Trainer;

/// Arguments of `refine`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  refine bound.ply --images scene/images --cameras scene/sparse/0 \\
      -o refined/ --short
  refine bound.ply --images dtu/image --masks dtu/mask \\
      --cameras dtu/cameras_sphere.npz --downscale 2 --white-background \\
      -o dtu_refined/
  refine bound.ply --images imgs --cameras cameras.json -o run/ \\
      --iterations 1000
  refine bound.ply --images imgs --cameras cameras.json -o run/ \\
      --iterations 2000 --resume run/

Outputs in OUT_DIR: refined_bound.ply, refined_mesh.ply, metrics.json,
checkpoint/.")]
pub struct RefineArgs {
    /// Bound Gaussians (from `bind-gaussians`, or a previous `refine`).
    pub bound: PathBuf,
    /// Optional mesh with the same faces whose vertices replace the bound
    /// mesh's before refining (the Gaussians are rebound to it).
    pub mesh: Option<PathBuf>,
    /// Folder of the photos (PNG or JPEG), named like the cameras.
    #[arg(long)]
    pub images: PathBuf,
    /// Cameras: COLMAP folder, cameras.json, transforms.json or cameras_sphere.npz.
    #[arg(long)]
    pub cameras: PathBuf,
    /// Folder of masks (object = non-zero): the loss counts only the object.
    #[arg(long)]
    pub masks: Option<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Total iterations (default: --short's 2000).
    #[arg(long, conflicts_with_all = ["short", "medium", "long"])]
    pub iterations: Option<u64>,
    /// SuGaR's short refinement: 2000 iterations.
    #[arg(long, conflicts_with_all = ["medium", "long"])]
    pub short: bool,
    /// SuGaR's medium refinement: 7000 iterations.
    #[arg(long, conflicts_with = "long")]
    pub medium: bool,
    /// SuGaR's long refinement: 15000 iterations.
    #[arg(long)]
    pub long: bool,
    /// Divide the cameras' resolution by this integer (images at full or
    /// divided size are both accepted).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64), conflicts_with = "resolution")]
    pub downscale: u32,
    /// Train at this image width: the cameras' resolution divided by
    /// (camera width / WIDTH), so WIDTH must divide the width of the first
    /// camera in name order (else exit 2). Instead of --downscale.
    #[arg(long, value_name = "WIDTH", value_parser = clap::value_parser!(u32).range(1..))]
    pub resolution: Option<u32>,
    /// White background instead of black.
    #[arg(long)]
    pub white_background: bool,
    /// Hold out every N-th view (name order, from the first) for evaluation;
    /// 0 = none (1 would hold out all).
    #[arg(long, default_value_t = 8, value_parser = crate::cli::holdout_every)]
    pub test_every: usize,
    /// Evaluate the held-out views every N iterations (0: start and end only).
    #[arg(long, default_value_t = 500)]
    pub eval_every: u64,
    /// Weight of the mesh normal-consistency term.
    #[arg(long, default_value_t = 0.1, value_parser = crate::cli::nonneg_f64)]
    pub normal_consistency: f64,
    /// Continue the run saved in this folder (its checkpoint/).
    #[arg(long, value_name = "DIR")]
    pub resume: Option<PathBuf>,
    /// Seed of the view order.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[command(flatten)]
    pub common: Common,
}

/// Bytes per pixel of one refinement step's buffers for the view it trains
/// on (beyond the photos, which [`crate::io::dataset::VIEW_BYTES_PER_PIXEL`]
/// counts): the render (52 of output + 12 working), the L1 and SSIM
/// gradients (SSIM in f64 per channel, the three in parallel, 15 maps × 8 =
/// 120 per channel, 360, plus 12 + 12 of f32 results), the backward pass's
/// image gradients (colour 12, alpha 4, depth 4, normal 12) and the normal
/// consistency's depth-normal map (48).
pub const REFINE_BYTES_PER_PIXEL: u64 = 64 + 384 + 32 + 48;

/// Refuses a view whose mask has no object pixel: its loss and its
/// PSNR / SSIM would be taken over 0 pixels (`null` and 1.0), so the run
/// and its metrics would mean nothing. Names the mask folder and the view.
fn check_masks_cover(views: &[crate::model::View], masks: &std::path::Path) -> anyhow::Result<()> {
    for v in views {
        if let Some(m) = &v.mask
            && !m.iter().any(|&b| b)
        {
            bail!(
                "--masks {}: the mask of view {:?} ({}) has no object pixel (all zero): its loss \
                 and metrics would cover 0 pixels",
                masks.display(),
                v.camera.name,
                v.source
            );
        }
    }
    Ok(())
}

/// `refine` entry point: parse, load, run the training session, write.
pub fn run(args: RefineArgs) -> anyhow::Result<()> {
    args.common.init()?;
    // Every path named as an input is protected, read or not (`--resume`
    // leaves BOUND unread).
    crate::cli::declare_inputs(&[
        Some(args.bound.as_path()),
        args.mesh.as_deref(),
        Some(args.images.as_path()),
        Some(args.cameras.as_path()),
        args.masks.as_deref(),
    ])?;
    // every step frees and reallocates the same large buffers
    let _ = crate::cli::memory::keep_freed_memory();
    let iterations = match (args.iterations, args.medium, args.long) {
        (Some(n), _, _) => n,
        (None, true, _) => 7000,
        (None, _, true) => 15000,
        _ => 2000,
    };
    let stage = StagedDir::new(&args.output)?;
    let t0 = std::time::Instant::now();
    let (model, saved) = load_model(&args)?;
    let (views, downscale) = load_refine_views(&args)?;
    let (train, test) = session::prepare_split(views.len(), args.test_every)?;
    let names: Vec<&str> = views.iter().map(|v| v.camera.name.as_str()).collect();
    let centres: Vec<[f64; 3]> = train
        .iter()
        .map(|&i| views[i].camera.center().to_array())
        .collect();
    let extent = crate::model::rig::nerfpp_radius(&centres).unwrap_or(1.0);
    let params = RefineParams {
        background: if args.white_background {
            [1.0; 3]
        } else {
            [0.0; 3]
        },
        normal_consistency: args.normal_consistency,
        sh_warmup: 1000,
        lr: LearningRates::default(),
        spatial_lr_scale: spatial_lr_scale(extent, model.mesh.vertices.len()),
        seed: args.seed,
    };
    let settings = json!({
        "params": params, "downscale": downscale, "test_every": args.test_every,
        "views": names, "masks": args.masks.is_some(),
    });
    let mut r = Refiner::new(model, params);
    let evals = match saved {
        Some(ck) => resume(&args, &mut r, ck, &settings)?,
        None => Vec::new(),
    };
    if r.iteration() > iterations {
        bail!(
            "the checkpoint is at iteration {} already, past --iterations {iterations}",
            r.iteration()
        );
    }
    let views = session::Views {
        all: &views,
        train: &train,
        test: &test,
    };
    let schedule = session::Schedule {
        iterations,
        stop_at: None,
        eval_every: args.eval_every,
    };
    let mut bar = args.common.loop_bar("refine");
    let outcome = session::run(&mut r, views, schedule, evals, "refine", &mut |e| match e {
        Event::Start { start, end } => bar.start(end - start),
        Event::Step { iteration, .. } => bar.step(iteration, || e.status()),
        Event::Edit(_) | Event::Eval(_) => {}
    });
    bar.finish();
    let outcome = outcome?;
    let summary = write_outputs(&args, stage.path(), &r, views, &outcome, &settings, t0)?;
    stage.commit()?;
    report(&args, &r, &outcome, test.len())?;
    let mut compact = summary;
    if let Some(o) = compact.as_object_mut() {
        o.remove("settings");
    }
    args.common.emit_json(&compact)
}

/// The model to refine: a checkpoint's (with its saved state) or the bound
/// file, its mesh replaced by MESH when one is given (not on `--resume`).
fn load_model(args: &RefineArgs) -> anyhow::Result<(BoundGaussians, Option<checkpoint::Saved>)> {
    let (mut model, saved) = match &args.resume {
        Some(dir) => {
            let ck = dir.join(checkpoint::DIR);
            // The run advances this checkpoint (often in the same output folder).
            crate::io::transaction::note_replaceable(&ck);
            let model = ck.join(checkpoint::MODEL);
            let (b, g) = load_bound(&model, "refine --resume")?;
            crate::model::filter3d::refuse_filter_3d(&g, "refine")
                .map_err(|e| e.in_file(shown(&model, false)))?;
            (b, Some(checkpoint::read(dir)?))
        }
        None => {
            let (b, g) = load_bound(&args.bound, "refine")?;
            crate::model::filter3d::refuse_filter_3d(&g, "refine")
                .map_err(|e| e.in_file(shown(&args.bound, false)))?;
            (b, None)
        }
    };
    if let (Some(m), None) = (&args.mesh, &args.resume) {
        let mesh = load_mesh_finite(m, "refine")?;
        model = rebind(&model, &mesh, ScaleRule::MeanSide)
            .map_err(|e| anyhow::anyhow!("{}: {e}", shown(m, false)))?;
    }
    Ok((model, saved))
}

/// The photos (and masks) of the cameras, in name order, at the downscale
/// of `--downscale` or `--resolution`: (views, downscale).
fn load_refine_views(args: &RefineArgs) -> anyhow::Result<(Vec<View>, u32)> {
    let mut cams = read_cameras(&args.cameras)?;
    if cams.is_empty() {
        bail!("{}: no cameras", shown(&args.cameras, false));
    }
    cams.sort_by(|a, b| a.name.cmp(&b.name));
    let downscale = match args.resolution {
        Some(w) => {
            let cw = cams[0].width;
            if w == 0 || cw % w != 0 {
                return Err(usage(format!(
                    "--resolution {w}: the cameras are {cw} pixels wide; give a width that divides it"
                )));
            }
            cw / w
        }
        None => args.downscale,
    };
    // a view of 0 pixels has no loss and no metric: refused before any
    // photo is read, naming the flag that sized it
    if let Some(c) = cams
        .iter()
        .find(|c| c.width / downscale == 0 || c.height / downscale == 0)
    {
        return Err(usage(format!(
            "{}: camera {:?} ({}x{}) has no pixels left at {} (downscale {downscale})",
            shown(&args.cameras, false),
            c.name,
            c.width,
            c.height,
            match args.resolution {
                Some(w) => format!("--resolution {w}"),
                None => format!("--downscale {}", args.downscale),
            }
        )));
    }
    // every photo is held in memory: refused before any is decoded
    check_views_budget(&args.cameras, &cams, downscale, REFINE_BYTES_PER_PIXEL)?;
    let views = load_views(
        &cams,
        &args.images,
        &ViewOptions {
            downscale,
            masks: args.masks.clone(),
            background: None,
        },
    )?;
    if let Some(masks) = &args.masks {
        check_masks_cover(&views, masks)?;
    }
    Ok((views, downscale))
}

/// Restores a checkpoint into `r`; returns its evaluations. Refused when
/// the checkpoint was made with other settings.
fn resume(
    args: &RefineArgs,
    r: &mut Refiner,
    ck: checkpoint::Saved,
    settings: &Value,
) -> anyhow::Result<Vec<Eval>> {
    let dir = args.resume.as_ref().expect("resume");
    let name = ck.state_file.display().to_string();
    let evals = session::resume_evals(&ck.state, settings, &name).map_err(|e| match e {
        Some(m) => anyhow::anyhow!(m),
        None => anyhow::anyhow!(
            "{}: the checkpoint was made with other settings or views (--images, --cameras, \
             --downscale, --test-every, --masks, --white-background, --seed, \
             --normal-consistency must match the first run)",
            dir.display()
        ),
    })?;
    r.restore(ck.step, ck.groups)
        .map_err(|m| anyhow::anyhow!("{}: {m}", dir.display()))?;
    Ok(evals)
}

/// Writes every output into the staging folder `dir`; returns the metrics.
fn write_outputs(
    args: &RefineArgs,
    dir: &Path,
    r: &Refiner,
    views: session::Views<'_>,
    o: &Outcome,
    settings: &Value,
    t0: std::time::Instant,
) -> anyhow::Result<Value> {
    let b: &BoundGaussians = &r.model;
    let g = attach(b, crate::geom::binding::materialize(b));
    std::fs::create_dir_all(dir.join(checkpoint::DIR))
        .with_context(|| format!("creating {}", dir.join(checkpoint::DIR).display()))?;
    save_gaussians(&dir.join("refined_bound.ply"), &g)?;
    save_gaussians(&dir.join(checkpoint::DIR).join(checkpoint::MODEL), &g)?;
    save_mesh(
        &dir.join("refined_mesh.ply"),
        &b.mesh,
        FileFormat::Ply,
        &Default::default(),
    )?;
    let (step, groups) = r.optimizer_state();
    let state = json!({"format": "splatkit-refine-checkpoint-1", "iteration": step,
                       "settings": settings, "evals": o.evals});
    checkpoint::write(dir, step, &groups, &state)?;
    let done = o.done(r);
    let summary = json!({
        "input": shown(&args.bound, false),
        "output": shown(&args.output, false),
        "gaussians": b.len(),
        "faces": b.mesh.faces.len(),
        "vertices": b.mesh.vertices.len(),
        "train_views": views.train.len(),
        "test_views": views.test.len(),
        "width": views.all[0].camera.width,
        "height": views.all[0].camera.height,
        "iterations": r.iteration(),
        "iterations_this_run": done,
        "seconds": t0.elapsed().as_secs_f64(),
        "loop_seconds": o.loop_s,
        "iterations_per_second": o.rate(r),
        "final_loss": o.last_loss,
        "evals": o.evals,
        "settings": settings,
    });
    checkpoint::write_json(&dir.join("metrics.json"), &summary)?;
    Ok(summary)
}

/// The human summary on stderr.
fn report(args: &RefineArgs, r: &Refiner, o: &Outcome, test_views: usize) -> anyhow::Result<()> {
    let done = o.done(r);
    if let (Some(first), Some(last)) = (o.evals.first(), o.evals.last()) {
        args.common.say(format!(
            "refine: {} Gaussians, {done} iterations in {:.1} s ({:.2} it/s); held-out PSNR \
             {:.2} -> {:.2} dB, SSIM {:.4} -> {:.4} ({test_views} views) -> {}",
            r.model.len(),
            o.loop_s,
            o.rate(r),
            first.psnr,
            last.psnr,
            first.ssim,
            last.ssim,
            args.output.display()
        ));
    } else {
        args.common.say(format!(
            "refine: {} Gaussians, {done} iterations in {:.1} s -> {}",
            r.model.len(),
            o.loop_s,
            args.output.display()
        ));
    }
    Ok(())
}
