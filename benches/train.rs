//! Training iterations per second (Triangle Splatting and 3DGS) with a
//! stage profile of one iteration.
//!
//! Scene, generated here: 200,000 seed points on the unit sphere
//! ([`sphere_points`]), made into triangles by [`init_triangles`] (Triangle
//! Splatting's init: one triangle per seed, sized by its 3 nearest seeds)
//! and Gaussians by [`init_gaussians`] (3DGS's init), SH degree 3 with small
//! non-zero higher bands. Photos: [`textured_photos`] of a 48-ring sphere
//! from 4 cameras of [`cameras_around`] at distance 3 with a 50° horizontal
//! field of view, at 400×300 and 800×600 (the sphere fills ~70% of the
//! image height).
//!
//! The trainers are set to where the SH warm-up has ended and densification
//! is between two events, so every measured step is a plain one at full SH
//! degree (3):
//! - triangles: 30,000 iterations, resumed at iteration 5,000 (active degree
//!   3, the normal-consistency term on, the size term on, densification
//!   every 500: none before 5,500);
//! - Gaussians: 30,000 iterations, vanilla 3DGS, resumed at 3,000 (active
//!   degree 3, densification statistics gathered, densification every 100:
//!   none before 3,100).
//!
//! Per case: the stage profile replicates `step` with the same public
//! functions (to raster, forward, loss, normal consistency, backward,
//! per-primitive statistics, raw gradients + regularisers, Adam, the rest),
//! mean of `iters` iterations after one warm-up; then the real `step()` end
//! to end, mean of `iters` after one warm-up, so the profile's sum can be
//! checked against the true total. The primitive count is checked to be
//! unchanged (no densification happened).
//!
//! Every measured iteration starts from the initial model (a fresh trainer
//! resumed at the start iteration + k, built outside the timing): resumed
//! with zero Adam moments at step 5,000 the first updates are ≈ 3·lr·sign(g)
//! per coordinate (no bias correction left), which moves each vertex by a
//! third of a triangle per step; left to run, the triangles grow and the
//! iteration slows down by 2–3× within 5 steps, which measures the
//! artefact, not training.
//!
//! Run: `cargo bench --bench train` (all cases) or
//! `cargo bench --bench train -- [--quick] [--iters N] [FILTER...]` where a
//! FILTER is a substring of a case name (`triangles/400x300`,
//! `gaussians/800x600`, ...); `--default-malloc` leaves glibc malloc at its
//! defaults instead of calling [`keep_freed_memory`] as `train` does.
//! `SPLATKIT_BENCH_QUICK=1` = `--quick` (2,000
//! primitives at 80×60, 2 iterations: a smoke run). Threads: the rayon
//! pool (`RAYON_NUM_THREADS`). `scripts/bench_train.sh OUT` runs it on 2
//! threads.

mod common;

use std::time::Instant;

use common::peak_mb;
use splatkit::cli::memory::keep_freed_memory;
use splatkit::model::{Camera, Gaussians, TriangleSoup, View};
use splatkit::testing::{cameras_around, sphere_points, textured_photos, uv_sphere};
use splatkit::train::gaussians::adc::AdcState;
use splatkit::train::gaussians::init::init_gaussians;
use splatkit::train::gaussians::{self, GaussianParams, GaussianTrainer};
use splatkit::train::groups::{GroupSpec, Groups};
use splatkit::train::photometric::{loss_and_grad_weighted, psnr_of};
use splatkit::train::schedule::view_at;
use splatkit::train::trainer::Trainer;
use splatkit::train::triangles::init::{InitParams, init_triangles};
use splatkit::train::triangles::mcmc::McmcState;
use splatkit::train::triangles::{self, Preset, TriangleParams, TriangleTrainer, size_loss};
use splatkit_render::depth_normal::normal_consistency;
use splatkit_render::gaussian::RasterSettings;
use splatkit_render::optim::LrSchedule;
use splatkit_render::triangle_stats::triangle_stats;
use splatkit_render::{gaussian, gaussian_grad, triangle, triangle_grad};

/// Reference run length the trainers are configured with.
const ITERATIONS: u64 = 30_000;
/// Resume points (see the module docs).
const TRI_START: u64 = 5_000;
const GS_START: u64 = 3_000;
const VIEWS: usize = 4;

