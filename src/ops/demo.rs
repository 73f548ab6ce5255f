//! `demo`: the built-in default scene, end to end, so a newcomer sees every
//! stage work with one command and no download.
//!
//! Part 1, SuGaR's coarse-mesh path on Gaussians: a torus (major radius 1,
//! minor 0.35) covered with flat, coloured Gaussians plus transparent
//! floaters ([`Torus::gaussians`]) and orbit cameras around it are written as
//! `scene.ply` and `cameras.json`; then `splat2points` (level 0.3),
//! `poisson` (depth 8) and `clean` (largest component) make `mesh.ply`, and
//! `chamfer` compares it with the true torus (`truth.ply`, a fine mesh of the
//! exact surface; the mean distance of the mesh vertices to the exact torus
//! is reported too); one view of the splats and of the mesh is rendered.
//!
//! Part 1b, SuGaR's second half: Gaussians bound to that mesh (one per
//! face, colours from the scene) are refined against renders of the scene
//! (`bound.ply`, `refined_bound.ply`; held-out PSNR before and after).
//!
//! Part 2, the triangle tools ([`demo_soup`](crate::geom::scenes::synthetic::demo_soup)): a torus tiled with solid,
//! opaque triangles (α = 0.95, σ = 0.5) coloured by angle with SH degree 3,
//! plus "floaters" — random triangles that are either transparent (α = 0.2)
//! or soft (σ = 3) — as training leaves them. The run writes the scene as a
//! Triangle Splatting checkpoint and a soup PLY, prunes it with the
//! game-engine preset, and exports OFF and GLB; the pruned count must equal
//! the torus's triangle count (every floater removed, every surface triangle
//! kept), which the demo checks.

use std::path::{Path, PathBuf};

use anyhow::{Context, ensure};
use clap::Args;
use serde_json::json;

use std::time::Instant;

use glam::DVec3;
use indicatif::ProgressBar;
use splatkit_render::gaussian::{self, Gaussians3, RasterSettings};

use crate::cli::Common;
use crate::eval::chamfer::{GenericParams, GenericReport, SampleMode, chamfer_generic, mesh_cloud};
use crate::geom::binding::{self, BindOptions};
use crate::geom::mesh_ops::clean::ComponentFilter;
use crate::geom::mesh_ops::cleanup::{CleanSteps, clean_mesh};
use crate::geom::mesh_ops::prune::{PruneParams, PruneReport, prune};
use crate::geom::meshing::poisson::pipeline::{PipelineOptions, run_pipeline};
use crate::geom::meshing::soup_mesh::{ExportParams, soup_to_mesh};
use crate::geom::scenes::orbit::{OrbitRing, orbit_cameras};
use crate::geom::scenes::synthetic::{Torus, demo_soup};
use crate::geom::surface_points::levelset::{LevelsetOptions, sample_levelset, to_point_cloud};
use crate::io::cameras::write_gs_json;
use crate::io::describe::{FileInfo, describe, render_text};
use crate::io::gltf::{GltfWriteOptions, write_gltf};
use crate::io::image::{to_u8, write_png8};
use crate::io::off::{OffWriteOptions, write_off};
use crate::io::ply;
use crate::io::ply::points::write_points;
use crate::io::ply::{Format, soup::write_soup};
use crate::io::{StagedDir, torch_pt, write_output};
use crate::model::{BoundGaussians, Camera, Gaussians, Mesh, PointCloud, TriangleSoup};
use crate::train::refine::{LearningRates, RefineParams, Refiner, spatial_lr_scale};
use crate::train::trainer::Trainer;

/// Command-line arguments of `demo`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  splatkit demo                 # writes splatkit-demo/
  splatkit demo -o /tmp/d --seed 7 --views 24 --json")]
