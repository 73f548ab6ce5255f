//! SuGaR's refinement (sugar.md §4.2): Gaussians bound to a mesh and the
//! mesh itself optimised jointly through the Gaussian rasteriser.
//!
//! Per iteration (one train view, seeded order, [`super::schedule`]):
//! 1. materialise the bound Gaussians at the active SH degree
//!    (min(model degree, iteration / 1000): one more band per 1000 steps);
//! 2. render on the background (black, or white), loss
//!    0.8·L1 + 0.2·D-SSIM (masked if the view has a mask,
//!    [`super::photometric`]) + 0.1·normal consistency of the mesh (PyTorch3D's
//!    `mesh_normal_consistency`);
//! 3. back-propagate through the rasteriser and the binding
//!    ([`crate::geom::binding::grad`]) and take one Adam step per group
//!    (ε 1e-15) with SuGaR's learning rates: vertices 1.6e-4 → 1.6e-6
//!    (exponential over 30k steps) × `spatial_lr_scale` = 10·R/√V (R the
//!    cameras' extent), SH DC 2.5e-3, SH rest 2.5e-3/20, opacity 0.05,
//!    in-plane scales 5e-3, complex rotations 1e-3.
//!
//! There is no densification or pruning (as in SuGaR). The result depends
//! only on the model, the views, the seed and the iteration count (the
//! rasteriser and every reduction here are deterministic for any thread
//! count), so a run resumed from a checkpoint equals an uninterrupted one.

use splatkit_render::gaussian::{RasterSettings, rasterize, render};
use splatkit_render::gaussian_grad;
use splatkit_render::optim::{Adam, LrSchedule, ParamGroup};

pub use super::photometric::Eval;
use super::photometric::{evaluate, loss_and_grad, psnr_of};
use super::schedule::view_at;
use super::trainer::{StepStats, Trainer};
use crate::geom::binding::grad::{NormalConsistency, backward};
use crate::geom::binding::to_raster;
use crate::model::optim_state::GroupState;
use crate::model::{BoundGaussians, View};
use crate::{Error, Result};

/// SuGaR's learning rates (see the module docs).
#[derive(Clone, Debug, serde::Serialize)]
pub struct LearningRates {
    pub vertices_init: f64,
    pub vertices_final: f64,
    pub vertices_steps: u64,
    pub sh_dc: f64,
    pub sh_rest: f64,
    pub opacity: f64,
    pub scales: f64,
    pub complex: f64,
}

impl Default for LearningRates {
    fn default() -> Self {
        LearningRates {
            vertices_init: 1.6e-4,
            vertices_final: 1.6e-6,
            vertices_steps: 30_000,
            sh_dc: 2.5e-3,
            sh_rest: 2.5e-3 / 20.0,
            opacity: 0.05,
            scales: 5e-3,
            complex: 1e-3,
        }
    }
}

/// Refinement settings.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RefineParams {
    /// Background colour (SuGaR: black, or white with `--white-background`).
    pub background: [f32; 3],
    /// Weight of the normal-consistency term (SuGaR: 0.1).
    pub normal_consistency: f64,
    /// Iterations per added SH band (SuGaR: 1000).
    pub sh_warmup: u64,
    pub lr: LearningRates,
    /// Multiplies the vertex learning rate: SuGaR's 10·R/√V.
    pub spatial_lr_scale: f64,
    /// Seed of the view order.
    pub seed: u64,
}

/// SuGaR's `spatial_lr_scale` for a mesh of `vertices` vertices and cameras
/// of extent `radius`.
pub fn spatial_lr_scale(radius: f64, vertices: usize) -> f64 {
    10.0 * radius / (vertices.max(1) as f64).sqrt()
}

/// Names of the optimiser groups, in checkpoint order.
pub const GROUPS: [&str; 6] = [
    "vertices",
    "complex",
    "log_scales",
    "opacity",
    "sh_dc",
    "sh_rest",
];