struct Opts {
    quick: bool,
    /// Leave glibc malloc at its defaults (the `train` command calls
    /// [`keep_freed_memory`]; this measures what that saves).
    default_malloc: bool,
    iters: usize,
    filters: Vec<String>,
}

fn opts() -> Opts {
    let mut o = Opts {
        quick: std::env::var_os("SPLATKIT_BENCH_QUICK").is_some_and(|v| v != "0"),
        default_malloc: false,
        iters: 0,
        filters: Vec::new(),
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--quick" => o.quick = true,
            "--default-malloc" => o.default_malloc = true,
            "--iters" => {
                o.iters = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .expect("--iters N (a positive integer)")
            }
            "--bench" => {}
            s if s.starts_with('-') => {} // cargo's own flags
            s => o.filters.push(s.to_string()),
        }
    }
    if o.iters == 0 {
        o.iters = if o.quick { 2 } else { 5 };
    }
    // warm-up + iters steps must stay before the next densification (every
    // 100 iterations for the Gaussians)
    assert!(o.iters < 99, "--iters must be below 99");
    o
}

/// Stage timer: accumulates seconds per named stage, in first-seen order.
#[derive(Default)]
struct Profile {
    stages: Vec<(&'static str, f64)>,
    t: Option<Instant>,
}

impl Profile {
    fn start(&mut self) {
        self.t = Some(Instant::now());
    }
    /// Ends the running stage as `name` and starts the next.
    fn lap(&mut self, name: &'static str) {
        let now = Instant::now();
        let dt = (now - self.t.expect("started")).as_secs_f64();
        match self.stages.iter_mut().find(|s| s.0 == name) {
            Some(s) => s.1 += dt,
            None => self.stages.push((name, dt)),
        }
        self.t = Some(now);
    }
    fn reset(&mut self) {
        self.stages.clear();
    }
    /// Mean per iteration, "rest" last.
    fn per_iter(mut self, iters: usize) -> Vec<(&'static str, f64)> {
        self.stages.sort_by_key(|s| s.0 == "rest");
        self.stages
            .into_iter()
            .map(|(k, v)| (k, v / iters as f64))
            .collect()
    }
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// `VIEWS` cameras at distance 3 with a 50° horizontal field of view, `w`×`h`.
fn cameras(w: u32, h: u32) -> Vec<Camera> {
    let f = w as f64 / 2.0 / 25f64.to_radians().tan();
    cameras_around(VIEWS, 3.0, w, f)
        .into_iter()
        .map(|mut c| {
            c.height = h;
            c.cy = h as f64 / 2.0;
            c
        })
        .collect()
}

fn sh_rest_pattern(rest: &mut [f32]) {
    for (i, x) in rest.iter_mut().enumerate() {
        *x = 0.02 * ((i as f32) * 0.618).sin();
    }
}

/// Same widths as the trainer's groups (the learning rates do not change
/// the cost).
fn specs(widths: &[(&'static str, usize)]) -> Vec<GroupSpec> {
    widths
        .iter()
        .map(|&(name, width)| GroupSpec {
            name,
            width,
            lr: LrSchedule::Constant(1e-3),
        })
        .collect()
}

struct CaseResult {
    case: String,
    count: usize,
    profile: Vec<(&'static str, f64)>,
    step_s: f64,
}

/// The stage profile of `TriangleTrainer::step` (same calls, same order).
fn profile_triangles(
    soup0: &TriangleSoup,
    p: &TriangleParams,
    views: &[View],
    iters: usize,
) -> Vec<(&'static str, f64)> {
    let train: Vec<usize> = (0..views.len()).collect();
    let n = soup0.len();
    let s = RasterSettings {
        background: p.background,
        ..Default::default()
    };
    let mut prof = Profile::default();
    for it in 0..=iters {
        if it == 1 {
            prof.reset(); // iteration 0 is the warm-up
        }
        // every iteration starts from the initial model (untimed, see the
        // module docs)
        let iteration = TRI_START + it as u64;
        let mut soup = soup0.clone();
        let mut groups = Groups::new(
            specs(&[
                ("vertices", 9),
                ("sh_dc", 3),
                ("sh_rest", soup.rest_per_channel() * 3),
                ("opacity", 1),
                ("sigma", 1),
            ]),
            n,
        );
        // as the trainer's restore: moments copied (touched), not calloc'd
        let st = groups.state();
        groups.restore(iteration, &st, n).expect("same groups");
        let mut mcmc = McmcState::new(n);
        prof.start();
        let vi = view_at(&train, p.seed, iteration);
        let view = &views[vi];
        soup.active_sh_degree = 3;
        let p = p.clone();
        prof.lap("rest");
        let t3 = soup.to_raster();
        prof.lap("to raster (SH, σ, α)");
        let (img, state) = triangle::rasterize(&t3, &view.camera, &s);
        prof.lap("forward rasterise");
        let (_photo, d_rgb) = loss_and_grad_weighted(&img.rgb, view, 1.0 - p.lambda_dssim);
        let _psnr = psnr_of(&img.rgb, view);
        prof.lap("loss (L1+SSIM, grad, PSNR)");
        let normal_on = p.lambda_normals > 0.0 && iteration + 1 > p.at(5_000);
        let (d_normal, d_depth) = if normal_on {
            let (_l, gn, gd) = normal_consistency(
                &img.normal_sum,
                &img.expected_depth,
                &img.alpha,
                &view.camera,
            );
            let w = p.lambda_normals as f32;
            (
                gn.into_iter().map(|g| g.map(|v| v * w)).collect(),
                gd.into_iter().map(|g| g * w).collect(),
            )
        } else {
            (Vec::new(), Vec::new())
        };
        prof.lap("normal consistency");
        let aux = triangle_grad::AuxGrads {
            alpha: None,
            depth: normal_on.then_some(&d_depth[..]),
            normal: normal_on.then_some(&d_normal[..]),
        };
        let g = triangle_grad::backward_aux(&t3, &view.camera, &s, &state, &d_rgb, &aux);
        prof.lap("backward");
        let stats = triangle_stats(&t3, &view.camera, &s, &state);
        prof.lap("per-triangle stats");
        let mut pg = triangles::raw_grads(&soup, &g);
        // regularisers: opacity mean, size
        let nf = n.max(1) as f64;
        let _mean_o = (0..n).map(|i| soup.opacity(i) as f64).sum::<f64>() / nf;
        for (i, go) in pg.opacity.iter_mut().enumerate() {
            let o = soup.opacity(i) as f64;
            *go += (p.lambda_opacity / nf * o * (1.0 - o)) as f32;
        }
        if iteration + 1 < p.at(25_000) {
            size_loss(&soup.triangles, p.lambda_size, &mut pg.vertices);
        }
        prof.lap("raw grads + regularisers");
        pg.apply(&mut groups, &mut soup);
        prof.lap("Adam (5 groups)");
        mcmc.observe(&stats);
        drop((t3, img, state, g, stats));
        drop((d_rgb, d_normal, d_depth));
        prof.lap("rest");
    }
    prof.per_iter(iters)
}

/// The stage profile of `GaussianTrainer::step` (vanilla 3DGS between
/// densification events).
fn profile_gaussians(
    model0: &Gaussians,
    p: &GaussianParams,
    views: &[View],
    iters: usize,
) -> Vec<(&'static str, f64)> {
    let train: Vec<usize> = (0..views.len()).collect();
    let n = model0.len();
    let s = RasterSettings {
        background: p.background,
        ..Default::default()
    };
    let mut prof = Profile::default();
    for it in 0..=iters {
        if it == 1 {
            prof.reset(); // iteration 0 is the warm-up
        }
        let iteration = GS_START + it as u64;
        let mut m = model0.clone();
        let mut groups = Groups::new(
            specs(&[
                ("means", 3),
                ("sh_dc", 3),
                ("sh_rest", m.rest_per_channel() * 3),
                ("opacity", 1),
                ("scales", 3),
                ("rotations", 4),
            ]),
            n,
        );
        let st = groups.state();
        groups.restore(iteration, &st, n).expect("same groups");
        let mut adc = AdcState::new(n);
        prof.start();
        let p = p.clone();
        let vi = view_at(&train, p.seed, iteration);
        let view = &views[vi];
        let cam = &view.camera;
        let d = 3;
        prof.lap("rest");
        let g3 = m.to_raster_at(d);
        prof.lap("to raster (SH, σ, α)");
        let (img, state) = gaussian::rasterize(&g3, cam, &s);
        prof.lap("forward rasterise");
        let (_photo, d_rgb) = loss_and_grad_weighted(&img.rgb, view, 1.0 - p.lambda_dssim);
        let _psnr = psnr_of(&img.rgb, view);
        prof.lap("loss (L1+SSIM, grad, PSNR)");
        // the step allocates the (unused) regulariser gradients every time
        let reg = splatkit::train::sugar::RawGrads::zeros(n);
        prof.lap("rest");
        let aux = gaussian_grad::AuxGrads {
            alpha: None,
            depth: None,
            normal: None,
        };
        let gg = gaussian_grad::backward_aux(&g3, cam, &s, &state, &d_rgb, &aux);
        prof.lap("backward");
        if iteration + 1 < p.densify_until() {
            let radii = state.radii(n, cam.width as usize, cam.height as usize);
            adc.observe(&gg.means2d_ndc(cam.width, cam.height), &radii);
        }
        prof.lap("densification stats");
        // GaussianTrainer::apply
        let pg = gaussians::raw_grads(&m, &gg, &reg, d);
        prof.lap("raw grads + regularisers");
        pg.apply(&mut groups, &mut m);
        prof.lap("Adam (6 groups)");
        drop((g3, img, state, gg, reg, d_rgb));
        prof.lap("rest");
    }
    prof.per_iter(iters)
}

/// Mean seconds of `step` over `iters` iterations after one warm-up; `fresh(k)`
/// builds (untimed) the trainer for iteration k, `step` runs it.
fn time_steps<T>(
    iters: usize,
    mut fresh: impl FnMut(usize) -> T,
    mut step: impl FnMut(&mut T),
) -> f64 {
    let mut total = 0.0;
    for k in 0..=iters {
        let mut tr = fresh(k);
        let t = Instant::now();
        step(&mut tr);
        if k > 0 {
            total += t.elapsed().as_secs_f64();
        }
    }
    total / iters as f64
}

fn report(r: &CaseResult) {
    println!(
        "\n{} ({} primitives): real step() {:.1} ms = {:.2} it/s",
        r.case,
        r.count,
        r.step_s * 1e3,
        1.0 / r.step_s
    );
    println!("  {:<28} {:>10} {:>7}", "stage", "ms/iter", "share");
    let total: f64 = r.profile.iter().map(|s| s.1).sum();
    for (name, t) in &r.profile {
        println!(
            "  {:<28} {:>10.1} {:>6.1}%",
            name,
            t * 1e3,
            100.0 * t / total.max(1e-12)
        );
    }
    println!(
        "  {:<28} {:>10.1}         = {:.2} it/s (real step(): {:.1} ms, {:+.1}%)",
        "profile sum",
        total * 1e3,
        1.0 / total,
        r.step_s * 1e3,
        100.0 * (total / r.step_s - 1.0)
    );
}

fn main() {
    let o = opts();
    if !o.default_malloc && !keep_freed_memory() {
        println!("(the allocator refused keep_freed_memory's limits)");
    }
    let (n, sizes): (usize, Vec<(u32, u32)>) = if o.quick {
        (2_000, vec![(80, 60), (160, 120)])
    } else {
        (200_000, vec![(400, 300), (800, 600)])
    };
    println!(
        "env: {} | {} rayon threads | {} iterations per measurement | malloc {}{}",
        cpu_model(),
        rayon::current_num_threads(),
        o.iters,
        if o.default_malloc {
            "glibc defaults"
        } else {
            "keep_freed_memory"
        },
        if o.quick { " | QUICK (smoke run)" } else { "" }
    );
    let wanted = |case: &str| o.filters.is_empty() || o.filters.iter().any(|f| case.contains(f));
    let cases: Vec<(bool, (u32, u32))> = [true, false]
        .into_iter()
        .flat_map(|tri| sizes.iter().map(move |&s| (tri, s)))
        .filter(|&(tri, (w, h))| {
            wanted(&format!(
                "{}/{w}x{h}",
                if tri { "triangles" } else { "gaussians" }
            ))
        })
        .collect();
    if cases.is_empty() {
        eprintln!("no case matches {:?}", o.filters);
        std::process::exit(2);
    }
    let t = Instant::now();
    let points = sphere_points(n, 7);
    let need_tri = cases.iter().any(|c| c.0);
    let need_gs = cases.iter().any(|c| !c.0);
    let soup = need_tri.then(|| {
        let mut s = init_triangles(
            &points,
            &InitParams::default(),
            &mut splatkit::model::rng::seeded(7),
        )
        .expect("init triangles");
        sh_rest_pattern(&mut s.sh_rest);
        s
    });
    let gs = need_gs.then(|| {
        let mut g = init_gaussians(&points, 3).expect("init gaussians");
        sh_rest_pattern(&mut g.sh_rest);
        g
    });
    println!(
        "scene: {n} seeds on the unit sphere, init in {:.2} s",
        t.elapsed().as_secs_f64()
    );
    let truth = uv_sphere(48, 1.0);
    let mut results = Vec::new();
    for (w, h) in sizes.iter().copied() {
        if !cases.iter().any(|c| c.1 == (w, h)) {
            continue;
        }
        let t = Instant::now();
        let views = textured_photos(&truth, &cameras(w, h));
        println!(
            "photos: {VIEWS} views at {w}x{h} in {:.2} s",
            t.elapsed().as_secs_f64()
        );
        let train: Vec<usize> = (0..views.len()).collect();
        for &(tri, _) in cases.iter().filter(|c| c.1 == (w, h)) {
            if tri {
                let soup = soup.as_ref().expect("built");
                let mut p = TriangleParams::preset(Preset::Outdoor, ITERATIONS);
                p.seed = 1;
                let profile = profile_triangles(soup, &p, &views, o.iters);
                let step_s = time_steps(
                    o.iters,
                    |k| {
                        let mut tr = TriangleTrainer::new(soup.clone(), p.clone());
                        let (_, groups) = tr.optimizer_state();
                        tr.restore(TRI_START + k as u64, groups).expect("restore");
                        assert_eq!(tr.active_degree(), 3);
                        tr
                    },
                    |tr| {
                        tr.step(&views, &train);
                        assert_eq!(tr.soup.len(), soup.len(), "densification happened");
                    },
                );
                results.push(CaseResult {
                    case: format!("triangles/{w}x{h}"),
                    count: soup.len(),
                    profile,
                    step_s,
                });
            } else {
                let g = gs.as_ref().expect("built");
                let mut p = GaussianParams::new(ITERATIONS, None, 3.3);
                p.seed = 1;
                let profile = profile_gaussians(g, &p, &views, o.iters);
                let step_s = time_steps(
                    o.iters,
                    |k| {
                        let mut tr = GaussianTrainer::new(g.clone(), p.clone());
                        let (_, groups) = tr.optimizer_state();
                        tr.restore(GS_START + k as u64, groups).expect("restore");
                        assert_eq!(tr.active_degree(), 3);
                        tr
                    },
                    |tr| {
                        tr.step(&views, &train);
                        assert_eq!(tr.model.len(), g.len(), "densification happened");
                    },
                );
                results.push(CaseResult {
                    case: format!("gaussians/{w}x{h}"),
                    count: g.len(),
                    profile,
                    step_s,
                });
            }
            report(results.last().expect("pushed"));
        }
    }
    println!("\nsummary ({} threads):", rayon::current_num_threads());
    println!(
        "  {:<20} {:>10} {:>10} {:>10}",
        "case", "ms/iter", "it/s", "profile"
    );
    for r in &results {
        let total: f64 = r.profile.iter().map(|s| s.1).sum();
        println!(
            "  {:<20} {:>10.1} {:>10.2} {:>9.1}ms",
            r.case,
            r.step_s * 1e3,
            1.0 / r.step_s,
            total * 1e3
        );
    }
    println!("peak memory {:.0} MB", peak_mb());
}