pub struct DemoArgs {
    /// Output folder (created if needed).
    #[arg(short, long, default_value = "splatkit-demo")]
    pub output: PathBuf,
    /// Seed of the generated scenes and of the sampling.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Cameras around the Gaussian torus (2 to 10000; 1 is taken as 2).
    #[arg(long, default_value_t = 16,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=10_000))]
    pub views: usize,
    /// Image size (square) of those cameras, pixels (at least 1; refused
    /// beyond the memory budget).
    #[arg(long, default_value_t = 256,
          value_parser = clap::builder::RangedU64ValueParser::<u32>::new().range(1..))]
    pub size: u32,
    /// Poisson depth (2 to 16, as `poisson --depth`).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(2..=16))]
    pub depth: u32,
    /// Refinement iterations of the bound Gaussians (SuGaR's second half).
    #[arg(long, default_value_t = 300)]
    pub refine_iterations: u64,
    /// Faces of the mesh the Gaussians are bound to (the Poisson mesh is
    /// decimated to this count first).
    #[arg(long, default_value_t = 10_000)]
    pub bind_faces: usize,
    /// Torus segments around the ring of the triangle scene (triangles =
    /// segments² roughly; at least 3; refused beyond the memory budget).
    #[arg(long, default_value_t = 96,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(3..))]
    pub segments: usize,
    #[command(flatten)]
    pub common: Common,
}

/// One line of the demo's table: stage, result, seconds.
type StageRow = (String, String, f64);

/// The Gaussian torus of part 1.
pub const DEMO_TORUS: Torus = Torus {
    major: 1.0,
    minor: 0.35,
};

/// Part 1's generated scene: the Gaussian torus as stored (`raw`) and
/// ready to rasterise (`g`), the cameras of two rings around it, and the
/// fine mesh of the exact torus (`truth`).
struct DemoScene {
    raw: Gaussians,
    g: Gaussians3,
    cams: Vec<Camera>,
    truth: Mesh,
}

/// Part 1: Gaussians → points → mesh → score, files written into `dir`.
/// Returns the JSON report and the table rows (stage, result, seconds).
fn gaussian_part(
    args: &DemoArgs,
    dir: &Path,
) -> anyhow::Result<(serde_json::Value, Vec<StageRow>)> {
    let mut rows = Vec::new();
    let scene = generate(args, dir, &mut rows)?;
    let cloud = level_set_points(args, dir, &scene, &mut rows)?;
    let mesh = mesh_points(args, dir, cloud, &mut rows)?;
    let (report, exact) = score(args, &mesh, &scene.truth, &mut rows)?;
    render_side_by_side(dir, &scene, &mesh, &mut rows)?;
    let refined = bind_and_refine(args, dir, &scene, &mesh, &mut rows)?;
    let json = json!({
        "bind_refine": refined,
        "gaussians": scene.g.len(),
        "cameras": scene.cams.len(),
        "points": rows[1].1,
        "mesh_vertices": mesh.vertices.len(),
        "mesh_faces": mesh.faces.len(),
        "chamfer": report,
        "mean_vertex_distance_to_torus": exact,
        "stages": rows.iter().map(|r| json!({"stage": r.0, "result": r.1, "seconds": r.2})).collect::<Vec<_>>(),
    });
    Ok((json, rows))
}

/// Stage "generate": the Gaussian torus ([`DEMO_TORUS`], 300 floaters,
/// `--seed`), `--views` cameras of `--size` on two rings (35° above and
/// below, radius 3.6) and the exact torus; writes `scene.ply`,
/// `cameras.json` and `truth.ply`.
fn generate(args: &DemoArgs, dir: &Path, rows: &mut Vec<StageRow>) -> anyhow::Result<DemoScene> {
    let t = Instant::now();
    let raw = DEMO_TORUS.gaussians(160, 56, 0.004, 300, args.seed);
    let g = raw.to_raster();
    // two rings, above and below, so every side of the torus is seen
    let ring = |n: usize, elevation: f64| {
        orbit_cameras(
            &DEMO_TORUS.mesh(64, 24).vertices,
            &OrbitRing {
                views: n,
                width: args.size,
                height: args.size,
                fov_deg: 50.0,
                elevation_deg: elevation,
                radius: Some(3.6),
                up: DVec3::Y,
            },
        )
    };
    let views = args.views.max(2);
    let mut cams = ring(views - views / 2, 35.0)?;
    for (k, mut c) in ring(views / 2, -35.0)?.into_iter().enumerate() {
        c.name = format!("below_{k:03}");
        cams.push(c);
    }
    write_output(&dir.join("scene.ply"), |w| {
        ply::gaussians::write_gaussians(w, &raw, Format::BinaryLittleEndian)
    })?;
    write_gs_json(&dir.join("cameras.json"), &cams)?;
    let truth = DEMO_TORUS.mesh(720, 240);
    write_output(&dir.join("truth.ply"), |w| {
        ply::mesh::write_mesh(w, &truth, Format::BinaryLittleEndian)
    })?;
    rows.push((
        "generate".into(),
        format!(
            "{} Gaussians ({} floaters), {} cameras",
            g.len(),
            300,
            cams.len()
        ),
        t.elapsed().as_secs_f64(),
    ));
    Ok(DemoScene {
        raw,
        g,
        cams,
        truth,
    })
}

