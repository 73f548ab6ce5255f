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
//! 4. adaptive density control ([`adc`]) every 100 iterations from 500
//!    until the end of densification, opacity reset every 3,000.
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

use self::adc::{AdcParams, AdcState, densify_and_prune, reset_opacity};
use super::groups::{GroupSpec, Groups, Source, kept, split_sh_grad};
use super::photometric::{Eval, evaluate, loss_and_grad_weighted, psnr_of, view_for_step};
use super::schedule::view_at;
use super::sugar::{
    Neighbours, RawGrads, SUGAR_K, SdfParams, density_regularizer, entropy, sample_points,
    sdf_regularizer, visible_candidates,
};
use crate::model::gaussians::sigmoid;
use crate::model::optim_state::{GroupState, find_values};
use crate::model::rng::stream;
use crate::model::{Gaussians, View};

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
    /// White background: also reset opacities at the start of densification.
    pub white_background: bool,
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
            white_background: false,
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

    /// A reference milestone scaled to this run.
    pub fn at(&self, milestone: u64) -> u64 {
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

/// What one iteration measured.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct StepStats {
    pub iteration: u64,
    pub view: usize,
    pub loss: f64,
    pub photometric: f64,
    pub regularizer: f64,
    pub psnr: f64,
    pub count: usize,
}

/// The training state.
pub struct GaussianTrainer {
    pub model: Gaussians,
    pub params: GaussianParams,
    groups: Groups,
    adc: AdcState,
    nbrs: Option<Neighbours>,
    iteration: u64,
}

fn flat<T: bytemuck::Pod>(v: &mut [T]) -> &mut [f32] {
    bytemuck::cast_slice_mut(v)
}

/// Gradients with respect to the model's stored parameters (means, SH DC,
/// SH rest (`rest_per_channel` × 3 per Gaussian), opacity logits, log
/// scales, rotations) from the rasteriser's gradients `gg` of the
/// activated values rendered at SH degree `d`, plus the regularisers'
/// gradients `reg` (already with respect to the stored parameters).
#[allow(clippy::type_complexity)]
pub fn raw_grads(
    m: &Gaussians,
    gg: &GaussianGrads,
    reg: &RawGrads,
    d: usize,
) -> (
    Vec<[f32; 3]>,
    Vec<[f32; 3]>,
    Vec<f32>,
    Vec<f32>,
    Vec<[f32; 3]>,
    Vec<[f32; 4]>,
) {
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
    (g_means, g_dc, g_rest, g_o, g_s, g_r)
}

