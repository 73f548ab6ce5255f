//! 3DGS training on the CPU Gaussian rasteriser, with SuGaR's coarse stage
//! (sugar.md §2, gaussian_training.md).
//!
//! Per iteration (one train view, seeded order):
//! 1. render at the active SH degree (one band per 1000 reference
//!    iterations) on the background;
//! 2. loss = 0.8·L1 + 0.2·(1 − SSIM) (masked), plus the SuGaR terms of the
//!    current phase;
//! 3. back-propagate (colour, and expected depth / accumulated normal where
//!    a regulariser reads them), add the regularisers' direct gradients,
//!    one Adam step per group (ε 1e-15): means 1.6e-4 → 1.6e-6 ×
//!    cameras_extent (log-linear over 30,000 reference iterations), SH DC
//!    2.5e-3, SH rest 2.5e-3/20, opacity 0.05, scales 0.005 (the 2023
//!    release SuGaR vendors), rotations 0.001;
//! 4. the densification strategies edit the model ([`adc::Adc`]: adaptive
//!    density control every 100 iterations from 500 until the end of
//!    densification, opacity reset every 3,000; SuGaR's prune,
//!    [`SugarPrune`]), moments and statistics following through
//!    [`crate::train::strategy::apply`]. The edits due after iteration N
//!    are made at the start of iteration N + 1, so what is evaluated,
//!    saved or checkpointed at N is the model before them, as in 3DGS's
//!    loop (its `training_report` and `scene.save` come before the
//!    densification block): a run of 3,000 iterations on the reference
//!    schedule otherwise ended on the opacity reset due at 3,000 (held-out
//!    8.8 dB after 40.7 at 2,000), and the last iteration's edits are
//!    never made.
//!
//! Phases (reference iterations):
//! - **vanilla 3DGS** (no `--regularize`): 30,000 iterations, densification
//!   until 15,000;
//! - **SuGaR coarse** (`regularize` set): 15,000 iterations in all:
//!   vanilla 3DGS with densification until 7,000; 7,000–9,000 the opacity
//!   entropy (weight 0.1); at 9,000 the hard prune α < 0.5 (skipped if it
//!   would remove every Gaussian); 9,000–15,000
//!   the surface regulariser: `density` (0.2 · R_density), `sdf`
//!   (0.2 · (R_sdf + 0.2 · R_normal), the depth map = this view's expected
//!   depth, with gradient) or `dn-consistency` (0.2 · R_density + 0.05 ·
//!   2DGS depth–normal consistency of the rendered normals and depth).
//!   The 16-nearest-neighbour table is rebuilt every 500 iterations.
//!
//! A run of N iterations scales every milestone by N / (30,000 or 15,000),
//! rounded (at least 1); at the reference length they are the reference's.
//! [`GaussianParams::reference_schedule`] (`--schedule reference`) keeps
//! them at the reference's numbers, as 3DGS's, SuGaR's and OpenSplat's own
//! iteration counts do (a shorter run is then the start of the full course).
//! Regulariser samples per iteration: SuGaR draws 1,000,000; here
//! `samples` (default 50,000 — a CPU budget, stated as a departure).

pub mod adc;
pub mod init;

use rayon::prelude::*;
use splatkit_render::depth_normal::normal_consistency;
use splatkit_render::gaussian::{RasterSettings, rasterize, render};
use splatkit_render::gaussian_grad::{self, AuxGrads, GaussianGrads};
use splatkit_render::optim::LrSchedule;
use splatkit_render::sh::coeff_count;

use self::adc::{Adc, AdcParams};
use super::groups::{GroupSpec, Groups, split_sh_grad};
use super::photometric::{Eval, evaluate, loss_and_grad_weighted, psnr_of, view_for_step};
use super::schedule::view_at;
use super::strategy::{self, EditReport, GaussianObservation, StepContext, Strategies};
use super::sugar::{
    Neighbours, RawGrads, SUGAR_K, SdfParams, SugarPrune, density_regularizer, entropy,
    sample_points, sdf_regularizer, visible_candidates,
};
use super::trainer::{StepStats, Trainer};
use crate::model::gaussians::sigmoid;
use crate::model::optim_state::GroupState;
use crate::model::rng::stream;
use crate::model::{Gaussians, View};
use crate::{Error, Result};

/// SuGaR's surface regularisers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Regularize {
    Density,
    Sdf,
    DnConsistency,
}

