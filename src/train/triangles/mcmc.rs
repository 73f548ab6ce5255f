//! Triangle Splatting's densification (triangle_splatting.md §3.4): MCMC-
//! style relocation of dead triangles plus growth by a fixed factor.
//!
//! Every densification step (every 500 iterations from 500 to 25,000 at the
//! reference schedule):
//! 1. **Dead** triangles: importance (largest α·T at any pixel of any view
//!    since the last step) below `importance_threshold`, or opacity ≤
//!    `opacity_dead`, the importance test and the fewer-than-2-views test
//!    (inradius above 1 px) only when a full pass over the training views
//!    was observed since the last step; indoors, those whose screen radius
//!    R exceeded 1400 px. A step never kills every triangle.
//! 2. **Count**: target = min(max_shapes, ⌊1.3·N⌋); n_add = max(0, target −
//!    N) + n_dead.
//! 3. **Pick** alive triangles without replacement with probability ∝ the
//!    opacity (even steps) or 1/σ (odd steps), keys by Efraimidis–Spirakis
//!    (u^{1/w}) from the step's seeded stream; each pick costs 3 when the
//!    triangle is big (R > `split_size` px at some observed view) else 1;
//!    picks stop once the cost reaches n_add.
//! 4. **Big** → 4-way midpoint subdivision (children keep colour, raw
//!    opacity, raw σ). **Small** → the original plus a copy moved rigidly by
//!    in-plane noise U(−½, ½)·(bounding-box extent per axis)·1.5 with its
//!    normal component removed; both get opacity 1 − sqrt(1 − o), so the two
//!    layers composite to the old opacity.
//! 5. Parents and dead triangles are removed; survivors keep their order
//!    and Adam moments, new triangles are appended with zero moments.
//!
//! After densification ends, the same steps only prune the dead.
//!
//! [`Mcmc`] is the [`Strategy`] that runs these on the reference schedule
//! (scaled by [`TriangleParams::at`]; the interval at least one pass over
//! the training views and [`super::MIN_INTERVAL`]), with the game-engine
//! variant's final pruning thresholds. Its checkpoint groups:
//! `state/importance`, `state/visible`, `state/image_size`,
//! `state/counters` (views observed, steps taken).

use glam::DVec3;
use rand::RngExt;

use super::TriangleParams;
use crate::model::TriangleSoup;
use crate::model::gaussians::{logit, sigmoid};
use crate::model::optim_state::{GroupState, find_values};
use crate::model::rng::{Rng, stream};
use crate::train::groups::{Source, gather_rows};
use crate::train::strategy::{Edit, Moments, StepContext, Strategy};
use splatkit_render::triangle_stats::TriangleStats;

/// Densification settings (the reference's defaults in [`Default`]).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct McmcParams {
    /// Growth factor per step (1.3).
    pub add_shape: f64,
    /// Most triangles the model may hold.
    pub max_shapes: usize,
    /// Dead below this importance (0.022 outdoor, 0.025 indoor scripts).
    pub importance_threshold: f32,
    /// Dead at or below this opacity (0.014).
    pub opacity_dead: f32,
    /// Screen radius (px) above which a picked triangle is split 4-way (24).
    pub split_size: f32,
    /// Clone noise scale (1.5).
    pub max_noise_factor: f64,
    /// Indoors: dead when the screen radius exceeded this (1400 px).
    pub max_screen_radius: Option<f32>,
}

impl Default for McmcParams {
    fn default() -> Self {
        McmcParams {
            add_shape: 1.3,
            max_shapes: 4_000_000,
            importance_threshold: 0.022,
            opacity_dead: 0.014,
            split_size: 24.0,
            max_noise_factor: 1.5,
            max_screen_radius: None,
        }
    }
}

/// What the strategy accumulates between steps, one entry per triangle.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct McmcState {
    /// Largest α·T since the last step.
    pub importance: Vec<f32>,
    /// Views in which the inradius exceeded 1 px.
    pub visible: Vec<f32>,
    /// Largest screen radius R (px).
    pub image_size: Vec<f32>,
    /// Views observed since the last step.
    pub views: u64,
    /// Densification steps taken (selects the sampling weights).
    pub steps: u64,
}

/// The number of triangles to add (relocated dead included).
pub fn growth_count(n: usize, n_dead: usize, add_shape: f64, max_shapes: usize) -> usize {
    let target = max_shapes.min((add_shape * n as f64) as usize);
    target.saturating_sub(n) + n_dead
}

/// Opacity of each of the two clones of a triangle of opacity `o`:
/// 1 − sqrt(1 − o) (two such layers composite to o).
pub fn clone_opacity(o: f32) -> f32 {
    1.0 - (1.0 - o).max(0.0).sqrt()
}

