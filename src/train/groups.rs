//! Per-primitive parameter groups with one Adam each, which densification
//! can reshape (rows kept, reordered, removed, added with zero moments).
//!
//! A group is a flat `f32` buffer of `rows × width` values (e.g. vertices:
//! width 9 per triangle; opacity: width 1). When a strategy edits the model
//! it describes the new rows as [`Source`]s; [`Groups::remap`] moves each
//! kept row's Adam moments with it and gives new rows zero moments, as 3DGS
//! and Triangle Splatting do when they concatenate new primitives to the
//! optimiser. The step count (bias correction) is shared and unchanged, as
//! PyTorch keeps the `step` of a parameter whose tensor is replaced.

use splatkit_render::optim::{Adam, LrSchedule, ParamGroup};

use crate::model::optim_state::GroupState;

/// Where a row of the edited model comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// Row `i` of the model before the edit: its moments move with it.
    Old(usize),
    /// A new row: zero moments.
    New,
}

/// The spec of one group: its name, values per row and learning rate.
#[derive(Clone, Debug)]
pub struct GroupSpec {
    pub name: &'static str,
    pub width: usize,
    pub lr: LrSchedule,
}

/// One Adam per group, all over the same number of rows.
#[derive(Clone, Debug)]
pub struct Groups {
    specs: Vec<GroupSpec>,
    adams: Vec<Adam>,
}

fn adam(len: usize, spec: &GroupSpec) -> Adam {
    Adam::new(
        len,
        vec![ParamGroup {
            name: spec.name.into(),
            range: 0..len,
            lr: spec.lr,
        }],
    )
}

impl Groups {
    /// Fresh optimisers for `rows` rows of each group.
    pub fn new(specs: Vec<GroupSpec>, rows: usize) -> Self {
        let adams = specs.iter().map(|s| adam(rows * s.width, s)).collect();
        Groups { specs, adams }
    }

    /// The group specs, in order.
    pub fn specs(&self) -> &[GroupSpec] {
        &self.specs
    }

    /// Steps taken (the same for every group).
    pub fn steps(&self) -> u64 {
        self.adams.first().map_or(0, Adam::steps)
    }

    /// The position of the group named `name`. Panics when there is none:
    /// group names are the trainers' constants, so a miss is a bug.
    fn index(&self, name: &str) -> usize {
        self.specs
            .iter()
            .position(|s| s.name == name)
            .unwrap_or_else(|| panic!("no optimiser group {name:?}"))
    }

    /// The learning rate the group `name` uses at the current step.
    pub fn lr(&self, name: &str) -> f64 {
        self.specs[self.index(name)].lr.at(self.steps())
    }

    /// One Adam step of the group `name`.
    pub fn step(&mut self, name: &str, params: &mut [f32], grads: &[f32]) {
        let g = self.index(name);
        self.adams[g].step(params, grads);
    }

    /// Rebuilds every group's moments for the rows `sources` (see
    /// [`Source`]).
    pub fn remap(&mut self, sources: &[Source]) {
        for (spec, a) in self.specs.iter().zip(&mut self.adams) {
            let w = spec.width;
            let steps = a.steps();
            let (m, v) = a.moments();
            let pick = |buf: &[f32]| -> Vec<f32> {
                let mut out = Vec::with_capacity(sources.len() * w);
                for s in sources {
                    match *s {
                        Source::Old(i) => out.extend_from_slice(&buf[i * w..(i + 1) * w]),
                        Source::New => out.extend(std::iter::repeat_n(0.0, w)),
                    }
                }
                out
            };
            let (m, v) = (pick(m), pick(v));
            let mut fresh = adam(m.len(), spec);
            fresh
                .restore(m, v, steps)
                .expect("moments built for the new length");
            *a = fresh;
        }
    }

    /// Zeroes both moments of the given rows of the group `name` (3DGS's
    /// opacity reset replaces the tensor and its optimiser state).
    pub fn zero_rows(&mut self, name: &str, rows: impl Iterator<Item = usize>) {
        let g = self.index(name);
        let w = self.specs[g].width;
        let steps = self.adams[g].steps();
        let (m, v) = self.adams[g].moments();
        let (mut m, mut v) = (m.to_vec(), v.to_vec());
        for r in rows {
            m[r * w..(r + 1) * w].fill(0.0);
            v[r * w..(r + 1) * w].fill(0.0);
        }
        self.adams[g]
            .restore(m, v, steps)
            .expect("same length as before");
    }

    /// The moments for a checkpoint, in group order.
    pub fn state(&self) -> Vec<GroupState> {
        self.specs
            .iter()
            .zip(&self.adams)
            .map(|(s, a)| {
                let (m, v) = a.moments();
                GroupState {
                    name: s.name.into(),
                    m: m.to_vec(),
                    v: v.to_vec(),
                }
            })
            .collect()
    }