/// Training settings.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct GaussianParams {
    pub iterations: u64,
    pub regularize: Option<Regularize>,
    pub lr_means_init: f64,
    pub lr_means_final: f64,
    pub lr_sh_dc: f64,
    pub lr_sh_rest: f64,
    pub lr_opacity: f64,
    pub lr_scales: f64,
    pub lr_rotations: f64,
    pub lambda_dssim: f64,
    pub adc: AdcParams,
    /// Regulariser samples per iteration.
    pub samples: usize,
    pub background: [f32; 3],
    /// A random background colour every iteration (photos with alpha are
    /// put on it; 3DGS's `--random_background`).
    #[serde(default)]
    pub random_background: bool,
    /// Milestones at the reference's iteration numbers whatever the run's
    /// length (`--schedule reference`); default: scaled by `iterations` /
    /// [`GaussianParams::reference_length`].
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub reference_schedule: bool,
    /// White background: also reset opacities at the start of densification.
    pub white_background: bool,
    /// The highest SH band trained (`--sh-degree`; 3 unless set lower):
    /// the active degree never passes it, so the bands above stay zero in
    /// the written files.
    #[serde(
        default = "crate::train::three",
        skip_serializing_if = "crate::train::is_three"
    )]
    pub sh_degree: usize,
    pub seed: u64,
}

impl GaussianParams {
    /// 3DGS / SuGaR defaults for a scene of cameras extent `extent`.
    pub fn new(iterations: u64, regularize: Option<Regularize>, extent: f64) -> Self {
        GaussianParams {
            iterations,
            regularize,
            lr_means_init: 1.6e-4,
            lr_means_final: 1.6e-6,
            lr_sh_dc: 2.5e-3,
            lr_sh_rest: 2.5e-3 / 20.0,
            lr_opacity: 0.05,
            lr_scales: 0.005,
            lr_rotations: 0.001,
            lambda_dssim: 0.2,
            adc: AdcParams {
                extent,
                ..Default::default()
            },
            samples: 50_000,
            background: [0.0; 3],
            random_background: false,
            reference_schedule: false,
            white_background: false,
            sh_degree: 3,
            seed: 0,
        }
    }

    /// The reference run length: 30,000 (3DGS) or 15,000 (SuGaR coarse).
    pub fn reference_length(&self) -> u64 {
        if self.regularize.is_some() {
            15_000
        } else {
            30_000
        }
    }

    /// A reference milestone, scaled to this run unless
    /// `reference_schedule`.
    pub fn at(&self, milestone: u64) -> u64 {
        if self.reference_schedule {
            return milestone.max(1);
        }
        ((milestone as f64 * self.iterations as f64 / self.reference_length() as f64).round()
            as u64)
            .max(1)
    }

    /// Last iteration of densification.
    pub fn densify_until(&self) -> u64 {
        self.at(if self.regularize.is_some() {
            7_000
        } else {
            15_000
        })
    }
}

/// Names of the optimiser groups, in order.
pub const GROUPS: [&str; 6] = [
    "means",
    "sh_dc",
    "sh_rest",
    "opacity",
    "scales",
    "rotations",
];

/// The training state.
pub struct GaussianTrainer {
    pub model: Gaussians,
    pub params: GaussianParams,
    groups: Groups,
    /// Adaptive density control, then (SuGaR) the coarse-stage prune.
    strategies: Strategies<Gaussians>,
    /// Edits not yet taken by the session.
    edits: Vec<EditReport>,
    nbrs: Option<Neighbours>,
    iteration: u64,
}

fn flat<T: bytemuck::Pod>(v: &mut [T]) -> &mut [f32] {
    bytemuck::cast_slice_mut(v)
}

/// Gradients with respect to the model's stored parameters, one field per
/// optimiser group.
#[derive(Clone, Debug, Default)]
pub struct ParamGrads {
    pub means: Vec<[f32; 3]>,
    pub sh_dc: Vec<[f32; 3]>,
    /// `rest_per_channel` × 3 per Gaussian.
    pub sh_rest: Vec<f32>,
    /// Of the opacity logits.
    pub opacity: Vec<f32>,
    /// Of the log scales.
    pub scales: Vec<[f32; 3]>,
    pub rotations: Vec<[f32; 4]>,
}

