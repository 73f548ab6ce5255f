//! `chamfer`: surface evaluation.
//!
//! - generic mode ([`crate::eval::chamfer`]): any two point clouds or meshes;
//! - `--protocol dtu`: [`crate::eval::dtu`] (+ [`crate::eval::cull`]);
//! - `--protocol tnt`: [`crate::eval::tnt`].
//!
//! This module reads the files (through `io::any`), pairs the DTU cameras
//! with their masks for culling, and writes the reports and visualisations.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use glam::DMat4;
use rayon::prelude::*;
use serde_json::json;

use crate::cli::{Common, check_output_file, positive_f64, shown, usage};
use crate::eval::chamfer::{
    Cloud, GenericParams, GenericReport, SampleMode, chamfer_generic, drop_non_finite, f64_points,
    mesh_cloud,
};
use crate::eval::cull::{CullView, DILATION_RADIUS, dilate_disk};
use crate::eval::dtu::{DtuParams, DtuPrediction, DtuReport, evaluate_dtu, vis_color};
use crate::eval::tnt::{
    TntInput, TntParams, TntReport, evaluate_tnt, plot_pr_curves, tnt_threshold,
    vertices_and_face_centroids,
};
use crate::geom::sampling::sample::dtu_sample_estimate;
use crate::io::StagedDir;
use crate::io::any::{load_kinds, load_mesh, load_points};
use crate::io::cameras::npz::{NpzOptions, read_neus_cameras};
use crate::io::cameras::validate_cameras;
use crate::io::image::read_mask;
use crate::io::ply::{Format, points::write_points};
use crate::model::{CropVolume, PointCloud, Scene, SceneKind};
use crate::{Error, Result};

/// Bytes one sampled point costs through an evaluation (f64 position, its
/// share of the k-d tree, distances, the downsampling order), rounded up.
const BYTES_PER_SAMPLE: u64 = 128;

/// The default of `--max-samples` (see its help): the usable memory
/// budget ([`crate::io::budget::usable_bytes`]) over [`BYTES_PER_SAMPLE`].
pub fn default_max_samples() -> u64 {
    (crate::io::budget::usable_bytes() / BYTES_PER_SAMPLE).max(1)
}

/// Refuses to make about `estimate` points from `file` (the `side` of the
/// evaluation) when that exceeds `max`, or when their memory exceeds the
/// budget: a `--max-samples` raised past the budget does not lift it.
fn check_samples(side: &str, file: &Path, estimate: f64, max: u64, how: &str) -> Result<()> {
    if estimate > max as f64 {
        return Err(Error::invalid(format!(
            "{side} {}: {how} would make about {estimate:.3e} points, more than --max-samples {max} \
             (raise it, or use a coarser --spacing / smaller --count)",
            shown(file, false)
        )));
    }
    // `as` saturates: an estimate past u64 is refused too
    let bytes = (estimate * BYTES_PER_SAMPLE as f64) as u64;
    crate::io::budget::check(
        &format!(
            "{side} {}: {how} ({estimate:.3e} points at {BYTES_PER_SAMPLE} bytes each)",
            shown(file, false)
        ),
        bytes,
    )
}

/// Loads a point cloud or mesh file as points (`-` = stdin): a cloud's
/// points (and normals), a mesh by `p.sample`; `side` ("prediction" or
/// "ground truth") names it in errors, and a mesh that would give more than
/// `max_samples` points is refused before sampling.
pub fn load_cloud(path: &Path, p: &GenericParams, side: &str, max_samples: u64) -> Result<Cloud> {
    let scene = load_kinds(path, "chamfer", &[SceneKind::Mesh, SceneKind::PointCloud])
        .map_err(|e| e.in_role(side))?;
    match scene {
        Scene::PointCloud(pc) => Ok(Cloud {
            points: f64_points(&pc.positions),
            normals: pc.normals.as_ref().map(|n| f64_points(n)),
        }),
        Scene::Mesh(m) => {
            match p.sample {
                SampleMode::Area => {
                    check_samples(side, path, p.count as f64, max_samples, "--count")?
                }
                SampleMode::Dtu => check_samples(
                    side,
                    path,
                    dtu_sample_estimate(&f64_points(&m.vertices), &m.faces, p.spacing),
                    max_samples,
                    "DTU up-sampling at this --spacing",
                )?,
                SampleMode::Vertices => {}
            }
            // a sampling failure (a mesh of zero area) names the file and side
            mesh_cloud(&m, p).map_err(|e| match e {
                Error::Invalid(msg) => Error::format(format!("{side} {}", shown(path, false)), msg),
                other => other.in_role(side),
            })
        }
        _ => unreachable!("load_kinds returns an accepted kind"),
    }
}

/// The evaluation protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Protocol {
    /// Any two point clouds or meshes.
    Generic,
    /// DTU (DTUeval-python / 2DGS).
    Dtu,
    /// Tanks and Temples (official toolbox).
    Tnt,
}