impl GaussianTrainer {
    /// A fresh run from `model` (extra properties are dropped).
    pub fn new(mut model: Gaussians, params: GaussianParams) -> Self {
        model.extras = Default::default();
        model.normals = None;
        let n = model.len();
        let groups = Groups::new(Self::specs(&params, &model), n);
        GaussianTrainer {
            adc: AdcState::new(n),
            model,
            params,
            groups,
            nbrs: None,
            iteration: 0,
        }
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

    /// Iterations done.
    pub fn iteration(&self) -> u64 {
        self.iteration
    }

    /// SH degree rendered at the current iteration.
    pub fn active_degree(&self) -> usize {
        ((self.iteration / self.params.at(1000)) as usize).min(self.model.sh_degree)
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

    /// One optimisation step.
    /// A step whose loss is not finite changes nothing (no update, the
    /// iteration count stays) and returns that loss; see
    /// [`crate::train::finite`].
    pub fn step(&mut self, views: &[View], train: &[usize]) -> StepStats {
        let p = self.params.clone();
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
        if it1 < p.densify_until() {
            let radii = state.radii(n, cam.width as usize, cam.height as usize);
            self.adc
                .observe(&gg.means2d_ndc(cam.width, cam.height), &radii);
        }
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
        self.apply(&gg, &reg, d);
        self.iteration += 1;
        self.edit(train.len());
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

    /// Raw gradients from the rasteriser's plus `reg`, and the Adam steps.
    fn apply(&mut self, gg: &GaussianGrads, reg: &RawGrads, d: usize) {
        let (mut g_means, mut g_dc, g_rest, g_o, mut g_s, mut g_r) =
            raw_grads(&self.model, gg, reg, d);
        let m = &mut self.model;
        self.groups.step(0, flat(&mut m.means), flat(&mut g_means));
        self.groups.step(1, flat(&mut m.sh_dc), flat(&mut g_dc));
        self.groups.step(2, &mut m.sh_rest, &g_rest);
        self.groups.step(3, &mut m.opacity_logits, &g_o);
        self.groups.step(4, flat(&mut m.log_scales), flat(&mut g_s));
        self.groups.step(5, flat(&mut m.rotations), flat(&mut g_r));
    }

    /// Densification, opacity reset and SuGaR's prune at the milestones
    /// (after `self.iteration` was advanced: it is the 1-based iteration
    /// just finished).
    fn edit(&mut self, _train_views: usize) {
        let p = self.params.clone();
        let it = self.iteration;
        if it < p.densify_until() {
            if it > p.at(500) && it.is_multiple_of(p.at(100)) {
                let big = it > p.at(3_000);
                let mut rng = stream(p.seed ^ 0x0041_4443, it);
                let src = densify_and_prune(&mut self.model, &mut self.adc, &p.adc, big, &mut rng);
                self.groups.remap(&src);
            }
            if it.is_multiple_of(p.at(3_000)) || (p.white_background && it == p.at(500)) {
                reset_opacity(&mut self.model);
                self.groups.zero_rows(3, 0..self.model.len());
            }
        }
        if p.regularize.is_some() && it == p.at(9_000) {
            let mut keep: Vec<bool> = self
                .model
                .opacity_logits
                .iter()
                .map(|&o| o >= 0.0)
                .collect();
            if !keep.contains(&true) {
                // never empty the model: a run too short to recover from its
                // last opacity reset keeps everything
                keep.fill(true);
            }
            let src: Vec<Source> = kept(&keep);
            let idx: Vec<usize> = (0..keep.len()).filter(|&i| keep[i]).collect();
            self.model = self.model.gather(&idx);
            self.adc.remap(&src);
            self.groups.remap(&src);
            self.nbrs = None;
        }
    }

    /// The first NaN or infinite parameter (means, SH, opacity, scales,
    /// rotations), described ([`crate::train::finite`]); `None` when all
    /// are finite.
    pub fn non_finite(&self) -> Option<String> {
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

    /// PSNR / SSIM on the views `test` at the current SH degree.
    pub fn evaluate(&self, views: &[View], test: &[usize]) -> Eval {
        let g3 = self.model.to_raster_at(self.active_degree());
        let s = self.settings();
        evaluate(views, test, self.iteration, |v| {
            render(&g3, &v.camera, &s).rgb
        })
    }

    /// The optimiser and strategy state for a checkpoint; the density
    /// control's accumulators and the neighbour table travel as `state/...`
    /// groups (values in `m`).
    pub fn optimizer_state(&self) -> (u64, Vec<GroupState>) {
        let mut g = self.groups.state();
        let extra = GroupState::values;
        g.push(extra("state/grad_sum", self.adc.grad_sum.clone()));
        g.push(extra("state/count", self.adc.count.clone()));
        g.push(extra("state/max_radius", self.adc.max_radius.clone()));
        if let Some(nb) = &self.nbrs {
            g.push(extra(
                "state/neighbours",
                nb.idx.iter().map(|&i| i as f32).collect(),
            ));
        }
        (self.iteration, g)
    }

    /// Restores [`GaussianTrainer::optimizer_state`] (the model was loaded
    /// into `self.model`); errors when it belongs to another model.
    pub fn restore(&mut self, step: u64, groups: Vec<GroupState>) -> Result<(), String> {
        let n = self.model.len();
        self.groups = Groups::new(Self::specs(&self.params, &self.model), n);
        self.groups.restore(step, &groups, n)?;
        let get = |name: &str| find_values(&groups, name, n, "Gaussian");
        self.adc = AdcState {
            grad_sum: get("state/grad_sum")?,
            count: get("state/count")?,
            max_radius: get("state/max_radius")?,
        };
        self.nbrs = match groups.iter().find(|g| g.name == "state/neighbours") {
            Some(g) => {
                let k = SUGAR_K.min(n);
                if g.m.len() != n * k || g.m.iter().any(|&v| v < 0.0 || v as usize >= n) {
                    return Err("the neighbour table does not fit the model".into());
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
}

#[cfg(test)]
mod tests;
