//! Densification strategies: what changes the set of primitives during
//! training (3DGS's adaptive density control, Triangle Splatting's MCMC
//! relocation, SuGaR's coarse-stage prune) behind one trait, in the manner
//! of gsplat's `Strategy`.
//!
//! A strategy owns its schedule (at which iterations it acts), its state
//! (the statistics it accumulates between steps) and that state's
//! checkpoint groups (`state/...`). The trainer gives it each rendered
//! view's statistics ([`Strategy::observe`]) and, after every optimiser
//! step, lets it edit the model ([`Strategy::edit`]). A strategy never
//! touches the optimiser: it returns what its edit means for the Adam
//! moments ([`Moments`]), and [`apply`] — the one remap path — moves the
//! moments of every group and the per-primitive state of every other
//! strategy with the rows, so parameters, moments and statistics stay
//! aligned whichever strategy edited.
//!
//! Every edit is reported as an [`EditReport`] (the session turns these
//! into verbose events: `train --verbose`).

use splatkit_render::triangle_stats::TriangleStats;

use super::groups::{Groups, Source};
use crate::Result;
use crate::model::optim_state::GroupState;
use crate::model::{Gaussians, TriangleSoup};

/// A model whose primitives a strategy edits: its row count and the
/// statistics one rendered view gives a strategy.
pub trait Primitives {
    /// What a strategy may read from one rendered training view.
    type Observation;
    /// The primitives in the model.
    fn rows(&self) -> usize;
}

/// What a Gaussian strategy reads from one rendered view.
#[derive(Clone, Debug, Default)]
pub struct GaussianObservation {
    /// ∂L/∂(screen mean) per Gaussian in NDC units (pixels × (W/2, H/2)).
    pub means2d_ndc: Vec<[f32; 2]>,
    /// Screen radius per Gaussian in pixels (0: not visible).
    pub radii: Vec<f32>,
}

impl Primitives for Gaussians {
    type Observation = GaussianObservation;
    fn rows(&self) -> usize {
        self.len()
    }
}

impl Primitives for TriangleSoup {
    /// The rasteriser's per-triangle statistics of the view (importance,
    /// inradius, screen radius).
    type Observation = TriangleStats;
    fn rows(&self) -> usize {
        self.len()
    }
}

/// When a strategy is asked to act: the iteration just finished (counted
/// from 1, as the references count) and the size of the training set.
#[derive(Clone, Copy, Debug)]
pub struct StepContext {
    pub iteration: u64,
    pub train_views: usize,
}

/// What an edit does to the optimiser's moments.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Moments {
    /// The rows were rebuilt from these sources: kept rows carry their
    /// moments (and every strategy's statistics) to their new place, new
    /// rows start at zero.
    Remap(Vec<Source>),
    /// The rows stay; the moments of every row of this group are zeroed
    /// (3DGS's opacity reset replaces the tensor and its optimiser state).
    ZeroGroup(&'static str),
}

/// One edit a strategy made to the model.
#[derive(Clone, Debug)]
pub struct Edit {
    /// What it was: "densify", "prune", "opacity reset", …
    pub kind: &'static str,
    /// Counts behind the edit, for the verbose report ("dead 12 …").
    pub detail: String,
    pub moments: Moments,
}

/// An applied [`Edit`], as reported to the session.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct EditReport {
    /// The iteration after which it happened (from 1).
    pub iteration: u64,
    /// The strategy's [`Strategy::name`].
    pub strategy: &'static str,
    pub kind: &'static str,
    /// Primitives before and after.
    pub before: usize,
    pub after: usize,
    pub detail: String,
}

impl std::fmt::Display for EditReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "iteration {}: {} {}: {} → {} primitives",
            self.iteration, self.strategy, self.kind, self.before, self.after
        )?;
        if !self.detail.is_empty() {
            write!(f, " ({})", self.detail)?;
        }
        Ok(())
    }
}

/// A densification strategy for models of type `M` (see the module docs).
pub trait Strategy<M: Primitives>: Send {
    /// A short name for reports ("adc", "mcmc", "sugar").
    fn name(&self) -> &'static str;

    /// Whether the strategy reads the statistics of the view rendered in
    /// iteration `iteration` (from 1); the trainer computes them only when
    /// some strategy does.
    fn observes(&self, _iteration: u64) -> bool {
        false
    }