/// The optimiser groups by name: `adams[G::Vertices as usize]` is the
/// group [`GROUPS`]`[G::Vertices as usize]`.
#[derive(Clone, Copy)]
enum G {
    Vertices,
    Complex,
    LogScales,
    Opacity,
    ShDc,
    ShRest,
}

/// The refinement state: the model, one Adam per parameter group, the
/// iteration count.
pub struct Refiner {
    pub model: BoundGaussians,
    pub params: RefineParams,
    adams: Vec<Adam>,
    nc: NormalConsistency,
    iteration: u64,
}

fn adam(len: usize, name: &str, lr: LrSchedule) -> Adam {
    Adam::new(
        len,
        vec![ParamGroup {
            name: name.into(),
            range: 0..len,
            lr,
        }],
    )
}

fn flat<T: bytemuck::Pod>(v: &mut [T]) -> &mut [f32] {
    bytemuck::cast_slice_mut(v)
}

impl Refiner {
    /// A fresh refinement of `model`.
    pub fn new(model: BoundGaussians, params: RefineParams) -> Self {
        let lr = &params.lr;
        let n = model.len();
        let k3 = model.rest_per_channel() * 3;
        let s = params.spatial_lr_scale;
        let vertex_lr = if lr.vertices_init * s > 0.0 && lr.vertices_final * s > 0.0 {
            LrSchedule::Exponential {
                init: lr.vertices_init * s,
                end: lr.vertices_final * s,
                steps: lr.vertices_steps,
            }
        } else {
            LrSchedule::Constant(0.0)
        };
        let lrs = [
            vertex_lr,
            LrSchedule::Constant(lr.complex),
            LrSchedule::Constant(lr.scales),
            LrSchedule::Constant(lr.opacity),
            LrSchedule::Constant(lr.sh_dc),
            LrSchedule::Constant(lr.sh_rest),
        ];
        let lens = [
            3 * model.mesh.vertices.len(),
            2 * n,
            2 * n,
            n,
            3 * n,
            n * k3,
        ];
        let adams = (0..6).map(|g| adam(lens[g], GROUPS[g], lrs[g])).collect();
        let nc = NormalConsistency::new(&model.mesh.faces);
        Refiner {
            model,
            params,
            adams,
            nc,
            iteration: 0,
        }
    }

    /// SH degree rendered at the current iteration.
    pub fn active_degree(&self) -> usize {
        let w = self.params.sh_warmup.max(1);
        ((self.iteration / w) as usize).min(self.model.sh_degree)
    }

    fn settings(&self) -> RasterSettings {
        RasterSettings {
            background: self.params.background,
            ..Default::default()
        }
    }

    /// [`Trainer::step`] on `views[view_at(train, seed, iteration)]`.
    fn step_impl(&mut self, views: &[View], train: &[usize]) -> StepStats {
        let vi = view_at(train, self.params.seed, self.iteration);
        let view = &views[vi];
        let d = self.active_degree();
        let s = self.settings();
        let g3 = to_raster(&self.model, d);
        let (img, state) = rasterize(&g3, &view.camera, &s);
        let (photo, d_rgb) = loss_and_grad(&img.rgb, view);
        let psnr = psnr_of(&img.rgb, view);
        let gg = gaussian_grad::backward(&g3, &view.camera, &s, &state, &d_rgb, None);
        let mut bg = backward(&self.model, &gg, d);
        let w = self.params.normal_consistency;
        let nc = if w > 0.0 {
            self.nc
                .eval(&self.model.mesh.vertices, w, Some(&mut bg.vertices))
        } else {
            0.0
        };
        let loss = photo + w * nc;
        if !loss.is_finite() {
            // no update and no iteration counted: the model stays as it
            // was, so the caller can name the value that made the loss
            // non-finite (train::finite) instead of the NaN Adam would
            // spread from it to every parameter
            return StepStats {
                iteration: self.iteration,
                view: vi,
                loss,
                photometric: photo,
                regularizer: w * nc,
                psnr,
                count: self.model.len(),
            };
        }
        let gv: Vec<f32> = bg.vertices.iter().flatten().map(|&x| x as f32).collect();
        let m = &mut self.model;
        let a = &mut self.adams;
        a[G::Vertices as usize].step(flat(&mut m.mesh.vertices), &gv);
        a[G::Complex as usize].step(flat(&mut m.complex), flat(&mut bg.complex));
        a[G::LogScales as usize].step(flat(&mut m.log_scales), flat(&mut bg.log_scales));
        a[G::Opacity as usize].step(&mut m.opacity_logits, &bg.opacity_logits);
        a[G::ShDc as usize].step(flat(&mut m.sh_dc), flat(&mut bg.sh_dc));
        a[G::ShRest as usize].step(&mut m.sh_rest, &bg.sh_rest);
        let stats = StepStats {
            iteration: self.iteration,
            view: vi,
            loss,
            photometric: photo,
            regularizer: w * nc,
            psnr,
            count: self.model.len(),
        };
        self.iteration += 1;
        stats
    }
}