/// Stage "splat2points": SuGaR's level-set points (level 0.3, at most a
/// million, `--seed`) of the scene from every camera; writes `points.ply`.
fn level_set_points(
    args: &DemoArgs,
    dir: &Path,
    scene: &DemoScene,
    rows: &mut Vec<StageRow>,
) -> anyhow::Result<PointCloud> {
    let t = Instant::now();
    let opts = LevelsetOptions {
        max_points: 1_000_000,
        seed: args.seed,
        ..Default::default()
    };
    let pts = sample_levelset(&scene.g, &scene.cams, &opts, |_| ())?;
    let cloud = to_point_cloud(pts, false);
    write_output(&dir.join("points.ply"), |w| {
        write_points(w, &cloud, Format::BinaryLittleEndian)
    })?;
    rows.push((
        "splat2points".into(),
        format!("{} points (level 0.3)", cloud.positions.len()),
        t.elapsed().as_secs_f64(),
    ));
    Ok(cloud)
}

/// Stages "poisson" (depth `--depth`) and "clean" (the largest
/// component kept): the mesh of the points; writes `mesh.ply`.
fn mesh_points(
    args: &DemoArgs,
    dir: &Path,
    cloud: PointCloud,
    rows: &mut Vec<StageRow>,
) -> anyhow::Result<Mesh> {
    let t = Instant::now();
    let mut popt = PipelineOptions::default();
    popt.params.depth = args.depth;
    let rec = run_pipeline(cloud, &popt)?;
    rows.push((
        "poisson".into(),
        format!(
            "{} vertices, {} faces (depth {})",
            rec.mesh.vertices.len(),
            rec.mesh.faces.len(),
            args.depth
        ),
        t.elapsed().as_secs_f64(),
    ));
    let t = Instant::now();
    let mut mesh = rec.mesh;
    let steps = CleanSteps {
        components: ComponentFilter {
            keep_largest: Some(1),
            ..Default::default()
        },
        ..Default::default()
    };
    clean_mesh(&mut mesh, &steps);
    write_output(&dir.join("mesh.ply"), |w| {
        ply::mesh::write_mesh(w, &mesh, Format::BinaryLittleEndian)
    })?;
    rows.push((
        "clean".into(),
        format!(
            "{} vertices, {} faces",
            mesh.vertices.len(),
            mesh.faces.len()
        ),
        t.elapsed().as_secs_f64(),
    ));
    Ok(mesh)
}

/// Stage "chamfer": the mesh against the exact torus's mesh (200,000
/// area samples each, thresholds 0.01 and 0.02, `--seed`), and the mean
/// distance of the mesh's vertices to the exact torus (scene units).
fn score(
    args: &DemoArgs,
    mesh: &Mesh,
    truth: &Mesh,
    rows: &mut Vec<StageRow>,
) -> anyhow::Result<(GenericReport, f64)> {
    let t = Instant::now();
    let cp = GenericParams {
        sample: SampleMode::Area,
        count: 200_000,
        thresholds: vec![0.01, 0.02],
        seed: args.seed,
        ..GenericParams::vertices()
    };
    let report = chamfer_generic(&mesh_cloud(mesh, &cp)?, &mesh_cloud(truth, &cp)?, &cp)?;
    let exact: f64 = mesh
        .vertices
        .iter()
        .map(|v| DEMO_TORUS.distance(v.map(f64::from)))
        .sum::<f64>()
        / mesh.vertices.len().max(1) as f64;
    rows.push((
        "chamfer".into(),
        format!(
            "Chamfer-L1 {:.4} (acc {:.4}, comp {:.4}); vertices to exact torus {:.4}",
            report.chamfer_l1, report.accuracy.mean, report.completeness.mean, exact
        ),
        t.elapsed().as_secs_f64(),
    ));
    Ok((report, exact))
}