    /// Accumulates one rendered view's statistics.
    fn observe(&mut self, _obs: &M::Observation) {}

    /// After the optimiser step of `ctx.iteration`: edits `model` when the
    /// schedule says so, returning the edits in the order made (their
    /// [`Moments`] are applied by [`apply`], in that order). A strategy
    /// resets its own statistics after its edit.
    fn edit(&mut self, ctx: StepContext, model: &mut M) -> Vec<Edit>;

    /// Another strategy rebuilt the rows from `sources`: move this one's
    /// per-primitive state with them (new rows start empty).
    fn remap(&mut self, _sources: &[Source]) {}

    /// The state for a checkpoint, as `state/...` groups (values in `m`).
    fn save(&self, _out: &mut Vec<GroupState>) {}

    /// Restores [`Strategy::save`] for a model of `rows` primitives.
    fn load(&mut self, _groups: &[GroupState], _rows: usize) -> Result<()> {
        Ok(())
    }
}

/// The strategies of a trainer, in the order they act.
pub type Strategies<M> = Vec<Box<dyn Strategy<M>>>;

/// Lets every strategy observe `obs` (built by `make` only when one asks
/// for iteration `iteration`).
pub fn observe_all<M: Primitives>(
    strategies: &mut Strategies<M>,
    iteration: u64,
    make: impl FnOnce() -> M::Observation,
) {
    if strategies.iter().any(|s| s.observes(iteration)) {
        let obs = make();
        for s in strategies.iter_mut().filter(|s| s.observes(iteration)) {
            s.observe(&obs);
        }
    }
}

/// Lets each strategy edit in turn and applies every edit's [`Moments`] to
/// `groups` and to the other strategies' state: the one remap path.
/// Returns what was done; `rows_changed` says whether any edit rebuilt the
/// rows (per-row tables the trainer keeps, such as a neighbour table, are
/// then stale).
pub fn apply<M: Primitives>(
    strategies: &mut Strategies<M>,
    ctx: StepContext,
    model: &mut M,
    groups: &mut Groups,
) -> Applied {
    let mut out = Applied::default();
    for i in 0..strategies.len() {
        let mut before = model.rows();
        for e in strategies[i].edit(ctx, model) {
            match &e.moments {
                Moments::Remap(src) => {
                    debug_assert_eq!(src.len(), model.rows(), "one source per row");
                    groups.remap(src);
                    for (j, s) in strategies.iter_mut().enumerate() {
                        if j != i {
                            s.remap(src);
                        }
                    }
                    out.rows_changed = true;
                }
                Moments::ZeroGroup(g) => groups.zero_rows(g, 0..model.rows()),
            }
            let after = model.rows();
            out.reports.push(EditReport {
                iteration: ctx.iteration,
                strategy: strategies[i].name(),
                kind: e.kind,
                before,
                after,
                detail: e.detail,
            });
            before = after;
        }
    }
    out
}

/// What [`apply`] did.
#[derive(Clone, Debug, Default)]
pub struct Applied {
    pub reports: Vec<EditReport>,
    pub rows_changed: bool,
}

/// Every strategy's checkpoint groups, in strategy order.
pub fn save_all<M: Primitives>(strategies: &Strategies<M>, out: &mut Vec<GroupState>) {
    for s in strategies {
        s.save(out);
    }
}

