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
use crate::io::dataset::check_views_budget;
use crate::io::detect::FileFormat;
use crate::io::ply::bound::attach;
use crate::io::views::{ViewOptions, load_views};
use crate::io::write_output;
use crate::model::BoundGaussians;
use crate::train::checkpoint::{decode, encode};
use crate::train::refine::{Eval, LearningRates, RefineParams, Refiner, spatial_lr_scale};
use crate::train::schedule::split;

/// Arguments of `refine`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  refine bound.ply --images scene/images --cameras scene/sparse/0 -o refined/ --short
  refine bound.ply --images dtu/image --masks dtu/mask --cameras dtu/cameras_sphere.npz \\
         --downscale 2 --white-background -o dtu_refined/
  refine bound.ply --images imgs --cameras cameras.json -o run/ --iterations 1000
  refine bound.ply --images imgs --cameras cameras.json -o run/ --iterations 2000 --resume run/

Outputs in OUT_DIR: refined_bound.ply, refined_mesh.ply, metrics.json, checkpoint/.")]
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
    /// Train at this image width (must divide the cameras' width).
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

fn read_json(path: &Path) -> anyhow::Result<Value> {
    let b = crate::io::source::read_file(path)
        .with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_slice(&b).with_context(|| format!("{}: not valid JSON", path.display()))
}