/// Command-line arguments of `chamfer`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  chamfer pred.ply gt.ply --tau 0.01,0.02 --json
  chamfer mesh.obj gt_points.ply --sample dtu --spacing 0.2 --max-dist 20
  chamfer --protocol dtu --scan 24 --dataset-dir DTU_OFFICIAL mesh_mm.ply \\
      --vis-dir vis/
  chamfer --protocol dtu --scan 24 --dataset-dir DTU_OFFICIAL fuse_post.ply \\
      --cull --cameras scan24/cameras.npz --masks scan24/mask \\
      --json=scan24.json
  chamfer --protocol tnt --scene Barn --gt-dir TNT_GT/Barn \\
      --traj Barn_COLMAP_SfM.log mesh.ply --plot pr.png")]
pub struct ChamferArgs {
    /// Prediction (and, in generic mode, ground truth): PLY points or meshes, OBJ, OFF, GLB.
    /// (TnT also takes the prediction as `--ply-path`.)
    #[arg(num_args = 0..=2)]
    pub inputs: Vec<PathBuf>,
    /// Evaluation protocol.
    #[arg(long, value_enum, default_value = "generic")]
    pub protocol: Protocol,
    /// How meshes become points (generic mode).
    #[arg(long, value_enum, default_value = "area")]
    pub sample: SampleMode,
    /// Samples per mesh with --sample area (at least 1).
    #[arg(long, default_value_t = 1_000_000,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    pub count: usize,
    /// Spacing of --sample dtu (same unit as the data), > 0.
    #[arg(long, default_value_t = 0.2, value_parser = positive_f64)]
    pub spacing: f64,
    /// Refuse an evaluation that would make more than N points from a mesh
    /// (the estimate of `--count` or of the DTU up-sampling, area / spacing²).
    /// Default: the memory this process may use (3/4 of the smaller of
    /// MemTotal and `ulimit -v`) over 128 bytes per point, about 150 million
    /// on 24 GiB. A larger N does not lift that memory limit.
    #[arg(long, value_name = "N", value_parser = clap::builder::RangedU64ValueParser::<u64>::new().range(1..))]
    pub max_samples: Option<u64>,
    /// Use mesh vertices instead of samples (same as --sample vertices).
    #[arg(long)]
    pub vertices: bool,
    /// F-score thresholds, comma-separated, in the data's unit. Generic: none
    /// by default (no F-score); TnT: overrides the scene's τ.
    #[arg(long, value_delimiter = ',', value_parser = positive_f64)]
    pub tau: Vec<f64>,
    /// Discard distances ≥ this before statistics (generic), > 0, in the
    /// data's unit. Off by default: every distance counts.
    #[arg(long, value_parser = positive_f64)]
    pub max_dist: Option<f64>,
    /// Seed of every random step (sampling, DTU shuffle, TnT RANSAC).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// DTU scan number.
    #[arg(long)]
    pub scan: Option<u32>,
    /// DTU: official dataset root (Points/stl, ObsMask). TnT: the scene's
    /// ground-truth folder, named after the scene, as the toolbox's
    /// `--dataset-dir` (same as --gt-dir, with the scene from its name).
    #[arg(long)]
    pub dataset_dir: Option<PathBuf>,
    /// DTU: the prediction is a point cloud (reference `--mode pcd`).
    #[arg(long)]
    pub pcd: bool,
    /// DTU: cull the (normalised-frame) mesh with the scene's masks and map it to mm first.
    #[arg(long)]
    pub cull: bool,
    /// DTU --cull: the scene's cameras.npz (world_mat_i, scale_mat_i).
    #[arg(long)]
    pub cameras: Option<PathBuf>,
    /// DTU --cull: the scene's mask folder (one PNG per view).
    #[arg(long)]
    pub masks: Option<PathBuf>,
    /// DTU: write vis_XXX_d2s.ply / vis_XXX_s2d.ply (and TnT precision/recall clouds) here.
    #[arg(long)]
    pub vis_dir: Option<PathBuf>,
    /// TnT scene name (Barn, Caterpillar, …): selects τ and the GT file names.
    #[arg(long)]
    pub scene: Option<String>,
    /// TnT: folder with <Scene>.ply, <Scene>.json, <Scene>_trans.txt, <Scene>_COLMAP_SfM.log.
    #[arg(long)]
    pub gt_dir: Option<PathBuf>,
    /// TnT: the reconstruction's camera trajectory (.log); also `--traj-path`.
    /// One longer than 1600 frames is reduced to the reference's frames with
    /// `<Scene>_mapping_reference.txt` of the ground-truth folder, as the
    /// toolbox does for full-video logs.
    #[arg(long, alias = "traj-path")]
    pub traj: Option<PathBuf>,
    /// TnT: the reconstruction, as the toolbox's `--ply-path` (instead of the
    /// positional input); its toolbox outputs then go to `evaluation/`
    /// beside it unless --out-dir says otherwise.
    #[arg(long)]
    pub ply_path: Option<PathBuf>,
    /// TnT: write the toolbox's outputs here: `<Scene>.precision.ply`,
    /// `<Scene>.recall.ply`, `<Scene>.precision.txt`, `<Scene>.recall.txt`,
    /// `<Scene>.prf_tau_plotstr.txt`, `PR_<Scene>_@d_th_0_<τ·10⁴>.png`.
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// TnT: write the precision/recall-versus-threshold plot (PNG).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// TnT: evaluate mesh vertices and face centroids (2DGS's eval script) instead of vertices only.
    #[arg(long)]
    pub with_centroids: bool,
    #[command(flatten)]
    pub common: Common,
}