/// The 4-way midpoint subdivision of (A, B, C): (A, ab, ca), (ab, B, bc),
/// (ca, bc, C), (ab, bc, ca).
pub fn split4(t: [[f32; 3]; 3]) -> [[[f32; 3]; 3]; 4] {
    let mid = |a: [f32; 3], b: [f32; 3]| [0, 1, 2].map(|k| 0.5 * (a[k] + b[k]));
    let [a, b, c] = t;
    let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
}

/// The clone of `t` moved by `u` (three uniforms in [0, 1)): offset
/// (u − ½)·extent·`noise` per axis, minus its component along the normal.
pub fn moved_clone(t: [[f32; 3]; 3], u: [f64; 3], noise: f64) -> [[f32; 3]; 3] {
    let v = t.map(|p| DVec3::from_array(p.map(f64::from)));
    let lo = v[0].min(v[1]).min(v[2]);
    let hi = v[0].max(v[1]).max(v[2]);
    let ext = hi - lo;
    let mut off = DVec3::new(
        (u[0] - 0.5) * ext.x,
        (u[1] - 0.5) * ext.y,
        (u[2] - 0.5) * ext.z,
    ) * noise;
    let n = (v[1] - v[0]).cross(v[2] - v[0]);
    if n.length() > 0.0 {
        let n = n.normalize();
        off -= n * off.dot(n);
    }
    v.map(|p| (p + off).as_vec3().to_array())
}

impl McmcState {
    /// Empty accumulators for `n` triangles.
    pub fn new(n: usize) -> Self {
        McmcState {
            importance: vec![0.0; n],
            visible: vec![0.0; n],
            image_size: vec![0.0; n],
            views: 0,
            steps: 0,
        }
    }

    /// Adds one view's statistics.
    pub fn observe(&mut self, s: &TriangleStats) {
        for i in 0..self.importance.len() {
            self.importance[i] = self.importance[i].max(s.importance[i]);
            if s.inradius[i] > 1.0 {
                self.visible[i] += 1.0;
            }
            self.image_size[i] = self.image_size[i].max(s.radius[i]);
        }
        self.views += 1;
    }

    fn reset(&mut self, n: usize) {
        let steps = self.steps;
        *self = McmcState::new(n);
        self.steps = steps;
    }

    /// The dead mask (see the module docs). `full_pass`: a full pass over
    /// the training views was observed since the last step, so the
    /// importance and fewer-than-2-views rules apply (the reference skips
    /// the importance test during an incomplete pass on large sets, and
    /// counts views over the last full pass); without it only the opacity
    /// and screen-radius rules do. When every triangle would be dead, none
    /// is (a step never empties the model).
    pub fn dead(&self, soup: &TriangleSoup, p: &McmcParams, full_pass: bool) -> Vec<bool> {
        let dead: Vec<bool> = (0..soup.len())
            .map(|i| {
                (full_pass && self.importance[i] < p.importance_threshold)
                    || soup.opacity(i) <= p.opacity_dead
                    || (full_pass && self.visible[i] < 2.0)
                    || p.max_screen_radius.is_some_and(|m| self.image_size[i] > m)
            })
            .collect();
        if dead.iter().all(|&d| d) {
            return vec![false; dead.len()];
        }
        dead
    }

    /// The verbose report of a densification step whose dead mask is
    /// `dead`: how many triangles each rule of [`McmcState::dead`] finds (a
    /// triangle may match several), and the growth the step adds.
    pub fn dead_summary(
        &self,
        soup: &TriangleSoup,
        p: &McmcParams,
        full_pass: bool,
        dead: &[bool],
    ) -> String {
        let n = soup.len();
        let n_dead = dead.iter().filter(|&&d| d).count();
        let n_add = growth_count(n, n_dead, p.add_shape, p.max_shapes);
        let imp = (0..n)
            .filter(|&i| full_pass && self.importance[i] < p.importance_threshold)
            .count();
        let op = (0..n)
            .filter(|&i| soup.opacity(i) <= p.opacity_dead)
            .count();
        let vis = (0..n)
            .filter(|&i| full_pass && self.visible[i] < 2.0)
            .count();
        format!("dead {n_dead}: importance {imp}, opacity {op}, views {vis}; add {n_add}")
    }

    /// One growth-and-relocation step on `soup` (see the module docs);
    /// returns where each row of the new soup comes from.
    pub fn densify(
        &mut self,
        soup: &mut TriangleSoup,
        p: &McmcParams,
        check_visibility: bool,
        rng: &mut Rng,
    ) -> Vec<Source> {
        let dead = self.dead(soup, p, check_visibility);
        self.densify_dead(soup, p, dead, rng)
    }