impl ParamGrads {
    /// One Adam step of every group of `groups` on `m`.
    pub fn apply(mut self, groups: &mut Groups, m: &mut Gaussians) {
        groups.step("means", flat(&mut m.means), flat(&mut self.means));
        groups.step("sh_dc", flat(&mut m.sh_dc), flat(&mut self.sh_dc));
        groups.step("sh_rest", &mut m.sh_rest, &self.sh_rest);
        groups.step("opacity", &mut m.opacity_logits, &self.opacity);
        groups.step("scales", flat(&mut m.log_scales), flat(&mut self.scales));
        groups.step(
            "rotations",
            flat(&mut m.rotations),
            flat(&mut self.rotations),
        );
    }
}

/// Gradients with respect to the model's stored parameters (means, SH DC,
/// SH rest, opacity logits, log scales, rotations) from the rasteriser's
/// gradients `gg` of the activated values rendered at SH degree `d`, plus
/// the regularisers' gradients `reg` (already with respect to the stored
/// parameters).
pub fn raw_grads(m: &Gaussians, gg: &GaussianGrads, reg: &RawGrads, d: usize) -> ParamGrads {
    let n = m.len();
    let k = m.rest_per_channel();
    let nc = coeff_count(d.min(m.sh_degree));
    let g_means: Vec<[f32; 3]> = gg
        .means
        .par_iter()
        .zip(&reg.means)
        .map(|(x, y)| [x[0] + y[0], x[1] + y[1], x[2] + y[2]])
        .collect();
    let (g_dc, g_rest) = split_sh_grad(&gg.sh, n, nc, k);
    let g_o: Vec<f32> = (0..n)
        .into_par_iter()
        .map(|i| {
            let a = sigmoid(m.opacity_logits[i]);
            gg.opacities[i] * a * (1.0 - a) + reg.opacity_logits[i]
        })
        .collect();
    let g_s: Vec<[f32; 3]> = (0..n)
        .into_par_iter()
        .map(|i| {
            std::array::from_fn(|j| {
                gg.scales[i][j] * m.log_scales[i][j].exp() + reg.log_scales[i][j]
            })
        })
        .collect();
    let g_r: Vec<[f32; 4]> = gg
        .rotations
        .par_iter()
        .zip(&reg.rotations)
        .map(|(a, b)| std::array::from_fn(|j| a[j] + b[j]))
        .collect();
    ParamGrads {
        means: g_means,
        sh_dc: g_dc,
        sh_rest: g_rest,
        opacity: g_o,
        scales: g_s,
        rotations: g_r,
    }
}

impl GaussianTrainer {
    /// A fresh run from `model` (extra properties are dropped).
    pub fn new(mut model: Gaussians, params: GaussianParams) -> Self {
        model.extras = Default::default();
        model.normals = None;
        let n = model.len();
        let groups = Groups::new(Self::specs(&params, &model), n);
        GaussianTrainer {
            strategies: Self::strategies(&params, n),
            edits: Vec::new(),
            model,
            params,
            groups,
            nbrs: None,
            iteration: 0,
        }
    }

    /// 3DGS's density control, and SuGaR's prune when regularising.
    fn strategies(p: &GaussianParams, n: usize) -> Strategies<Gaussians> {
        let mut s: Strategies<Gaussians> = vec![Box::new(Adc::new(p, n))];
        if p.regularize.is_some() {
            s.push(Box::new(SugarPrune { at: p.at(9_000) }));
        }
        s
    }

    fn specs(p: &GaussianParams, g: &Gaussians) -> Vec<GroupSpec> {
        let c = LrSchedule::Constant;
        let e = p.adc.extent;
        vec![
            GroupSpec {
                name: GROUPS[0],
                width: 3,
                lr: LrSchedule::Exponential {
                    init: p.lr_means_init * e,
                    end: p.lr_means_final * e,
                    steps: p.at(30_000),
                },
            },
            GroupSpec {
                name: GROUPS[1],
                width: 3,
                lr: c(p.lr_sh_dc),
            },
            GroupSpec {
                name: GROUPS[2],
                width: g.rest_per_channel() * 3,
                lr: c(p.lr_sh_rest),
            },
            GroupSpec {
                name: GROUPS[3],
                width: 1,
                lr: c(p.lr_opacity),
            },
            GroupSpec {
                name: GROUPS[4],
                width: 3,
                lr: c(p.lr_scales),
            },
            GroupSpec {
                name: GROUPS[5],
                width: 4,
                lr: c(p.lr_rotations),
            },
        ]
    }