/// Runs the command.
pub fn run(args: ChamferArgs) -> anyhow::Result<()> {
    args.common.init()?;
    match args.protocol {
        Protocol::Generic => run_generic(&args),
        Protocol::Dtu => run_dtu(&args),
        Protocol::Tnt => run_tnt(&args),
    }
}

fn run_generic(args: &ChamferArgs) -> anyhow::Result<()> {
    let [pred_path, gt_path] = args.inputs.as_slice() else {
        bail!("generic mode needs two inputs: PRED GT");
    };
    if pred_path.as_os_str() == "-" && gt_path.as_os_str() == "-" {
        return Err(usage(
            "only one of PRED and GT can be `-` (stdin is read once)",
        ));
    }
    if args.tau.iter().any(|t| t.is_nan() || *t <= 0.0) {
        bail!("--tau values must be positive");
    }
    let params = GenericParams {
        sample: if args.vertices {
            SampleMode::Vertices
        } else {
            args.sample
        },
        count: args.count,
        spacing: args.spacing,
        thresholds: args.tau.clone(),
        max_dist: args.max_dist,
        seed: args.seed,
    };
    let (pred, gt, dropped) = load_generic_clouds(args, pred_path, gt_path, &params)?;
    let report = chamfer_generic(&pred, &gt, &params)?;
    report_generic(args, &report, [pred_path, gt_path], dropped, &params)
}

/// The prediction and ground-truth points of generic mode (meshes
/// sampled by `params`; the ground truth with another seed), without
/// their non-finite points, whose counts come third. An error when either
/// has no point left.
fn load_generic_clouds(
    args: &ChamferArgs,
    pred_path: &Path,
    gt_path: &Path,
    params: &GenericParams,
) -> anyhow::Result<(Cloud, Cloud, [usize; 2])> {
    let max_samples = args.max_samples.unwrap_or_else(default_max_samples);
    let mut pred = load_cloud(pred_path, params, "prediction", max_samples)?;
    // A different seed for the GT's samples, so two copies of one mesh are
    // not sampled at identical points.
    let gt_params = GenericParams {
        seed: params.seed ^ 0x9e37_79b9_7f4a_7c15,
        ..params.clone()
    };
    let mut gt = load_cloud(gt_path, &gt_params, "ground truth", max_samples)?;
    let dropped = [drop_non_finite(&mut pred), drop_non_finite(&mut gt)];
    for (cloud, path, side, n_bad) in [
        (&pred, pred_path, "prediction", dropped[0]),
        (&gt, gt_path, "ground truth", dropped[1]),
    ] {
        if cloud.points.is_empty() {
            return Err(Error::invalid(format!(
                "{side} {}: no points to compare ({})",
                shown(path, false),
                if n_bad > 0 {
                    format!("all {n_bad} are non-finite")
                } else {
                    "the file holds none".to_string()
                }
            ))
            .into());
        }
    }
    Ok((pred, gt, dropped))
}

/// The human summary (stderr) and the JSON report of generic mode:
/// `paths` are the prediction and the ground truth, `dropped` their
/// non-finite points.
fn report_generic(
    args: &ChamferArgs,
    report: &GenericReport,
    paths: [&Path; 2],
    dropped: [usize; 2],
    params: &GenericParams,
) -> anyhow::Result<()> {
    args.common.say(format!(
        "chamfer: accuracy {:.6} completeness {:.6} chamfer-L1 {:.6} ({} vs {} points{})",
        report.accuracy.mean,
        report.completeness.mean,
        report.chamfer_l1,
        report.pred_points,
        report.gt_points,
        if dropped != [0, 0] {
            format!(
                "; dropped {} + {} non-finite points",
                dropped[0], dropped[1]
            )
        } else {
            String::new()
        }
    ));
    for f in &report.fscores {
        args.common.say(format!(
            "  tau {}: precision {:.4} recall {:.4} f-score {:.4}",
            f.tau, f.precision, f.recall, f.fscore
        ));
    }
    let mut v = serde_json::to_value(report)?;
    v["pred"] = shown(paths[0], false).into();
    v["gt"] = shown(paths[1], false).into();
    v["non_finite_dropped"] = json!(dropped);
    v["params"] = serde_json::to_value(params)?;
    args.common.emit_json(&v)
}