/// Restores every strategy from a checkpoint's groups.
pub fn load_all<M: Primitives>(
    strategies: &mut Strategies<M>,
    groups: &[GroupState],
    rows: usize,
) -> Result<()> {
    for s in strategies.iter_mut() {
        s.load(groups, rows)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::train::groups::GroupSpec;
    use splatkit_render::optim::LrSchedule;

    /// A model of one value per row.
    struct Toy(Vec<f32>);

    impl Primitives for Toy {
        type Observation = Vec<f32>;
        fn rows(&self) -> usize {
            self.0.len()
        }
    }

    /// Drops row 0 and appends a new row at iteration 2, then (when set)
    /// zeroes the "x" moments.
    struct Editor(bool);

    impl Strategy<Toy> for Editor {
        fn name(&self) -> &'static str {
            "editor"
        }
        fn edit(&mut self, ctx: StepContext, m: &mut Toy) -> Vec<Edit> {
            if ctx.iteration != 2 {
                return Vec::new();
            }
            let n = m.0.len();
            m.0 = m.0[1..].to_vec();
            m.0.push(9.0);
            let mut src: Vec<Source> = (1..n).map(Source::Old).collect();
            src.push(Source::New);
            let mut e = vec![Edit {
                kind: "densify",
                detail: "1 new".into(),
                moments: Moments::Remap(src),
            }];
            if self.0 {
                e.push(Edit {
                    kind: "reset",
                    detail: String::new(),
                    moments: Moments::ZeroGroup("x"),
                });
            }
            e
        }
    }

    /// Sums each row's observations; never edits.
    struct Counter(Vec<f32>);

    impl Strategy<Toy> for Counter {
        fn name(&self) -> &'static str {
            "counter"
        }
        fn observes(&self, iteration: u64) -> bool {
            iteration < 3
        }
        fn observe(&mut self, obs: &Vec<f32>) {
            for (c, o) in self.0.iter_mut().zip(obs) {
                *c += o;
            }
        }
        fn edit(&mut self, _: StepContext, _: &mut Toy) -> Vec<Edit> {
            Vec::new()
        }
        fn remap(&mut self, sources: &[Source]) {
            self.0 = sources
                .iter()
                .map(|s| match *s {
                    Source::Old(i) => self.0[i],
                    Source::New => 0.0,
                })
                .collect();
        }
        fn save(&self, out: &mut Vec<GroupState>) {
            out.push(GroupState::values("state/counter", self.0.clone()));
        }
    }

    /// One strategy's edit moves the optimiser moments and the other
    /// strategy's per-row statistics with the rows (and a second edit of
    /// the same step applies after it); reports count the rows before and
    /// after each edit; observations are built only when asked for.
    #[test]
    fn one_edit_moves_moments_and_other_state() {
        let spec = GroupSpec {
            name: "x",
            width: 1,
            lr: LrSchedule::Constant(0.1),
        };
        let setup = |zero: bool| {
            let mut model = Toy(vec![1.0, 2.0, 3.0]);
            let mut groups = Groups::new(vec![spec.clone()], 3);
            groups.step("x", &mut model.0, &[1.0, 2.0, 3.0]);
            let s: Strategies<Toy> = vec![Box::new(Editor(zero)), Box::new(Counter(vec![0.0; 3]))];
            (model, groups, s)
        };
        let (mut model, mut groups, _) = setup(false);
        let m0 = groups.state()[0].m.clone();
        let x0 = model.0.clone();
        let mut s = setup(false).2;
        let ctx2 = StepContext {
            iteration: 2,
            train_views: 1,
        };
        apply(&mut s, ctx2, &mut model, &mut groups);
        assert_eq!(groups.state()[0].m, vec![m0[1], m0[2], 0.0]);
        assert_eq!(model.0, vec![x0[1], x0[2], 9.0]);
        let (mut model, mut groups, mut s) = setup(true);
        observe_all(&mut s, 1, || vec![10.0, 20.0, 30.0]);
        observe_all(&mut s, 3, || panic!("nobody observes iteration 3"));
        let ctx = |iteration| StepContext {
            iteration,
            train_views: 1,
        };
        let none = apply(&mut s, ctx(1), &mut model, &mut groups);
        assert!(none.reports.is_empty() && !none.rows_changed);
        assert!(m0.iter().all(|&m| m != 0.0));
        let done = apply(&mut s, ctx(2), &mut model, &mut groups);
        assert!(done.rows_changed);
        assert_eq!(groups.state()[0].m, vec![0.0; 3]);
        let mut saved = Vec::new();
        save_all(&s, &mut saved);
        assert_eq!(saved[0].m, vec![20.0, 30.0, 0.0]);
        let r = &done.reports;
        assert_eq!((r[0].kind, r[0].before, r[0].after), ("densify", 3, 3));
        assert_eq!((r[1].kind, r[1].strategy), ("reset", "editor"));
        assert_eq!(
            r[0].to_string(),
            "iteration 2: editor densify: 3 → 3 primitives (1 new)"
        );
    }
}