    /// [`McmcState::densify`] with the dead mask already computed.
    pub fn densify_dead(
        &mut self,
        soup: &mut TriangleSoup,
        p: &McmcParams,
        mut dead: Vec<bool>,
        rng: &mut Rng,
    ) -> Vec<Source> {
        let n = soup.len();
        let n_dead = dead.iter().filter(|&&d| d).count();
        let n_add = growth_count(n, n_dead, p.add_shape, p.max_shapes);
        // Efraimidis–Spirakis keys ln(u)/w over the alive triangles
        let by_opacity = self.steps.is_multiple_of(2);
        let mut keys: Vec<(f64, usize)> = (0..n)
            .filter(|&i| !dead[i])
            .map(|i| {
                let w = if by_opacity {
                    soup.opacity(i) as f64
                } else {
                    1.0 / soup.sigma(i).max(1e-6) as f64
                };
                let u: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
                let key = if w > 0.0 {
                    u.ln() / w
                } else {
                    f64::NEG_INFINITY
                };
                (key, i)
            })
            .collect();
        keys.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut picks = Vec::new();
        let mut cost = 0;
        for &(_, i) in &keys {
            if cost >= n_add {
                break;
            }
            let big = self.image_size[i] > p.split_size;
            cost += if big { 3 } else { 1 };
            picks.push((i, big));
        }
        for &(i, _) in &picks {
            dead[i] = true; // parents go too
        }
        let k3 = soup.rest_per_channel() * 3;
        let mut out = soup.gather(&(0..n).filter(|&i| !dead[i]).collect::<Vec<_>>());
        let mut sources: Vec<Source> = (0..n).filter(|&i| !dead[i]).map(Source::Old).collect();
        for &(i, big) in &picks {
            let t = soup.triangles[i];
            let rest = &soup.sh_rest[i * k3..(i + 1) * k3];
            let mut push = |tri: [[f32; 3]; 3], opacity_raw: f32| {
                out.triangles.push(tri);
                out.opacity_raw.push(opacity_raw);
                out.sigma_raw.push(soup.sigma_raw[i]);
                out.sh_dc.push(soup.sh_dc[i]);
                out.sh_rest.extend_from_slice(rest);
                sources.push(Source::New);
            };
            if big {
                for c in split4(t) {
                    push(c, soup.opacity_raw[i]);
                }
            } else {
                let o = logit(clone_opacity(sigmoid(soup.opacity_raw[i])).clamp(1e-6, 1.0 - 1e-6));
                let u: [f64; 3] = std::array::from_fn(|_| rng.random::<f64>());
                push(t, o);
                push(moved_clone(t, u, p.max_noise_factor), o);
            }
        }
        out.extras = Default::default();
        *soup = out;
        self.steps += 1;
        self.reset(soup.len());
        sources
    }

    /// Removes the dead (plus `also[i]`) without growth; returns the row
    /// sources.
    pub fn prune(
        &mut self,
        soup: &mut TriangleSoup,
        p: &McmcParams,
        check_visibility: bool,
        also: impl Fn(usize) -> bool,
    ) -> Vec<Source> {
        let dead = self.dead(soup, p, check_visibility);
        let keep: Vec<usize> = (0..soup.len()).filter(|&i| !dead[i] && !also(i)).collect();
        *soup = soup.gather(&keep);
        self.reset(soup.len());
        keep.into_iter().map(Source::Old).collect()
    }
}

/// Triangle Splatting's densification as a [`Strategy`] (see the module
/// docs).
#[derive(Clone, Debug)]
pub struct Mcmc {
    params: McmcParams,
    state: McmcState,
    seed: u64,
    /// The reference's 500-iteration interval, scaled.
    interval: u64,
    /// Densify after this iteration…
    from: u64,
    /// …and before this one; prune only from it on.
    until: u64,
    /// The game-engine variant's final phase: opacity threshold 0.7 after
    /// the first, σ ≥ 1 removed after the second.
    game_engine: Option<(u64, u64)>,
}

/// RNG tag of a step's picks (the stream is `(seed ^ tag, iteration)`).
const RNG_TAG: u64 = 0x7269_616e_676c_6573;

impl Mcmc {
    /// The schedule of `p` for a soup of `n` triangles.
    pub fn new(p: &TriangleParams, n: usize) -> Self {
        Mcmc {
            params: p.mcmc.clone(),
            state: McmcState::new(n),
            seed: p.seed,
            interval: p.at(500),
            from: p.at(500),
            until: p.at(25_000),
            game_engine: p.game_engine.then(|| (p.at(29_000), p.at(28_000))),
        }
    }
}