/// Inputs of a DTU evaluation from files.
#[derive(Clone, Debug)]
pub struct DtuFiles<'a> {
    /// The prediction (mesh, or point cloud when `pcd`).
    pub pred: &'a Path,
    /// Official dataset root.
    pub dataset_dir: &'a Path,
    pub scan: u32,
    pub pcd: bool,
    /// `cameras.npz` and mask folder for the culling step.
    pub cull: Option<(&'a Path, &'a Path)>,
    /// Refuse a mesh whose up-sampling would exceed this many points.
    pub max_samples: u64,
}

/// What [`dtu_from_files`] returns.
pub struct DtuRun {
    pub report: DtuReport,
    /// Vertices removed by culling, when it ran.
    pub culled: Option<usize>,
    /// The STL points (for the visualisation).
    pub stl: Vec<[f64; 3]>,
}

/// Reads everything a DTU evaluation needs and runs it (the whole
/// `--protocol dtu` path without the output side).
pub fn dtu_from_files(f: &DtuFiles, params: &DtuParams) -> anyhow::Result<DtuRun> {
    let ds = crate::io::dtu::DtuOfficial::new(f.dataset_dir);
    ds.check(f.scan)?;
    let DtuPred {
        vertices,
        faces,
        culled,
    } = load_dtu_prediction(f, params)?;
    if vertices.is_empty() {
        bail!(
            "prediction {}: has no points to evaluate",
            shown(f.pred, false)
        );
    }
    let stl_path = ds.stl_path(f.scan);
    let stl = load_points(&stl_path, "chamfer").map_err(|e| e.in_role("ground truth"))?;
    if stl.is_empty() {
        bail!("ground truth {}: holds no points", stl_path.display());
    }
    let stl: Vec<[f64; 3]> = f64_points(&stl.positions);
    let obs = crate::io::dtu::read_obs_mask(&ds.obs_mask_path(f.scan))?;
    let plane = crate::io::dtu::read_plane(&ds.plane_path(f.scan))?;
    let pred = if f.pcd {
        DtuPrediction::Points(&vertices)
    } else {
        DtuPrediction::Mesh {
            vertices: &vertices,
            faces: &faces,
        }
    };
    let report = evaluate_dtu(&pred, &stl, &obs, plane, params)?;
    // An empty side would give a NaN score: say why instead.
    if report.points_in_obs == 0 {
        bail!(
            "prediction {}: none of its {} points falls in scan {}'s observed volume (ObsMask, bounding box {:?}..{:?} mm): is it in millimetres, in the DTU frame (--cull maps a normalised mesh)?",
            shown(f.pred, false),
            report.points_down,
            f.scan,
            obs.bb[0],
            obs.bb[1]
        );
    }
    if report.stl_above_plane == 0 {
        bail!(
            "ground truth {}: no point lies above the plane of {}",
            stl_path.display(),
            ds.plane_path(f.scan).display()
        );
    }
    Ok(DtuRun {
        report,
        culled,
        stl,
    })
}

/// A DTU prediction as read: its points (f64, the file's units), its
/// faces (none for `--pcd`) and, with `--cull`, the count of vertices the
/// masks removed.
struct DtuPred {
    vertices: Vec<[f64; 3]>,
    faces: Vec<[u32; 3]>,
    culled: Option<usize>,
}

/// Reads the DTU prediction, culled by the masks with `--cull`; a mesh's
/// up-sampling estimate is checked against `--max-samples` first.
fn load_dtu_prediction(f: &DtuFiles, params: &DtuParams) -> anyhow::Result<DtuPred> {
    let (vertices, faces, culled) = if f.pcd {
        if f.cull.is_some() {
            bail!("--cull applies to meshes; it cannot be combined with --pcd");
        }
        let pc = load_cloud(
            f.pred,
            &GenericParams::vertices(),
            "prediction",
            f.max_samples,
        )?;
        (pc.points, Vec::new(), None)
    } else {
        let m = load_mesh(f.pred, "chamfer").map_err(|e| e.in_role("prediction"))?;
        let verts = f64_points(&m.vertices);
        check_samples(
            "prediction",
            f.pred,
            dtu_sample_estimate(&verts, &m.faces, params.density),
            f.max_samples,
            "the DTU up-sampling",
        )?;
        if let Some((cams, masks)) = f.cull {
            let (views, scale_mat) = load_cull_views(cams, masks)?;
            let (v, fc, removed) =
                crate::eval::cull::cull_mesh(&verts, &m.faces, &views, &scale_mat);
            (v, fc, Some(removed))
        } else {
            (verts, m.faces.clone(), None)
        }
    };
    Ok(DtuPred {
        vertices,
        faces,
        culled,
    })
}

