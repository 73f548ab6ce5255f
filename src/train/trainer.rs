//! The seam between the training session ([`super::session`]: the loop,
//! evaluations, guards, progress) and the models: Triangle Splatting, 3DGS /
//! SuGaR and the refiner of bound Gaussians implement [`Trainer`], so one
//! session drives them all, and a new model (or a GPU backend of one) plugs
//! in by implementing it (docs/ARCHITECTURE.md, "Where a new thing goes").
//! What changes the set of primitives during a run is a
//! [`super::strategy::Strategy`] the trainer holds.

use super::finite;
use super::photometric::Eval;
use super::strategy::EditReport;
use crate::Result;
use crate::model::View;
use crate::model::optim_state::GroupState;

/// What one iteration measured (every trainer's).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct StepStats {
    /// The iteration this step ran (from 0).
    pub iteration: u64,
    /// Index of the training view it rendered.
    pub view: usize,
    /// The total loss: `photometric` + `regularizer`.
    pub loss: f64,
    /// The photometric term ((1 − λ)·L1 + λ·D-SSIM).
    pub photometric: f64,
    /// Everything else in the loss, weighted (SuGaR's regularisers, the
    /// refiner's normal consistency; the triangle trainer's opacity, size,
    /// normal and game-engine terms).
    pub regularizer: f64,
    /// PSNR of this training view's render before the step.
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
    fn step(&mut self, views: &[View], train: &[usize]) -> StepStats;
    /// Held-out PSNR / SSIM on `test` at the current SH degree.
    fn evaluate(&self, views: &[View], test: &[usize]) -> Eval;
    /// Iterations done.
    fn iteration(&self) -> u64;
    /// Primitives in the model.
    fn count(&self) -> usize;
    /// Optimiser and strategy state for a checkpoint: (step, groups); the
    /// strategies' statistics travel as `state/...` groups.
    fn optimizer_state(&self) -> (u64, Vec<GroupState>);
    /// Restores [`Trainer::optimizer_state`] for the model already loaded;
    /// errors when it belongs to another model.
    fn restore(&mut self, step: u64, groups: Vec<GroupState>) -> Result<()>;
    /// The first NaN or infinite parameter, described (one pass over the
    /// model, see [`super::finite`]); `None` when all are finite.
    fn non_finite(&self) -> Option<String>;
    /// The strategies' edits since the last call (none for a trainer
    /// without densification).
    fn take_edits(&mut self) -> Vec<EditReport> {
        Vec::new()
    }

    /// [`Trainer::step`], then the per-iteration guard: `Err` naming the
    /// iteration (and the first non-finite parameter, if any) when the loss
    /// is not finite.
    fn step_checked(&mut self, views: &[View], train: &[usize]) -> Result<StepStats> {
        let before = self.iteration();
        let s = self.step(views, train);
        finite::check_loss(before + 1, s.loss, || self.non_finite())?;
        Ok(s)
    }

    /// The parameter guard (before evaluations and at the end of a run):
    /// `Err` naming the iteration and the first non-finite parameter.
    fn check_finite(&self) -> Result<()> {
        finite::check_params(self.iteration(), self.non_finite())
    }
}