/// Stage "render": the first camera's view of the splats (white
/// background) beside the lit mesh, written as `view.png`.
fn render_side_by_side(
    dir: &Path,
    scene: &DemoScene,
    mesh: &Mesh,
    rows: &mut Vec<StageRow>,
) -> anyhow::Result<()> {
    let t = Instant::now();
    let view = &scene.cams[0];
    let s = RasterSettings {
        background: [1.0; 3],
        near: 0.2,
        ..Default::default()
    };
    let splats = gaussian::render(&scene.g, view, &s);
    let z = splatkit_render::mesh::render(&mesh.vertices, &mesh.faces, view, 0.2);
    let (w, h) = (view.width as usize, view.height as usize);
    let mut side = vec![255u8; 2 * w * h * 3];
    for y in 0..h {
        for x in 0..w {
            let o = y * w + x;
            let left = splats.rgb[o].map(to_u8);
            let shade = if z.face[o] == splatkit_render::mesh::NO_FACE {
                255
            } else {
                to_u8(0.2 + 0.8 * (-z.normal[o][2]).max(0.0))
            };
            let base = (y * 2 * w + x) * 3;
            side[base..base + 3].copy_from_slice(&left);
            side[base + 3 * w..base + 3 * w + 3].copy_from_slice(&[shade; 3]);
        }
    }
    write_output(&dir.join("view.png"), |wr| {
        write_png8(wr, "view.png", 2 * w, h, 3, &side)
    })?;
    rows.push((
        "render".into(),
        "view.png: splats | mesh".into(),
        t.elapsed().as_secs_f64(),
    ));
    Ok(())
}

/// Part 1b, SuGaR's second half: Gaussians bound to the cleaned mesh,
/// decimated to `--bind-faces` (1 per face, colours from the scene), refined for `--refine-iterations` against
/// renders of the scene from the same cameras (every 8th held out); writes
/// `bound.ply` and `refined_bound.ply` and reports held-out PSNR.
fn bind_and_refine(
    args: &DemoArgs,
    dir: &Path,
    scene: &DemoScene,
    mesh: &Mesh,
    rows: &mut Vec<StageRow>,
) -> anyhow::Result<serde_json::Value> {
    let (b, extent) = bind_stage(args, dir, scene, mesh, rows)?;
    refine_stage(args, dir, scene, b, extent, rows)
}

/// Stage "bind": the mesh decimated to `--bind-faces`, one Gaussian per
/// face (thickness 1e-6 × the cameras' extent, SH degree 3), coloured from
/// the scene's Gaussians; writes `bound.ply`. Returns the bound Gaussians
/// and the cameras' extent (NeRF++ radius, scene units; 1 when undefined).
fn bind_stage(
    args: &DemoArgs,
    dir: &Path,
    scene: &DemoScene,
    mesh: &Mesh,
    rows: &mut Vec<StageRow>,
) -> anyhow::Result<(BoundGaussians, f64)> {
    let t = Instant::now();
    let (mesh, _) = crate::geom::mesh_ops::decimate::decimate(
        mesh,
        crate::geom::mesh_ops::decimate::Target::Faces(args.bind_faces),
    )?;
    let centres: Vec<[f64; 3]> = scene.cams.iter().map(|c| c.center().to_array()).collect();
    let extent = crate::model::rig::nerfpp_radius(&centres).unwrap_or(1.0);
    let mut b = binding::bind(
        &mesh,
        &BindOptions {
            per_face: 1,
            thickness: (extent * binding::THICKNESS_FACTOR) as f32,
            sh_degree: 3,
        },
        None,
    )
    .map_err(|m| anyhow::anyhow!("binding the demo mesh: {m}"))?;
    let at: Vec<[f64; 3]> = (0..b.len()).map(|i| binding::mean_of(&b, i)).collect();
    b.sh_dc = binding::colors::dc_from_gaussians(&at, &scene.raw)?;
    save_bound_ply(dir, "bound.ply", &b)?;
    rows.push((
        "bind".into(),
        format!(
            "bound.ply: {} Gaussians, 1 per face of the mesh decimated to {} faces",
            b.len(),
            mesh.faces.len()
        ),
        t.elapsed().as_secs_f64(),
    ));
    Ok((b, extent))
}