impl Strategy<TriangleSoup> for Mcmc {
    fn name(&self) -> &'static str {
        "mcmc"
    }

    fn observes(&self, _iteration: u64) -> bool {
        true
    }

    fn observe(&mut self, s: &TriangleStats) {
        self.state.observe(s);
    }

    fn edit(&mut self, ctx: StepContext, soup: &mut TriangleSoup) -> Vec<Edit> {
        let it = ctx.iteration;
        // at least one pass over the views between steps (the statistics —
        // importance, views seen — mean nothing over fewer), and at least
        // `MIN_INTERVAL` iterations so a short run's new triangles settle
        // before the next step as the reference's 500 let them
        let interval = self
            .interval
            .max(ctx.train_views as u64)
            .max(super::MIN_INTERVAL);
        if !it.is_multiple_of(interval) {
            return Vec::new();
        }
        let full_pass = self.state.views >= ctx.train_views as u64;
        let mut rng = stream(self.seed ^ RNG_TAG, it);
        let (kind, detail, sources) = if it > self.from && it < self.until {
            let dead = self.state.dead(soup, &self.params, full_pass);
            let detail = self
                .state
                .dead_summary(soup, &self.params, full_pass, &dead);
            let src = self.state.densify_dead(soup, &self.params, dead, &mut rng);
            ("densify", detail, src)
        } else if it >= self.until {
            let mut mp = self.params.clone();
            let mut sigma_cut = f32::INFINITY;
            if let Some((opacity_07_after, sigma_after)) = self.game_engine {
                mp.opacity_dead = if it > opacity_07_after { 0.7 } else { 0.1 };
                if it > sigma_after {
                    sigma_cut = 1.0;
                }
            }
            let soft: Vec<bool> = (0..soup.len())
                .map(|i| soup.sigma(i) >= sigma_cut)
                .collect();
            let src = self.state.prune(soup, &mp, full_pass, |i| soft[i]);
            ("prune", String::new(), src)
        } else {
            return Vec::new();
        };
        vec![Edit {
            kind,
            detail,
            moments: Moments::Remap(sources),
        }]
    }

    fn remap(&mut self, sources: &[Source]) {
        let pick = |v: &[f32]| gather_rows(v, 1, sources, |_| vec![0.0]);
        let st = &mut self.state;
        st.importance = pick(&st.importance);
        st.visible = pick(&st.visible);
        st.image_size = pick(&st.image_size);
    }

    fn save(&self, out: &mut Vec<GroupState>) {
        let st = &self.state;
        let extra = GroupState::values;
        out.push(extra("state/importance", st.importance.clone()));
        out.push(extra("state/visible", st.visible.clone()));
        out.push(extra("state/image_size", st.image_size.clone()));
        out.push(extra(
            "state/counters",
            vec![st.views as f32, st.steps as f32],
        ));
    }

    fn load(&mut self, groups: &[GroupState], n: usize) -> crate::Result<()> {
        let get = |name: &str, len: usize| find_values(groups, name, len, "triangle");
        let c = get("state/counters", 2)?;
        self.state = McmcState {
            importance: get("state/importance", n)?,
            visible: get("state/visible", n)?,
            image_size: get("state/image_size", n)?,
            views: c[0] as u64,
            steps: c[1] as u64,
        };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::rng::seeded;

    fn soup(n: usize) -> TriangleSoup {
        TriangleSoup {
            triangles: (0..n)
                .map(|i| {
                    let x = i as f32;
                    [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 1.0, 0.0]]
                })
                .collect(),
            opacity_raw: vec![0.0; n],
            sigma_raw: vec![0.0; n],
            sh_degree: 1,
            active_sh_degree: 0,
            sh_dc: (0..n).map(|i| [i as f32; 3]).collect(),
            sh_rest: (0..n * 9).map(|v| v as f32).collect(),
            extras: Default::default(),
        }
    }

    /// 30 % growth: 100 → 130 with no dead (30 added); with 7 dead, 37 are
    /// added so the total is still 130; the cap wins; growth never negative.
    #[test]
    fn growth_arithmetic() {
        assert_eq!(growth_count(100, 0, 1.3, 1_000), 30);
        assert_eq!(growth_count(100, 7, 1.3, 1_000), 37);
        assert_eq!(growth_count(100, 7, 1.3, 110), 17);
        assert_eq!(growth_count(100, 2, 1.3, 50), 2);
        assert_eq!(growth_count(3, 0, 1.3, 100), 0); // ⌊3.9⌋ = 3
    }

    /// Dead: low importance, low opacity, too few views (only when asked),
    /// too big indoors.
    #[test]
    fn dead_mask() {
        let mut s = soup(5);
        s.opacity_raw[1] = logit(0.01);
        let mut st = McmcState::new(5);
        st.importance = vec![0.5, 0.5, 0.01, 0.5, 0.5];
        st.visible = vec![3.0, 3.0, 3.0, 1.0, 3.0];
        st.image_size = vec![10.0, 10.0, 10.0, 10.0, 2000.0];
        let mut p = McmcParams::default();
        assert_eq!(st.dead(&s, &p, true), vec![false, true, true, true, false]);
        // without a full pass only the opacity rule
        assert_eq!(
            st.dead(&s, &p, false),
            vec![false, true, false, false, false]
        );
        p.max_screen_radius = Some(1400.0);
        assert_eq!(st.dead(&s, &p, true), vec![false, true, true, true, true]);
        // never all
        st.importance = vec![0.0; 5];
        assert_eq!(st.dead(&s, &p, true), vec![false; 5]);
    }

    /// The 4 children tile the parent: same total area, corners and
    /// midpoints as hand-computed.
    #[test]
    fn split_is_midpoint_subdivision() {
        let t = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
        let c = split4(t);
        assert_eq!(c[0], [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        assert_eq!(c[1], [[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 1.0, 0.0]]);
        assert_eq!(c[2], [[0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 2.0, 0.0]]);
        assert_eq!(c[3], [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]);
    }

    /// The clone moves rigidly within the triangle's plane, by at most
    /// ½·extent·noise per axis; two clones of opacity 1 − sqrt(1 − o)
    /// composite to o.
    #[test]
    fn clone_moves_in_plane_and_keeps_opacity() {
        let t = [[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
        let m = moved_clone(t, [1.0, 0.0, 0.9], 1.5);
        let d = [m[0][0] - t[0][0], m[0][1] - t[0][1], m[0][2] - t[0][2]];
        // in-plane: z unchanged; x by +0.5·2·1.5, y by −0.5·1·1.5
        assert!((d[0] - 1.5).abs() < 1e-6 && (d[1] + 0.75).abs() < 1e-6 && d[2].abs() < 1e-6);
        for k in 0..3 {
            for j in 0..3 {
                assert!((m[k][j] - t[k][j] - d[j]).abs() < 1e-6, "rigid");
            }
        }
        for o in [0.1f32, 0.5, 0.9, 0.99] {
            let c = clone_opacity(o);
            assert!((1.0 - (1.0 - c) * (1.0 - c) - o).abs() < 1e-6);
        }
    }

    /// A densification step: dead removed, big picks become 4 children,
    /// small ones 2 clones with the opacity rule, survivors keep their rows
    /// (Old) and new rows are New (zero moments); the count grows to
    /// ⌊1.3·N⌋ (up to the last pick's cost overshoot).
    #[test]
    fn densify_step() {
        let n = 20;
        let mut s = soup(n);
        let mut st = McmcState::new(n);
        st.importance = vec![0.5; n];
        st.importance[3] = 0.0; // dead
        st.image_size = (0..n)
            .map(|i| if i % 2 == 0 { 30.0 } else { 5.0 })
            .collect();
        let before = s.clone();
        st.visible = vec![5.0; n];
        let src = st.densify(&mut s, &McmcParams::default(), true, &mut seeded(4));
        assert_eq!(src.len(), s.len());
        assert!(s.len() >= 26 && s.len() <= 28, "{}", s.len()); // 6 + 1 relocated, cost ≥ 7
        let old: Vec<usize> = src
            .iter()
            .filter_map(|x| match x {
                Source::Old(i) => Some(*i),
                Source::New => None,
            })
            .collect();
        assert!(!old.contains(&3));
        for (row, &i) in old.iter().enumerate() {
            assert_eq!(s.triangles[row], before.triangles[i]);
        }
        let new = src.iter().filter(|x| **x == Source::New).count();
        let parents = n - 1 - old.len();
        assert!(new >= 2 * parents && new <= 4 * parents);
        // clones carry the opacity rule, children the parent's raw opacity
        let o_clone = logit(clone_opacity(0.5));
        for r in old.len()..s.len() {
            let o = s.opacity_raw[r];
            assert!(o == 0.0 || (o - o_clone).abs() < 1e-6, "{o}");
        }
        assert_eq!(st.steps, 1);
        assert_eq!(st.importance, vec![0.0; s.len()]);
        assert_eq!(s.sh_rest.len(), s.len() * 9);
    }
}