/// Loads the views: cameras from `cameras.npz` (`world_mat_i`, `scale_mat_i`)
/// and one mask per view from `mask_dir` (`*.png`, sorted by name), dilated.
/// Returns the views and the `scale_mat` that maps the normalised frame to mm.
pub fn load_cull_views(cameras: &Path, mask_dir: &Path) -> Result<(Vec<CullView>, DMat4)> {
    let cams = read_neus_cameras(cameras, &NpzOptions::default())?;
    validate_cameras(&cameras.display().to_string(), &cams.cameras)?;
    let mut masks: Vec<PathBuf> = std::fs::read_dir(mask_dir)
        .map_err(|e| Error::io(mask_dir.display(), e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .collect();
    masks.sort();
    if masks.is_empty() {
        return Err(Error::invalid(format!(
            "{}: no PNG masks",
            mask_dir.display()
        )));
    }
    if cams.views.len() < masks.len() {
        return Err(Error::invalid(format!(
            "{} has {} views but {} holds {} masks: every mask needs a camera (world_mat_0..world_mat_{})",
            cameras.display(),
            cams.views.len(),
            mask_dir.display(),
            masks.len(),
            masks.len() - 1
        )));
    }
    let views = masks
        .par_iter()
        .enumerate()
        .map(|(i, path)| {
            let d = &cams.views[i].decomposition;
            Ok(CullView {
                k: d.k,
                rotation: d.rotation,
                translation: d.translation,
                mask: dilate_disk(&read_mask(path)?, DILATION_RADIUS),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((views, cams.scale_mat))
}

fn run_dtu(args: &ChamferArgs) -> anyhow::Result<()> {
    let [pred_path] = args.inputs.as_slice() else {
        return Err(usage(
            "--protocol dtu takes one input: the predicted mesh (or point cloud with --pcd)",
        ));
    };
    let scan = args.scan.context("--protocol dtu needs --scan N")?;
    let root = args
        .dataset_dir
        .as_ref()
        .context("--protocol dtu needs --dataset-dir DTU_OFFICIAL")?;
    let cull = if args.cull {
        Some((
            args.cameras
                .as_deref()
                .context("--cull needs --cameras cameras.npz")?,
            args.masks.as_deref().context("--cull needs --masks DIR")?,
        ))
    } else {
        None
    };
    let params = DtuParams {
        seed: args.seed,
        ..DtuParams::default()
    };
    // The visualisation folder is staged now (a bad path fails before the
    // evaluation) and moved into place only after it is complete.
    let vis = args.vis_dir.as_deref().map(StagedDir::new).transpose()?;
    let run = dtu_from_files(
        &DtuFiles {
            pred: pred_path,
            dataset_dir: root,
            scan,
            pcd: args.pcd,
            max_samples: args.max_samples.unwrap_or_else(default_max_samples),
            cull,
        },
        &params,
    )?;
    let report = &run.report;
    if let Some(st) = vis {
        write_dtu_vis(st.path(), scan, report, &run.stl, &params)?;
        st.commit()?;
    }
    args.common.say(format!(
        "dtu scan {scan}: mean_d2s {} mean_s2d {} overall {}",
        report.mean_d2s, report.mean_s2d, report.overall
    ));
    let mut v = serde_json::to_value(report)?;
    v["scan"] = scan.into();
    v["pred"] = shown(pred_path, false).into();
    if let Some(r) = run.culled {
        v["culled_vertices"] = r.into();
    }
    args.common.emit_json(&v)
}

/// Writes the two reference visualisation clouds.
fn write_dtu_vis(
    dir: &Path,
    scan: u32,
    r: &DtuReport,
    stl: &[[f64; 3]],
    p: &DtuParams,
) -> Result<()> {
    let cloud = |pts: &[[f64; 3]], d: &[f64]| PointCloud {
        positions: pts.iter().map(|q| q.map(|c| c as f32)).collect(),
        normals: None,
        colors: Some(d.iter().map(|&x| vis_color(x, p)).collect()),
        extras: Default::default(),
    };
    let d2s = cloud(&r.vis.data_down, &r.vis.d2s);
    crate::io::write_output(&dir.join(format!("vis_{scan:03}_d2s.ply")), |w| {
        write_points(w, &d2s, Format::BinaryLittleEndian)
    })?;
    let s2d = cloud(stl, &r.vis.s2d);
    crate::io::write_output(&dir.join(format!("vis_{scan:03}_s2d.ply")), |w| {
        write_points(w, &s2d, Format::BinaryLittleEndian)
    })
}

/// Colour of a TnT visualisation point: distance clipped at 3τ on a
/// white (0) → red → black (≥ 3τ) ramp, the look of matplotlib's `hot_r`
/// the toolbox uses (approximated: white → yellow → red → black).
fn hot_r(d: f64, tau: f64) -> [u8; 3] {
    let t = (d / (3.0 * tau)).clamp(0.0, 1.0);
    // hot runs black → red → yellow → white over thirds; hot_r reverses it.
    let h = 1.0 - t;
    let c = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    [c(h * 3.0), c(h * 3.0 - 1.0), c(h * 3.0 - 2.0)]
}

/// `--protocol tnt`: resolves the files ([`tnt_setup`]), reads them
/// ([`load_tnt`]), runs [`evaluate_tnt`], writes the plot and the
/// point clouds and toolbox files ([`write_tnt_outputs`]) and reports.
fn run_tnt(args: &ChamferArgs) -> anyhow::Result<()> {
    let setup = tnt_setup(args)?;
    let data = load_tnt(args, &setup)?;
    let mut params = TntParams::default();
    params.ransac.seed = args.seed;
    let report = evaluate_tnt(&data.input(), setup.tau, &params)?;
    let scene = setup.scene.as_str();
    write_tnt_outputs(args, setup.vis, setup.toolbox_out, &report, scene)?;
    args.common.say(format!(
        "tnt {scene}: precision {:.4} recall {:.4} f-score {:.4} (tau {})",
        report.precision, report.recall, report.fscore, setup.tau
    ));
    let mut v = serde_json::to_value(&report)?;
    v["scene"] = scene.into();
    v["pred"] = shown(setup.pred_path, false).into();
    v["trajectory_mapped"] = data.mapped.into();
    if let Some(d) = &setup.out_dir {
        v["out_dir"] = d.display().to_string().into();
    }
    args.common.emit_json(&v)
}

/// The files and settings of a TnT evaluation, resolved from the flags.
struct TntSetup<'a> {
    /// The reconstruction (the argument or `--ply-path`).
    pred_path: &'a Path,
    /// The scene's ground-truth folder.
    gt_dir: &'a Path,
    /// The scene name its files use ([`tnt_file_stem`]).
    scene: String,
    /// The reconstruction's trajectory (`.log`).
    traj: &'a Path,
    /// τ, ground-truth units (metres).
    tau: f64,
    /// The toolbox's output folder (`--out-dir`, or `evaluation/` beside a
    /// `--ply-path`) and its staging.
    out_dir: Option<PathBuf>,
    toolbox_out: Option<StagedDir>,
    /// `--vis-dir`, staged.
    vis: Option<StagedDir>,
}

impl TntSetup<'_> {
    /// The ground-truth file `<scene><suffix>`.
    fn file(&self, suffix: &str) -> PathBuf {
        self.gt_dir.join(format!("{}{suffix}", self.scene))
    }
}

/// Resolves the TnT flags: the reconstruction, the ground-truth folder,
/// the scene, the trajectory and τ (usage errors, exit 2, for what is
/// missing or given twice); checks `--plot`, stages `--vis-dir` and the
/// toolbox's folder, and checks that the ground-truth files exist.
fn tnt_setup(args: &ChamferArgs) -> anyhow::Result<TntSetup<'_>> {
    let (pred_path, gt_dir) = tnt_paths(args)?;
    let scene = tnt_scene(args, gt_dir)?;
    let traj = args
        .traj
        .as_ref()
        .ok_or_else(|| usage("--protocol tnt needs --traj-path RECONSTRUCTION.log"))?;
    let tau = match args.tau.as_slice() {
        [] => tnt_threshold(&scene)
            .with_context(|| format!("no published threshold for scene '{scene}': give --tau"))?,
        [t] if *t > 0.0 && t.is_finite() => *t,
        _ => return Err(usage("--protocol tnt takes one positive --tau")),
    };
    if let Some(plot) = &args.plot {
        check_output_file(plot, "--plot")?;
    }
    if args.vis_dir.is_some() && args.vis_dir == args.out_dir {
        return Err(usage("--vis-dir and --out-dir must be different folders"));
    }
    let vis = args.vis_dir.as_deref().map(StagedDir::new).transpose()?;
    // The toolbox's outputs: --out-dir, or evaluation/ beside a --ply-path.
    let out_dir = args.out_dir.clone().or_else(|| {
        args.ply_path.as_ref().map(|p| {
            p.parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."))
                .join("evaluation")
        })
    });
    let toolbox_out = out_dir.as_deref().map(StagedDir::new).transpose()?;
    let setup = TntSetup {
        pred_path,
        gt_dir,
        scene,
        traj,
        tau,
        out_dir,
        toolbox_out,
        vis,
    };
    let missing: Vec<String> = [".ply", ".json", "_trans.txt", "_COLMAP_SfM.log"]
        .iter()
        .map(|s| setup.file(s))
        .filter(|p| !p.exists())
        .map(|p| p.display().to_string())
        .collect();
    if !missing.is_empty() {
        bail!(
            "missing Tanks-and-Temples ground truth: {}",
            missing.join(", ")
        );
    }
    Ok(setup)
}

/// The reconstruction (the argument or `--ply-path`) and the ground-truth
/// folder (`--gt-dir` or `--dataset-dir`): usage errors when either is
/// missing or given twice.
fn tnt_paths(args: &ChamferArgs) -> anyhow::Result<(&Path, &Path)> {
    let pred_path = match (args.inputs.as_slice(), &args.ply_path) {
        ([p], None) | ([], Some(p)) => p,
        ([_], Some(_)) => {
            return Err(usage(
                "give the reconstruction once: as the argument or as --ply-path",
            ));
        }
        _ => {
            return Err(usage(
                "--protocol tnt takes one reconstruction (mesh or point cloud): the argument or --ply-path",
            ));
        }
    };
    let gt_dir = match (&args.gt_dir, &args.dataset_dir) {
        (Some(d), None) | (None, Some(d)) => d,
        (Some(_), Some(_)) => {
            return Err(usage(
                "--gt-dir and --dataset-dir name the same folder: give one",
            ));
        }
        (None, None) => {
            return Err(usage(
                "--protocol tnt needs --dataset-dir DIR (the scene's ground-truth folder)",
            ));
        }
    };
    Ok((pred_path, gt_dir))
}

/// The scene name the ground-truth files use: `--scene`, else the
/// folder's name as the toolbox takes it, spelled as the files in
/// `gt_dir` are ([`tnt_file_stem`]).
fn tnt_scene(args: &ChamferArgs, gt_dir: &Path) -> anyhow::Result<String> {
    let folder_name = std::fs::canonicalize(gt_dir)
        .unwrap_or_else(|_| gt_dir.to_path_buf())
        .file_name()
        .map(|n| n.to_string_lossy().into_owned());
    let given = match (&args.scene, &folder_name) {
        (Some(s), _) => s.clone(),
        (None, Some(n)) => n.clone(),
        (None, None) => return Err(usage("give --scene NAME (Barn, Caterpillar, ...)")),
    };
    Ok(tnt_file_stem(gt_dir, &given))
}

/// What a TnT evaluation reads: the reconstruction's points and
/// trajectory (reduced to the reference frames when `mapped`), and the
/// ground truth's points, trajectory, transform and crop volume.
struct TntData {
    rec_points: Vec<[f64; 3]>,
    gt_points: Vec<[f64; 3]>,
    rec_traj: Vec<DMat4>,
    gt_traj: Vec<DMat4>,
    trans: DMat4,
    crop: CropVolume,
    mapped: bool,
}

impl TntData {
    /// The data as [`evaluate_tnt`] takes it.
    fn input(&self) -> TntInput<'_> {
        TntInput {
            rec_points: &self.rec_points,
            rec_traj: &self.rec_traj,
            gt_traj: &self.gt_traj,
            gt_trans: &self.trans,
            crop: &self.crop,
            gt_points: &self.gt_points,
        }
    }
}

/// Reads the reconstruction (vertices, plus face centroids with
/// `--with-centroids`), the ground-truth points, both trajectories (a
/// full-video log reduced by the scene's mapping), the transform and the
/// crop volume.
fn load_tnt(args: &ChamferArgs, s: &TntSetup) -> anyhow::Result<TntData> {
    // The official toolbox reads a mesh PLY's vertices (`read_point_cloud`);
    // 2DGS's script adds the face centroids (`--with-centroids`).
    let rec_points = if args.with_centroids {
        let m = load_mesh(s.pred_path, "chamfer").map_err(|e| e.in_role("prediction"))?;
        vertices_and_face_centroids(&f64_points(&m.vertices), &m.faces)?
    } else {
        load_cloud(
            s.pred_path,
            &GenericParams::vertices(),
            "prediction",
            args.max_samples.unwrap_or_else(default_max_samples),
        )?
        .points
    };
    let gt = load_points(&s.file(".ply"), "chamfer").map_err(|e| e.in_role("ground truth"))?;
    let gt_points = f64_points(&gt.positions);
    let mut rec_traj: Vec<_> = crate::io::tnt::read_log(s.traj)?
        .iter()
        .map(|f| f.pose)
        .collect();
    // A full-video log: the reference frames, by the scene's mapping (the
    // toolbox's rule: more than 1600 frames and a mapping file present).
    let mapping = s.file("_mapping_reference.txt");
    let mut mapped = false;
    if rec_traj.len() > 1600 && mapping.is_file() {
        let m = crate::io::tnt::read_mapping(&mapping)?;
        rec_traj = m.sparse(&mapping.display().to_string(), &rec_traj)?;
        mapped = true;
    }
    let gt_traj: Vec<_> = crate::io::tnt::read_log(&s.file("_COLMAP_SfM.log"))?
        .iter()
        .map(|f| f.pose)
        .collect();
    let trans = crate::io::tnt::read_trans(&s.file("_trans.txt"))?;
    let crop = crate::io::tnt::read_crop_json(&s.file(".json"))?;
    Ok(TntData {
        rec_points,
        gt_points,
        rec_traj,
        gt_traj,
        trans,
        crop,
        mapped,
    })
}

/// Writes `--plot`, then into each staged folder (`vis`, then the
/// toolbox's) the precision and recall point clouds coloured by distance
/// (the toolbox's folder also gets [`write_toolbox_files`]), committing
/// each folder when it is complete.
fn write_tnt_outputs(
    args: &ChamferArgs,
    vis: Option<StagedDir>,
    toolbox_out: Option<StagedDir>,
    report: &TntReport,
    scene: &str,
) -> anyhow::Result<()> {
    if let Some(plot) = &args.plot {
        let img = plot_pr_curves(report);
        let name = plot.display().to_string();
        crate::io::write_output(plot, |w| {
            crate::io::image::write_png8(w, &name, img.width, img.height, 3, &img.rgb)
        })?;
    }
    let has_toolbox = toolbox_out.is_some();
    let mut dirs = Vec::new();
    dirs.extend(vis);
    dirs.extend(toolbox_out);
    let n_dirs = dirs.len();
    for (k, st) in dirs.into_iter().enumerate() {
        let dir = st.path();
        let toolbox = has_toolbox && k + 1 == n_dirs;
        for (what, pts, d) in [
            (
                "precision",
                &report.source_eval_points,
                &report.source_distances,
            ),
            (
                "recall",
                &report.target_eval_points,
                &report.target_distances,
            ),
        ] {
            let pc = PointCloud {
                positions: pts.iter().map(|q| q.map(|c| c as f32)).collect(),
                normals: None,
                colors: Some(d.iter().map(|&x| hot_r(x, report.tau)).collect()),
                extras: Default::default(),
            };
            crate::io::write_output(&dir.join(format!("{scene}.{what}.ply")), |w| {
                write_points(w, &pc, Format::BinaryLittleEndian)
            })?;
        }
        if toolbox {
            write_toolbox_files(dir, scene, report)?;
        }
        st.commit()?;
    }
    Ok(())
}

/// The scene name the ground-truth files in `dir` use: `given` when
/// `<given>.ply` is there, else the published spelling of a known scene
/// (`ignatius` → `Ignatius`) when its file is there, else `given` (the
/// missing-file check then names what was looked for).
fn tnt_file_stem(dir: &Path, given: &str) -> String {
    if dir.join(format!("{given}.ply")).exists() {
        return given.to_string();
    }
    crate::eval::tnt::TNT_THRESHOLDS
        .iter()
        .map(|(s, _)| *s)
        .find(|s| s.eq_ignore_ascii_case(given) && dir.join(format!("{s}.ply")).exists())
        .unwrap_or(given)
        .to_string()
}

/// A number as numpy's `savetxt` writes it (`%.18e`: two-digit exponent
/// with its sign; `nan`, `inf`, `-inf`).
fn savetxt_number(x: f64) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf" } else { "-inf" }.into();
    }
    let s = format!("{x:.18e}");
    let (mant, exp) = s.split_once('e').expect("exponent form");
    let e: i32 = exp.parse().expect("integer exponent");
    format!("{mant}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
}

/// The toolbox's text outputs and PR plot for `scene` in `dir`: the
/// cumulative precision and recall histograms, [P, R, F, τ, 5] (each value
/// on its own line, as `np.savetxt` writes a 1-D array), and the plot as
/// `PR_<Scene>_@d_th_0_<%04d of τ·10⁴>.png` (the toolbox also writes a PDF
/// of the same plot; splatkit writes the PNG only).
fn write_toolbox_files(dir: &Path, scene: &str, r: &crate::eval::tnt::TntReport) -> Result<()> {
    let lines = |v: &[f64]| -> String { v.iter().map(|&x| savetxt_number(x) + "\n").collect() };
    for (name, text) in [
        (format!("{scene}.precision.txt"), lines(&r.cum_precision)),
        (format!("{scene}.recall.txt"), lines(&r.cum_recall)),
        (
            format!("{scene}.prf_tau_plotstr.txt"),
            lines(&[r.precision, r.recall, r.fscore, r.tau, 5.0]),
        ),
    ] {
        crate::io::write_output(&dir.join(name), |w| {
            w.write_all(text.as_bytes())
                .map_err(crate::io::source::werr)
        })?;
    }
    let img = crate::eval::tnt::plot_pr_curves(r);
    let name = format!("PR_{scene}_@d_th_0_{:04}.png", (r.tau * 10000.0) as i64);
    let path = dir.join(&name);
    crate::io::write_output(&path, |w| {
        crate::io::image::write_png8(w, &name, img.width, img.height, 3, &img.rgb)
    })
}