/// Stage "refine": `b` refined for `--refine-iterations` against renders
/// of the scene's Gaussians from every camera (every 8th held out, black
/// background, `--seed`); writes `refined_bound.ply`. Returns the report's
/// `bind_refine` entry (held-out PSNR in dB and SSIM, before and after).
fn refine_stage(
    args: &DemoArgs,
    dir: &Path,
    scene: &DemoScene,
    b: BoundGaussians,
    extent: f64,
    rows: &mut Vec<StageRow>,
) -> anyhow::Result<serde_json::Value> {
    let t = Instant::now();
    let s = RasterSettings::default();
    let views: Vec<crate::model::View> = scene
        .cams
        .iter()
        .map(|c| crate::model::View {
            camera: c.clone(),
            image: gaussian::render(&scene.g, c, &s).rgb,
            mask: None,
            alpha: None,
            source: c.name.clone(),
        })
        .collect();
    let (train, test) = crate::train::schedule::split(views.len(), 8);
    let params = RefineParams {
        background: [0.0; 3],
        normal_consistency: 0.1,
        sh_warmup: 1000,
        lr: LearningRates::default(),
        spatial_lr_scale: spatial_lr_scale(extent, b.mesh.vertices.len()),
        seed: args.seed,
    };
    let mut r = Refiner::new(b, params);
    let before = r.evaluate(&views, &test);
    for _ in 0..args.refine_iterations {
        r.step(&views, &train);
    }
    let after = r.evaluate(&views, &test);
    save_bound_ply(dir, "refined_bound.ply", &r.model)?;
    rows.push((
        "refine".into(),
        format!(
            "refined_bound.ply: {} iterations, held-out PSNR {:.2} -> {:.2} dB",
            args.refine_iterations, before.psnr, after.psnr
        ),
        t.elapsed().as_secs_f64(),
    ));
    Ok(json!({
        "gaussians": r.model.len(),
        "iterations": args.refine_iterations,
        "test_views": test.len(),
        "psnr_before": before.psnr,
        "psnr_after": after.psnr,
        "ssim_before": before.ssim,
        "ssim_after": after.ssim,
    }))
}

/// Writes `b` as the bound 3DGS PLY `dir/name`.
fn save_bound_ply(dir: &Path, name: &str, b: &BoundGaussians) -> anyhow::Result<()> {
    let file = ply::bound::attach(b, binding::materialize(b));
    write_output(&dir.join(name), |w| {
        ply::gaussians::write_gaussians(w, &file, Format::BinaryLittleEndian)
    })?;
    Ok(())
}

/// Bytes per pixel of every demo view held at once: the reference render
/// kept as the refinement's photo (3 × f32 = 12).
pub const DEMO_HELD_BYTES_PER_PIXEL: u64 = 12;
/// Bytes per pixel of the one view a demo stage works on, the largest of
/// its stages: a refinement step (render 64, L1 and SSIM gradients 384,
/// image gradients 32, normal consistency 48 = 528; the level-set sampling
/// takes 96 and the side-by-side picture 98).
pub const DEMO_WORK_BYTES_PER_PIXEL: u64 = 528;
/// Bytes per triangle of the demo's triangle scene: the soup (vertices 36,
/// opacity 4, σ 4, SH 12 + 180 = 236) twice for the growth of its vectors,
/// the pruned copy (236), the exported mesh (unwelded vertices 36 + face 12)
/// and the encoded glTF buffer (48): 1,028, rounded up to 1,056.
pub const DEMO_BYTES_PER_TRIANGLE: u64 = 1056;

