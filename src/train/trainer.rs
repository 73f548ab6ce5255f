//! The seam between the training session ([`super::session`]: the loop,
//! evaluations, guards, progress) and the models: Triangle Splatting, 3DGS /
//! SuGaR and the refiner of bound Gaussians implement [`Trainer`], so one
//! session drives them all, and a new model (or a GPU backend of one) plugs
//! in by implementing it (docs/ARCHITECTURE.md, "Where a new thing goes").

use super::finite;
use super::photometric::Eval;
use crate::model::View;
use crate::model::optim_state::GroupState;

/// The common summary of one iteration.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Progress {
    pub loss: f64,
    pub psnr: f64,
    /// Primitives after the step.
    pub count: usize,
}

/// A model trainer (see the module docs).
pub trait Trainer {
    /// One optimisation step on the next view of `train`.
    /// A step whose loss is not finite changes nothing (no update, the
    /// iteration count stays) and returns that loss; see
    /// [`crate::train::finite`].
    fn step_once(&mut self, views: &[View], train: &[usize]) -> Progress;
    /// Held-out PSNR / SSIM.
    fn eval(&self, views: &[View], test: &[usize]) -> Eval;
    /// Iterations done.
    fn iterations_done(&self) -> u64;
    /// Primitives in the model.
    fn count(&self) -> usize;
    /// Optimiser and strategy state: (step, groups).
    fn state(&self) -> (u64, Vec<GroupState>);
    /// Restores [`Trainer::state`] for the model already loaded.
    fn restore_state(&mut self, step: u64, groups: Vec<GroupState>) -> Result<(), String>;
    /// The first NaN or infinite parameter, described (one pass over the
    /// model, see [`super::finite`]); `None` when all are finite.
    fn first_non_finite(&self) -> Option<String>;

    /// [`Trainer::step_once`], then the per-iteration guard: `Err` naming
    /// the iteration (and the first non-finite parameter, if any) when the
    /// loss is not finite.
    fn step_checked(&mut self, views: &[View], train: &[usize]) -> Result<Progress, String> {
        let before = self.iterations_done();
        let p = self.step_once(views, train);
        finite::check_loss(before + 1, p.loss, || self.first_non_finite())?;
        Ok(p)
    }

    /// The parameter guard (before evaluations and at the end of a run):
    /// `Err` naming the iteration and the first non-finite parameter.
    fn check_finite(&self) -> Result<(), String> {
        finite::check_params(self.iterations_done(), self.first_non_finite())
    }
}

/// Implements [`Trainer`] for a trainer type whose inherent methods have
/// these meanings: `step` (one iteration, returning its loss and PSNR),
/// `evaluate`, `iteration`, `optimizer_state`, `restore`, `non_finite`;
/// `$primitives` names the field whose length is the primitive count.
macro_rules! impl_trainer {
    ($t:ty, $primitives:ident) => {
        impl Trainer for $t {
            fn step_once(&mut self, views: &[View], train: &[usize]) -> Progress {
                let s = self.step(views, train);
                Progress {
                    loss: s.loss,
                    psnr: s.psnr,
                    count: self.$primitives.len(),
                }
            }
            fn eval(&self, views: &[View], test: &[usize]) -> Eval {
                self.evaluate(views, test)
            }
            fn iterations_done(&self) -> u64 {
                self.iteration()
            }
            fn count(&self) -> usize {
                self.$primitives.len()
            }
            fn state(&self) -> (u64, Vec<GroupState>) {
                self.optimizer_state()
            }
            fn restore_state(&mut self, step: u64, groups: Vec<GroupState>) -> Result<(), String> {
                self.restore(step, groups)
            }
            fn first_non_finite(&self) -> Option<String> {
                self.non_finite()
            }
        }
    };
}

impl_trainer!(super::triangles::TriangleTrainer, soup);
impl_trainer!(super::gaussians::GaussianTrainer, model);
// the refiner of bound Gaussians: a primitive is a Gaussian
impl_trainer!(super::refine::Refiner, model);