impl Trainer for Refiner {
    fn step(&mut self, views: &[View], train: &[usize]) -> StepStats {
        self.step_impl(views, train)
    }

    fn iteration(&self) -> u64 {
        self.iteration
    }

    /// Gaussians (a primitive is a bound Gaussian).
    fn count(&self) -> usize {
        self.model.len()
    }

    /// The first NaN or infinite parameter (mesh vertices, complex
    /// rotations, in-plane scales, opacity, SH), described; `None` when all
    /// are finite.
    fn non_finite(&self) -> Option<String> {
        use super::finite::{Param, first_non_finite};
        let m = &self.model;
        let k3 = m.rest_per_channel() * 3;
        let p = |name, unit, width, values| Param {
            name,
            unit,
            width,
            values,
        };
        first_non_finite(&[
            p(GROUPS[0], "vertex", 3, m.mesh.vertices.as_flattened()),
            p(GROUPS[1], "Gaussian", 2, m.complex.as_flattened()),
            p(GROUPS[2], "Gaussian", 2, m.log_scales.as_flattened()),
            p(GROUPS[3], "Gaussian", 1, &m.opacity_logits),
            p(GROUPS[4], "Gaussian", 3, m.sh_dc.as_flattened()),
            p(GROUPS[5], "Gaussian", k3, &m.sh_rest),
        ])
    }

    /// PSNR / SSIM on the views `test` (mean over views) at the current
    /// iteration's SH degree.
    fn evaluate(&self, views: &[View], test: &[usize]) -> Eval {
        let g3 = to_raster(&self.model, self.active_degree());
        let s = self.settings();
        evaluate(views, test, self.iteration, |v| {
            render(&g3, &v.camera, &s).rgb
        })
    }

    /// The optimiser state for a checkpoint: (step, groups).
    fn optimizer_state(&self) -> (u64, Vec<GroupState>) {
        let groups = self
            .adams
            .iter()
            .zip(GROUPS)
            .map(|(a, name)| {
                let (m, v) = a.moments();
                GroupState {
                    name: name.into(),
                    m: m.to_vec(),
                    v: v.to_vec(),
                }
            })
            .collect();
        (self.iteration, groups)
    }

    /// Restores a checkpoint's optimiser state (the model was loaded into
    /// `self.model` by the caller); errors when it belongs to another model.
    fn restore(&mut self, step: u64, groups: Vec<GroupState>) -> Result<()> {
        if groups.len() != GROUPS.len() {
            return Err(Error::invalid(format!(
                "the optimiser state has {} groups, a refinement has {}",
                groups.len(),
                GROUPS.len()
            )));
        }
        for ((a, g), want) in self.adams.iter_mut().zip(groups).zip(GROUPS) {
            if g.name != want {
                return Err(Error::invalid(format!(
                    "optimiser group {:?} where {want:?} was expected",
                    g.name
                )));
            }
            a.restore(g.m, g.v, step).map_err(|m| {
                Error::invalid(format!(
                    "group {want}: {m} (a checkpoint of another model?)"
                ))
            })?;
        }
        self.iteration = step;
        Ok(())
    }
}

#[cfg(test)]
mod tests;