/// Bytes the demo's views take for `views` cameras of `size`×`size`:
/// size² × (views × [`DEMO_HELD_BYTES_PER_PIXEL`] +
/// [`DEMO_WORK_BYTES_PER_PIXEL`]); saturating.
pub fn demo_image_bytes(views: usize, size: u32) -> u64 {
    let px = u64::from(size) * u64::from(size);
    let per = (views.max(2) as u64)
        .saturating_mul(DEMO_HELD_BYTES_PER_PIXEL)
        .saturating_add(DEMO_WORK_BYTES_PER_PIXEL);
    px.saturating_mul(per)
}

/// The triangles [`demo_soup`] makes for `segments`: 2·nu·nv with nu =
/// max(segments, 3), nv = max(segments / 2, 3) (the floaters, a fixed few
/// hundred, are covered by the rounding of [`DEMO_BYTES_PER_TRIANGLE`]).
pub fn demo_triangles(segments: usize) -> u64 {
    let (nu, nv) = (segments.max(3) as u64, (segments / 2).max(3) as u64);
    nu.saturating_mul(nv).saturating_mul(2)
}

/// Refuses `--views`, `--size` and `--segments` whose buffers exceed the
/// memory budget (a usage error naming the flags, the estimate and the
/// budget), before anything is made.
fn check_budget(args: &DemoArgs) -> anyhow::Result<()> {
    let as_usage = |e: crate::Error| crate::cli::usage(e.to_string());
    crate::io::budget::check(
        &format!(
            "--views {} --size {}: the demo's images ({} views of {}x{} held, and the buffers of one)",
            args.views, args.size, args.views.max(2), args.size, args.size
        ),
        demo_image_bytes(args.views, args.size),
    )
    .map_err(as_usage)?;
    let t = demo_triangles(args.segments);
    crate::io::budget::check(
        &format!(
            "--segments {}: the triangle scene ({t} triangles)",
            args.segments
        ),
        t.saturating_mul(DEMO_BYTES_PER_TRIANGLE),
    )
    .map_err(as_usage)
}

/// Runs the demo.
pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    args.common.init()?;
    check_budget(&args)?;
    // Everything is written into a staging folder that becomes the output
    // only when both parts (and their self-checks) succeeded.
    let staged = StagedDir::new(&args.output)
        .with_context(|| format!("creating {}", args.output.display()))?;
    let (gauss_json, rows) = gaussian_part(&args, staged.path())?;
    let (soup, surface) = demo_soup(args.seed, args.segments);
    let pb = args.common.progress(5, "demo");
    let part2 = triangle_part(&args, staged.path(), &soup, surface, &pb)?;
    staged.commit()?;
    pb.finish_and_clear();
    if !args.common.quiet && !args.common.json_to_stdout() {
        print_summary(&args, &rows, &soup, surface, &part2);
    }
    args.common.emit_json(&json!({
        "output": shown_dir(&args.output),
        "gaussian_pipeline": gauss_json,
        "triangles": soup.len(),
        "surface_triangles": surface,
        "prune": part2.report,
        "exported_vertices": part2.mesh.vertices.len(),
        "exported_faces": part2.mesh.faces.len(),
        "files": part2.infos,
    }))
}

/// What part 2 made: the prune report, the exported mesh and the
/// descriptions of its files.
struct TrianglePart {
    report: PruneReport,
    mesh: Mesh,
    infos: Vec<FileInfo>,
}