    /// SH degree rendered at the current iteration.
    pub fn active_degree(&self) -> usize {
        crate::train::sh_band(
            self.iteration,
            self.params.at(1000),
            self.model.sh_degree,
            self.params.sh_degree,
        )
    }

    fn settings(&self) -> RasterSettings {
        RasterSettings {
            background: self.params.background,
            ..Default::default()
        }
    }

    /// Whether the surface regulariser is on at the current iteration.
    fn regularizing(&self) -> Option<Regularize> {
        self.params
            .regularize
            .filter(|_| self.iteration + 1 > self.params.at(9_000))
    }

    /// [`Trainer::step`]: render, loss, regularisers, backward, Adam, the
    /// strategies' edits.
    fn step_impl(&mut self, views: &[View], train: &[usize]) -> StepStats {
        let p = self.params.clone();
        // the strategies' edits due after the previous iteration, made
        // before this one renders: an evaluation, save or checkpoint at
        // iteration N sees the model before the N-th edit, as 3DGS's loop
        // reports and saves before its densification block (module docs)
        if self.iteration > 0 {
            let ctx = StepContext {
                iteration: self.iteration,
                train_views: train.len(),
            };
            let done =
                strategy::apply(&mut self.strategies, ctx, &mut self.model, &mut self.groups);
            if done.rows_changed {
                self.nbrs = None; // indices into the old rows
            }
            self.edits.extend(done.reports);
        }
        let it1 = self.iteration + 1; // the reference's 1-based iteration
        let vi = view_at(train, p.seed, self.iteration);
        let mut s = self.settings();
        let (view, bg) = view_for_step(
            &views[vi],
            p.background,
            p.random_background,
            p.seed,
            self.iteration,
        );
        s.background = bg;
        let view = &*view;
        let cam = &view.camera;
        let d = self.active_degree();
        let g3 = self.model.to_raster_at(d);
        let (img, state) = rasterize(&g3, cam, &s);
        let (photo, d_rgb) = loss_and_grad_weighted(&img.rgb, view, 1.0 - p.lambda_dssim);
        let psnr = psnr_of(&img.rgb, view);
        let n = self.model.len();
        let mut reg = RawGrads::zeros(n);
        // (a zero set when no regulariser is on: a few MB, cheaper than
        // branching every gradient)
        let mut reg_loss = 0.0;
        let (mut d_depth, mut d_normal) = (None::<Vec<f32>>, None::<Vec<[f32; 3]>>);
        // SuGaR: entropy between 7,000 and 9,000
        if p.regularize.is_some() && it1 > p.at(7_000) && it1 <= p.at(9_000) {
            let (e, ge) = entropy(&self.model.opacity_logits);
            reg_loss += 0.1 * e;
            for (a, b) in reg.opacity_logits.iter_mut().zip(ge) {
                *a += 0.1 * b;
            }
        }
        if let Some(mode) = self.regularizing() {
            if self.nbrs.is_none() || (it1 - p.at(9_000)).is_multiple_of(p.at(500)) {
                self.nbrs = Neighbours::build(&self.model.means, SUGAR_K).ok();
            }
            if let Some(nbrs) = &self.nbrs {
                let cand = visible_candidates(&self.model, cam, &img.expected_depth, 2.0);
                let mut rng = stream(p.seed ^ 0x0053_7547_6152, self.iteration);
                let samples = sample_points(&self.model, &cand, p.samples, &mut rng);
                match mode {
                    Regularize::Density | Regularize::DnConsistency => {
                        let (l, g) = density_regularizer(&self.model, nbrs, &samples);
                        reg_loss += 0.2 * l;
                        g.add_to(&mut reg, 0.2);
                    }
                    Regularize::Sdf => {
                        let sp = SdfParams::sugar(p.adc.extent);
                        let (l, g, dd) = sdf_regularizer(
                            &self.model,
                            nbrs,
                            &samples,
                            cam,
                            &img.expected_depth,
                            &sp,
                        );
                        reg_loss += 0.2 * l;
                        g.add_to(&mut reg, 0.2);
                        d_depth = Some(dd.into_iter().map(|v| 0.2 * v).collect());
                    }
                }
                if mode == Regularize::DnConsistency {
                    let (l, gn, gd) =
                        normal_consistency(&img.normal_sum, &img.expected_depth, &img.alpha, cam);
                    reg_loss += 0.05 * l;
                    d_normal = Some(gn.into_iter().map(|v| v.map(|x| 0.05 * x)).collect());
                    d_depth = Some(gd.into_iter().map(|v| 0.05 * v).collect());
                }
            }
        }
        let aux = AuxGrads {
            alpha: None,
            depth: d_depth.as_deref(),
            normal: d_normal.as_deref(),
        };
        let gg = gaussian_grad::backward_aux(&g3, cam, &s, &state, &d_rgb, &aux);
        strategy::observe_all(&mut self.strategies, it1, || GaussianObservation {
            means2d_ndc: gg.means2d_ndc(cam.width, cam.height),
            radii: state.radii(n, cam.width as usize, cam.height as usize),
        });
        if !(photo + reg_loss).is_finite() {
            // no update and no iteration counted: the model stays as it
            // was, so the caller can name the value that made the loss
            // non-finite (train::finite) instead of the NaN Adam would
            // spread from it to every parameter
            return StepStats {
                iteration: self.iteration,
                view: vi,
                loss: photo + reg_loss,
                photometric: photo,
                regularizer: reg_loss,
                psnr,
                count: self.model.len(),
            };
        }
        raw_grads(&self.model, &gg, &reg, d).apply(&mut self.groups, &mut self.model);
        self.iteration += 1;
        StepStats {
            iteration: self.iteration - 1,
            view: vi,
            loss: photo + reg_loss,
            photometric: photo,
            regularizer: reg_loss,
            psnr,
            count: self.model.len(),
        }
    }
}