    /// Restores [`Groups::state`] (for a model of `rows` rows) at `step`;
    /// errors name the group that does not fit.
    pub fn restore(&mut self, step: u64, groups: &[GroupState], rows: usize) -> crate::Result<()> {
        use crate::Error;
        for (spec, a) in self.specs.iter().zip(&mut self.adams) {
            let Some(g) = groups.iter().find(|g| g.name == spec.name) else {
                return Err(Error::invalid(format!(
                    "the optimiser state has no group {:?} (a checkpoint of another model?)",
                    spec.name
                )));
            };
            if g.m.len() != rows * spec.width {
                return Err(Error::invalid(format!(
                    "optimiser group {:?} holds {} values, the model's {rows} rows need {} \
                     (a checkpoint of another model?)",
                    spec.name,
                    g.m.len(),
                    rows * spec.width
                )));
            }
            let mut fresh = adam(g.m.len(), spec);
            fresh
                .restore(g.m.clone(), g.v.clone(), step)
                .map_err(Error::invalid)?;
            *a = fresh;
        }
        Ok(())
    }
}

/// Keeps rows where `keep[i]`: the [`Source`] list of a pure removal.
pub fn kept(keep: &[bool]) -> Vec<Source> {
    keep.iter()
        .enumerate()
        .filter(|(_, k)| **k)
        .map(|(i, _)| Source::Old(i))
        .collect()
}

/// Gathers rows of a flat buffer of `width` values per row by `sources`,
/// filling new rows with `fill(k)` for the k-th new row (in order).
pub fn gather_rows(
    buf: &[f32],
    width: usize,
    sources: &[Source],
    mut fill: impl FnMut(usize) -> Vec<f32>,
) -> Vec<f32> {
    let mut out = Vec::with_capacity(sources.len() * width);
    let mut k = 0;
    for s in sources {
        match *s {
            Source::Old(i) => out.extend_from_slice(&buf[i * width..(i + 1) * width]),
            Source::New => {
                let row = fill(k);
                assert_eq!(row.len(), width, "new row of the wrong width");
                out.extend(row);
                k += 1;
            }
        }
    }
    out
}

/// Splits the rasteriser's SH gradient (`nc` coefficients per primitive,
/// coefficient-major, DC first) into the DC gradient and the `k`-per-channel
/// rest layout of the models (bands above the active degree get zero).
pub fn split_sh_grad(sh: &[[f32; 3]], n: usize, nc: usize, k: usize) -> (Vec<[f32; 3]>, Vec<f32>) {
    use rayon::prelude::*;
    let dc: Vec<[f32; 3]> = (0..n).into_par_iter().map(|i| sh[i * nc]).collect();
    let mut rest = vec![0.0f32; n * k * 3];
    if k > 0 {
        rest.par_chunks_mut(k * 3).enumerate().for_each(|(i, r)| {
            for kk in 1..nc {
                r[(kk - 1) * 3..kk * 3].copy_from_slice(&sh[i * nc + kk]);
            }
        });
    }
    (dc, rest)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Kept rows carry their moments to their new place, new rows start at
    /// zero, the step count stays; a remapped optimiser then steps exactly
    /// like the original on the kept rows.
    #[test]
    fn remap_moves_moments_and_zeroes_new_rows() {
        let spec = GroupSpec {
            name: "x",
            width: 2,
            lr: LrSchedule::Constant(0.1),
        };
        let mut a = Groups::new(vec![spec.clone()], 3);
        let mut p = vec![1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0];
        let g = vec![0.5f32, -1.0, 2.0, 0.25, -3.0, 1.0];
        a.step("x", &mut p, &g);
        let mut b = a.clone();
        b.remap(&[Source::Old(2), Source::New, Source::Old(0)]);
        let st = b.state();
        let (m0, _) = (a.state()[0].m.clone(), ());
        assert_eq!(&st[0].m[0..2], &m0[4..6]);
        assert_eq!(&st[0].m[2..4], &[0.0, 0.0]);
        assert_eq!(&st[0].m[4..6], &m0[0..2]);
        assert_eq!(b.steps(), 1);
        // same second step on the kept rows
        let mut pa = p.clone();
        a.step("x", &mut pa, &g);
        let mut pb = vec![p[4], p[5], 0.0, 0.0, p[0], p[1]];
        let gb = vec![g[4], g[5], 0.0, 0.0, g[0], g[1]];
        b.step("x", &mut pb, &gb);
        assert_eq!([pb[0], pb[1], pb[4], pb[5]], [pa[4], pa[5], pa[0], pa[1]]);
    }

    /// `gather_rows` and `kept` agree with a hand-written case.
    #[test]
    fn gather_and_kept() {
        let buf = [1.0f32, 2.0, 3.0];
        let s = kept(&[true, false, true]);
        assert_eq!(s, vec![Source::Old(0), Source::Old(2)]);
        let mut s2 = s.clone();
        s2.push(Source::New);
        assert_eq!(
            gather_rows(&buf, 1, &s2, |k| vec![10.0 + k as f32]),
            vec![1.0, 3.0, 10.0]
        );
    }
}