/// Part 2: the triangle scene `soup` (`surface` of its triangles on the
/// torus) written as `scene.pt` and `scene_soup.ply`, pruned with the
/// game-engine preset (`solid.pt`; the self-check: exactly the surface is
/// kept) and exported as `solid.off` and `solid.glb`, into `dir`; `pb`
/// advances after each of the four steps.
fn triangle_part(
    args: &DemoArgs,
    dir: &Path,
    soup: &TriangleSoup,
    surface: usize,
    pb: &ProgressBar,
) -> anyhow::Result<TrianglePart> {
    let out = |f: &str| -> PathBuf { dir.join(f) };
    write_output(&out("scene.pt"), |w| {
        torch_pt::write_triangle_checkpoint(w, soup)
    })?;
    write_output(&out("scene_soup.ply"), |w| {
        write_soup(w, soup, Format::BinaryLittleEndian)
    })?;
    pb.inc(1);
    let game = PruneParams {
        min_opacity: Some(0.7),
        max_sigma: Some(1.0),
        max_count: None,
        solidify: true,
    };
    let (solid, report) = prune(soup, &game);
    ensure!(
        report.kept == surface,
        "demo self-check failed: pruning kept {} triangles, the torus has {surface}",
        report.kept
    );
    write_output(&out("solid.pt"), |w| {
        torch_pt::write_triangle_checkpoint(w, &solid)
    })?;
    pb.inc(1);
    let mesh = soup_to_mesh(&solid, &ExportParams::default());
    write_output(&out("solid.off"), |w| {
        write_off(w, &mesh, &OffWriteOptions::triangle_splatting())
    })?;
    pb.inc(1);
    write_output(&out("solid.glb"), |w| {
        write_gltf(w, &mesh, &GltfWriteOptions::default())
    })?;
    pb.inc(1);
    // Described from the staging folder: the files land when the run's
    // outputs are committed, after this function returns.
    let infos: Vec<_> = ["scene.pt", "solid.off", "solid.glb"]
        .iter()
        .map(|f| {
            describe(&out(f)).map(|mut i| {
                i.path = args.output.join(f).display().to_string();
                i
            })
        })
        .collect::<crate::Result<_>>()?;
    Ok(TrianglePart {
        report,
        mesh,
        infos,
    })
}

/// The human summary on stderr: part 1's table of stages, part 2's
/// counts and file descriptions, and the list of outputs.
fn print_summary(
    args: &DemoArgs,
    rows: &[StageRow],
    soup: &TriangleSoup,
    surface: usize,
    part2: &TrianglePart,
) {
    eprintln!(
        "demo, part 1: Gaussian torus -> points -> mesh -> score -> bound Gaussians -> refined"
    );
    eprintln!("  {:<13} {:<78} {:>8}", "stage", "result", "seconds");
    for (stage, result, secs) in rows {
        eprintln!("  {stage:<13} {result:<78} {secs:>8.2}");
    }
    eprintln!(
        "demo, part 2: generated {} triangles ({} on a torus, {} floaters); prune kept {}; exported {} vertices / {} faces",
        soup.len(),
        surface,
        soup.len() - surface,
        part2.report.kept,
        part2.mesh.vertices.len(),
        part2.mesh.faces.len()
    );
    for i in &part2.infos {
        eprint!("{}", render_text(i));
    }
    eprintln!(
        "outputs in {}: scene.ply cameras.json truth.ply points.ply mesh.ply view.png bound.ply refined_bound.ply (part 1), scene.pt scene_soup.ply solid.pt solid.off solid.glb (part 2)",
        shown_dir(&args.output)
    );
}

fn shown_dir(p: &Path) -> String {
    p.display().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`demo_triangles`] counts the torus triangles [`demo_soup`] makes,
    /// and the floaters fit in the rounding of the bytes per triangle.
    #[test]
    fn demo_triangle_estimate_covers_the_soup() {
        for seg in [3usize, 7, 96, 200] {
            let (soup, surface) = demo_soup(1, seg);
            assert_eq!(demo_triangles(seg), surface as u64, "{seg}");
            let bytes = soup.triangles.len() * 36 + soup.sh_rest.len() * 4 + soup.len() * 20;
            assert!(
                demo_triangles(seg) * DEMO_BYTES_PER_TRIANGLE >= 2 * bytes as u64,
                "{seg}"
            );
        }
        assert_eq!(demo_triangles(usize::MAX), u64::MAX);
        assert_eq!(demo_image_bytes(16, 256), 65536 * (16 * 12 + 528));
    }
}