fn write_bytes(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    write_output(path, |w| {
        w.write_all(bytes).map_err(crate::io::source::werr)
    })
    .with_context(|| format!("writing {}", path.display()))
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

/// `refine` entry point.
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
    // the model: a checkpoint or the bound file
    let (mut model, resume_state) = match &args.resume {
        Some(dir) => {
            let ck = dir.join("checkpoint");
            // The run advances this checkpoint (often in the same output folder).
            crate::io::transaction::note_replaceable(&ck);
            let (b, _) = load_bound(&ck.join("model.ply"), "refine --resume")?;
            let state = read_json(&ck.join("state.json"))?;
            let opt = crate::io::source::read_file(&ck.join("optimizer.bin"))
                .with_context(|| format!("reading {}", ck.join("optimizer.bin").display()))?;
            let (step, groups) = decode(&ck.join("optimizer.bin").display().to_string(), &opt)?;
            (b, Some((state, step, groups)))
        }
        None => (load_bound(&args.bound, "refine")?.0, None),
    };
    if let (Some(m), None) = (&args.mesh, &args.resume) {
        let mesh = load_mesh_finite(m, "refine")?;
        model = rebind(&model, &mesh, ScaleRule::MeanSide)
            .map_err(|e| anyhow::anyhow!("{}: {e}", shown(m, false)))?;
    }
    // the views
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
    let (train, test) = split(views.len(), args.test_every);
    if train.is_empty() {
        bail!(
            "all {} views are held out (--test-every {}): nothing to train on",
            views.len(),
            args.test_every
        );
    }
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
    let mut evals: Vec<Eval> = Vec::new();
    if let Some((state, step, groups)) = resume_state {
        if state.get("settings") != Some(&settings) {
            bail!(
                "{}: the checkpoint was made with other settings or views (--images, --cameras, \
                 --downscale, --test-every, --masks, --white-background, --seed, \
                 --normal-consistency must match the first run)",
                args.resume.as_ref().expect("resume").display()
            );
        }
        r.restore(step, groups).map_err(|m| {
            anyhow::anyhow!("{}: {m}", args.resume.as_ref().expect("resume").display())
        })?;
        if let Some(e) = state.get("evals") {
            evals = serde_json::from_value(e.clone()).context("checkpoint state.json: evals")?;
        }
    }
    if r.iteration() > iterations {
        bail!(
            "the checkpoint is at iteration {} already, past --iterations {iterations}",
            r.iteration()
        );
    }
    if !test.is_empty() && evals.is_empty() {
        evals.push(r.evaluate(&views, &test));
    }
    let start = r.iteration();
    let pb = args.common.progress(iterations - start, "refine");
    let t_loop = std::time::Instant::now();
    // `None` (JSON null) when this run took no step
    let mut last_loss = None;
    while r.iteration() < iterations {
        // the loss every iteration, every parameter before each evaluation
        // and at the end (train::finite)
        let st = r
            .step_checked(&views, &train)
            .map_err(|m| anyhow::anyhow!("refine: {m}"))?;
        last_loss = Some(st.loss);
        pb.inc(1);
        if r.iteration().is_multiple_of(10) {
            let rate = (r.iteration() - start) as f64 / t_loop.elapsed().as_secs_f64().max(1e-9);
            pb.set_message(format!(
                "loss {:.4}  PSNR {:.2}  {rate:.2} it/s",
                st.loss, st.psnr
            ));
        }
        let at = r.iteration();
        if !test.is_empty()
            && args.eval_every > 0
            && at.is_multiple_of(args.eval_every)
            && at < iterations
        {
            r.check_finite()
                .map_err(|m| anyhow::anyhow!("refine: {m}"))?;
            evals.push(r.evaluate(&views, &test));
        }
    }
    r.check_finite()
        .map_err(|m| anyhow::anyhow!("refine: {m}"))?;
    if !test.is_empty() && evals.last().map(|e| e.iteration) != Some(r.iteration()) {
        evals.push(r.evaluate(&views, &test));
    }
    pb.finish_and_clear();
    let loop_s = t_loop.elapsed().as_secs_f64();
    // outputs
    let dir = stage.path().to_path_buf();
    let ck = dir.join("checkpoint");
    std::fs::create_dir_all(&ck).with_context(|| format!("creating {}", ck.display()))?;
    let b: &BoundGaussians = &r.model;
    let g = attach(b, crate::geom::binding::materialize(b));
    save_gaussians(&dir.join("refined_bound.ply"), &g)?;
    save_gaussians(&ck.join("model.ply"), &g)?;
    save_mesh(
        &dir.join("refined_mesh.ply"),
        &b.mesh,
        FileFormat::Ply,
        &Default::default(),
    )?;
    let (step, groups) = r.optimizer_state();
    write_bytes(&ck.join("optimizer.bin"), &encode(step, &groups))?;
    let state = json!({"format": "splatkit-refine-checkpoint-1", "iteration": step,
                       "settings": settings, "evals": evals});
    write_bytes(
        &ck.join("state.json"),
        serde_json::to_string_pretty(&state)?.as_bytes(),
    )?;
    let done = r.iteration() - start;
    let summary = json!({
        "input": shown(&args.bound, false),
        "output": shown(&args.output, false),
        "gaussians": b.len(),
        "faces": b.mesh.faces.len(),
        "vertices": b.mesh.vertices.len(),
        "train_views": train.len(),
        "test_views": test.len(),
        "width": views[0].camera.width,
        "height": views[0].camera.height,
        "iterations": r.iteration(),
        "iterations_this_run": done,
        "seconds": t0.elapsed().as_secs_f64(),
        "loop_seconds": loop_s,
        "iterations_per_second": done as f64 / loop_s.max(1e-9),
        "final_loss": last_loss,
        "evals": evals,
        "settings": settings,
    });
    write_bytes(
        &dir.join("metrics.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    stage.commit()?;
    if let (Some(first), Some(last)) = (evals.first(), evals.last()) {
        args.common.say(format!(
            "refine: {} Gaussians, {done} iterations in {loop_s:.1} s ({:.2} it/s); held-out PSNR \
             {:.2} -> {:.2} dB, SSIM {:.4} -> {:.4} ({} views) -> {}",
            b.len(),
            done as f64 / loop_s.max(1e-9),
            first.psnr,
            last.psnr,
            first.ssim,
            last.ssim,
            test.len(),
            args.output.display()
        ));
    } else {
        args.common.say(format!(
            "refine: {} Gaussians, {done} iterations in {loop_s:.1} s -> {}",
            b.len(),
            args.output.display()
        ));
    }
    let mut compact = summary.clone();
    if let Some(o) = compact.as_object_mut() {
        o.remove("settings");
    }
    args.common.emit_json(&compact)?;
    Ok(())
}