impl Trainer for GaussianTrainer {
    fn step(&mut self, views: &[View], train: &[usize]) -> StepStats {
        self.step_impl(views, train)
    }

    /// The first NaN or infinite parameter (means, SH, opacity, scales,
    /// rotations), described ([`crate::train::finite`]).
    fn non_finite(&self) -> Option<String> {
        use super::finite::{Param, first_non_finite};
        let m = &self.model;
        let k3 = m.rest_per_channel() * 3;
        let p = |name, width, values| Param {
            name,
            unit: "Gaussian",
            width,
            values,
        };
        first_non_finite(&[
            p(GROUPS[0], 3, m.means.as_flattened()),
            p(GROUPS[1], 3, m.sh_dc.as_flattened()),
            p(GROUPS[2], k3, &m.sh_rest),
            p(GROUPS[3], 1, &m.opacity_logits),
            p(GROUPS[4], 3, m.log_scales.as_flattened()),
            p(GROUPS[5], 4, m.rotations.as_flattened()),
        ])
    }

    fn evaluate(&self, views: &[View], test: &[usize]) -> Eval {
        let g3 = self.model.to_raster_at(self.active_degree());
        let s = self.settings();
        evaluate(views, test, self.iteration, |v| {
            render(&g3, &v.camera, &s).rgb
        })
    }

    fn iteration(&self) -> u64 {
        self.iteration
    }

    fn count(&self) -> usize {
        self.model.len()
    }

    /// The optimiser groups, the strategies' statistics and the neighbour
    /// table (`state/neighbours`) of the surface regulariser.
    fn optimizer_state(&self) -> (u64, Vec<GroupState>) {
        let mut g = self.groups.state();
        strategy::save_all(&self.strategies, &mut g);
        if let Some(nb) = &self.nbrs {
            g.push(GroupState::values(
                "state/neighbours",
                nb.idx.iter().map(|&i| i as f32).collect(),
            ));
        }
        (self.iteration, g)
    }

    fn restore(&mut self, step: u64, groups: Vec<GroupState>) -> Result<()> {
        let n = self.model.len();
        self.groups = Groups::new(Self::specs(&self.params, &self.model), n);
        self.groups.restore(step, &groups, n)?;
        self.strategies = Self::strategies(&self.params, n);
        strategy::load_all(&mut self.strategies, &groups, n)?;
        self.nbrs = match groups.iter().find(|g| g.name == "state/neighbours") {
            Some(g) => {
                let k = SUGAR_K.min(n);
                if g.m.len() != n * k || g.m.iter().any(|&v| v < 0.0 || v as usize >= n) {
                    return Err(Error::invalid("the neighbour table does not fit the model"));
                }
                Some(Neighbours {
                    k,
                    idx: g.m.iter().map(|&v| v as u32).collect(),
                })
            }
            None => None,
        };
        self.iteration = step;
        Ok(())
    }

    fn take_edits(&mut self) -> Vec<EditReport> {
        std::mem::take(&mut self.edits)
    }
}

#[cfg(test)]
mod tests;
