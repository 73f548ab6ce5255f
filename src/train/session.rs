//! The one training session every optimisation runs in: Triangle
//! Splatting, 3DGS / SuGaR's coarse stage and the refinement of bound
//! Gaussians all implement [`Trainer`], and [`run`] drives them: the
//! iterations up to `--iterations` (or a planned `--stop-at`), the held-out
//! evaluations (at the start, every `--eval-every` iterations and at the
//! end), the finiteness guards ([`super::finite`]) and the timing. It
//! reports through [`Event`]s, which the op turns into a progress bar and
//! its JSON; it touches no file (the op writes the outputs and the
//! checkpoint through `io::checkpoint`).
//!
//! Data preparation that every trainer shares lives here too:
//! [`prepare_split`] (the train / test split, refused when nothing is left
//! to train on) and [`resume_evals`] (a checkpoint's settings must be this
//! run's).

use serde_json::Value;

use super::photometric::Eval;
use super::schedule::split;
use super::strategy::EditReport;
use super::trainer::{StepStats, Trainer};
use crate::model::View;
use crate::{Error, Result};

/// The views a session trains and evaluates on.
#[derive(Clone, Copy, Debug)]
pub struct Views<'a> {
    /// Every view, in camera order.
    pub all: &'a [View],
    /// Indices of the training views.
    pub train: &'a [usize],
    /// Indices of the held-out views (may be empty: no evaluation).
    pub test: &'a [usize],
}

/// When a session stops and evaluates.
#[derive(Clone, Copy, Debug)]
pub struct Schedule {
    /// The run's total iterations.
    pub iterations: u64,
    /// A planned interruption: stop after this iteration (clamped to the
    /// run); the final evaluation is then left to the resumed run.
    pub stop_at: Option<u64>,
    /// Evaluate every this many iterations (0: only at the start and end).
    pub eval_every: u64,
}

/// What a session reports while it runs.
#[derive(Clone, Copy, Debug)]
pub enum Event<'a> {
    /// The loop is about to run iterations `start + 1 ..= end`.
    Start { start: u64, end: u64 },
    /// One iteration done (`iteration` counts from 1), with the loop's
    /// rate so far.
    Step {
        iteration: u64,
        progress: StepStats,
        it_per_s: f64,
    },
    /// A densification strategy changed the model (after the
    /// [`Event::Step`] of its iteration).
    Edit(&'a EditReport),
    /// A held-out evaluation.
    Eval(&'a Eval),
}

impl Event<'_> {
    /// A one-line status of a [`Event::Step`] for a progress bar ("loss
    /// 0.0123  PSNR 28.41  10234 primitives  3.10 it/s"); empty otherwise.
    pub fn status(&self) -> String {
        match self {
            Event::Step {
                progress: p,
                it_per_s,
                ..
            } => format!(
                "loss {:.4}  PSNR {:.2}  {} primitives  {it_per_s:.2} it/s",
                p.loss, p.psnr, p.count
            ),
            _ => String::new(),
        }
    }
}

/// What a session ends with.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// Every held-out evaluation of the run so far (a resumed run's include
    /// the checkpoint's).
    pub evals: Vec<Eval>,
    /// The iteration this session started at.
    pub start: u64,
    /// Seconds in the loop.
    pub loop_s: f64,
    /// The loss of the last step, `None` when this session took no step.
    pub last_loss: Option<f64>,
}

impl Outcome {
    /// Iterations this session ran.
    pub fn done(&self, t: &dyn Trainer) -> u64 {
        t.iteration() - self.start
    }

    /// Iterations per second of the loop.
    pub fn rate(&self, t: &dyn Trainer) -> f64 {
        self.done(t) as f64 / self.loop_s.max(1e-9)
    }
}

/// Runs `t` on `views` by `schedule`, continuing `evals` (a checkpoint's,
/// or empty). `label` starts every error ("train gaussians: iteration 12:
/// the loss is NaN …"). Errors: a non-finite loss or parameter, named by
/// the guards.
pub fn run(
    t: &mut dyn Trainer,
    views: Views<'_>,
    schedule: Schedule,
    mut evals: Vec<Eval>,
    label: &str,
    on: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome> {
    let with_label = |e: Error| Error::invalid(format!("{label}: {e}"));
    let evaluate = |t: &dyn Trainer, evals: &mut Vec<Eval>, on: &mut dyn FnMut(Event<'_>)| {
        let e = t.evaluate(views.all, views.test);
        on(Event::Eval(&e));
        evals.push(e);
    };
    if !views.test.is_empty() && evals.is_empty() {
        evaluate(t, &mut evals, on);
    }
    let start = t.iteration();
    let end = schedule
        .stop_at
        .map_or(schedule.iterations, |s| s.clamp(start, schedule.iterations));
    on(Event::Start { start, end });
    let t_loop = std::time::Instant::now();
    let mut last_loss = None;
    while t.iteration() < end {
        // the loss every iteration, every parameter before each evaluation
        // and at the end (train::finite)
        let p = t.step_checked(views.all, views.train).map_err(with_label)?;
        last_loss = Some(p.loss);
        let at = t.iteration();
        let it_per_s = (at - start) as f64 / t_loop.elapsed().as_secs_f64().max(1e-9);
        on(Event::Step {
            iteration: at,
            progress: p,
            it_per_s,
        });
        for e in t.take_edits() {
            on(Event::Edit(&e));
        }
        if !views.test.is_empty()
            && schedule.eval_every > 0
            && at.is_multiple_of(schedule.eval_every)
            && at < schedule.iterations
        {
            t.check_finite().map_err(with_label)?;
            evaluate(t, &mut evals, on);
        }
    }
    t.check_finite().map_err(with_label)?;
    let finished = t.iteration() == schedule.iterations;
    if finished
        && !views.test.is_empty()
        && evals.last().map(|e| e.iteration) != Some(t.iteration())
    {
        evaluate(t, &mut evals, on);
    }
    Ok(Outcome {
        evals,
        start,
        loop_s: t_loop.elapsed().as_secs_f64(),
        last_loss,
    })
}

/// The train / test split of `n` views holding out every `test_every`-th
/// ([`split`]); an error when every view is held out.
pub fn prepare_split(n: usize, test_every: usize) -> Result<(Vec<usize>, Vec<usize>)> {
    let (train, test) = split(n, test_every);
    if train.is_empty() {
        return Err(Error::invalid(format!(
            "all {n} views are held out (--test-every {test_every}): nothing to train on"
        )));
    }
    Ok((train, test))
}

/// A resumed run's evaluations so far: `Ok(evals)` when the checkpoint's
/// `state.json` (named `state_name` in messages) was written with these
/// `settings`, `Err(None)` when the settings differ (the op names the flags
/// that must match), `Err(Some)` naming the file when its `evals` do not
/// decode.
pub fn resume_evals(
    state: &Value,
    settings: &Value,
    state_name: &str,
) -> Result<Vec<Eval>, Option<String>> {
    if state.get("settings") != Some(settings) {
        return Err(None);
    }
    match state.get("evals") {
        Some(e) => serde_json::from_value(e.clone())
            .map_err(|e| Some(format!("{state_name}: \"evals\": {e}"))),
        None => Ok(Vec::new()),
    }
}
