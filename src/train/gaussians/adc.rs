//! 3DGS's adaptive density control (gaussian_training.md): clone, split,
//! prune from the view-space gradient, and the opacity reset.
//!
//! Statistics per Gaussian between steps: the sum of ‖∂L/∂(screen mean)‖ in
//! NDC units (pixels × (W/2, H/2), as the CUDA backward gives it) over the
//! views where it was visible (radius > 0), their count, and the largest
//! screen radius. At a step, with grad = sum / count (0 when never seen):
//! - **clone** where grad ≥ threshold and max scale ≤ percent_dense·extent:
//!   an identical copy (appended, zero Adam moments);
//! - **split** where grad ≥ threshold and max scale > percent_dense·extent:
//!   2 children at μ + R(s ⊙ ε), ε ~ N(0, I), scales s / 1.6, everything
//!   else copied; the parent removed (clones made in this step are never
//!   split, as in 3DGS where they enter with zero gradient);
//! - **prune** opacity < 0.005, and (`big` set, after the first opacity
//!   reset) max screen radius > 20 px or max scale > 0.1·extent.
//!
//! The opacity reset sets every opacity to min(α, 0.01) and zeroes its Adam
//! moments.
//!
//! [`Adc`] is the [`Strategy`] that runs these on 3DGS's schedule
//! (reference iterations, scaled by [`GaussianParams::at`]): statistics from
//! every view while densifying; densify-and-prune every 100 iterations
//! after 500 (the size prune after 3,000); opacity reset every 3,000 (and
//! at 500 on a white background); nothing after the end of densification
//! (15,000, or SuGaR's 7,000). Its checkpoint groups: `state/grad_sum`,
//! `state/count`, `state/max_radius`.

use glam::{DQuat, DVec3};

use super::GaussianParams;
use crate::model::Gaussians;
use crate::model::gaussians::logit;
use crate::model::optim_state::{GroupState, find_values};
use crate::model::rng::{Rng, normal, stream};
use crate::train::groups::{Source, gather_rows};
use crate::train::strategy::{Edit, GaussianObservation, Moments, StepContext, Strategy};

/// Settings (3DGS defaults in [`Default`], extent 1).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct AdcParams {
    pub grad_threshold: f32,
    pub percent_dense: f64,
    /// cameras_extent (scene units).
    pub extent: f64,
    pub min_opacity: f32,
    pub max_screen_radius: f32,
    pub max_world_fraction: f64,
}

impl Default for AdcParams {
    fn default() -> Self {
        AdcParams {
            grad_threshold: 2e-4,
            percent_dense: 0.01,
            extent: 1.0,
            min_opacity: 0.005,
            max_screen_radius: 20.0,
            max_world_fraction: 0.1,
        }
    }
}

/// Accumulated statistics (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AdcState {
    pub grad_sum: Vec<f32>,
    pub count: Vec<f32>,
    pub max_radius: Vec<f32>,
}

impl AdcState {
    pub fn new(n: usize) -> Self {
        AdcState {
            grad_sum: vec![0.0; n],
            count: vec![0.0; n],
            max_radius: vec![0.0; n],
        }
    }

    /// Adds one view: NDC screen-mean gradients and screen radii (0 = not
    /// visible).
    pub fn observe(&mut self, means2d_ndc: &[[f32; 2]], radii: &[f32]) {
        for i in 0..self.grad_sum.len() {
            if radii[i] > 0.0 {
                let [x, y] = means2d_ndc[i];
                self.grad_sum[i] += (x * x + y * y).sqrt();
                self.count[i] += 1.0;
                self.max_radius[i] = self.max_radius[i].max(radii[i]);
            }
        }
    }

    /// Keeps the statistics of the rows `sources` (new rows start at 0).
    pub fn remap(&mut self, sources: &[Source]) {
        let pick = |v: &[f32]| gather_rows(v, 1, sources, |_| vec![0.0]);
        *self = AdcState {
            grad_sum: pick(&self.grad_sum),
            count: pick(&self.count),
            max_radius: pick(&self.max_radius),
        };
    }

    /// Mean gradient per Gaussian (0 where never visible).
    pub fn mean_grad(&self) -> Vec<f32> {
        self.grad_sum
            .iter()
            .zip(&self.count)
            .map(|(&s, &c)| if c > 0.0 { s / c } else { 0.0 })
            .collect()
    }
}

fn max_scale(g: &Gaussians, i: usize) -> f64 {
    g.log_scales[i]
        .iter()
        .fold(f64::MIN, |m, &v| m.max((v as f64).exp()))
}

/// Appends a copy of row `i` of `g` with a new mean and log scales.
fn push_copy(g: &mut Gaussians, i: usize, mean: [f32; 3], log_scales: [f32; 3]) {
    let k3 = g.rest_per_channel() * 3;
    g.means.push(mean);
    g.log_scales.push(log_scales);
    g.rotations.push(g.rotations[i]);
    g.opacity_logits.push(g.opacity_logits[i]);
    g.sh_dc.push(g.sh_dc[i]);
    let rest = g.sh_rest[i * k3..(i + 1) * k3].to_vec();
    g.sh_rest.extend(rest);
    if let Some(n) = &mut g.normals {
        n.push([0.0; 3]);
    }
}

#[allow(clippy::needless_range_loop)] // parallel arrays of the model, indexed together
/// One densify-and-prune step; `big`: apply the screen/world size prune.
/// Returns the row sources of the edited model and resets the statistics.
pub fn densify_and_prune(
    g: &mut Gaussians,
    st: &mut AdcState,
    p: &AdcParams,
    big: bool,
    rng: &mut Rng,
) -> Vec<Source> {
    let n = g.len();
    let grads = st.mean_grad();
    let limit = p.percent_dense * p.extent;
    let mut sources: Vec<Source> = (0..n).map(Source::Old).collect();
    // clone
    for i in 0..n {
        if grads[i] >= p.grad_threshold && max_scale(g, i) <= limit {
            push_copy(g, i, g.means[i], g.log_scales[i]);
            sources.push(Source::New);
        }
    }
    // split (originals only)
    let mut remove = vec![false; g.len()];
    for i in 0..n {
        if grads[i] >= p.grad_threshold && max_scale(g, i) > limit {
            let [w, x, y, z] = g.rotations[i].map(f64::from);
            let q = DQuat::from_xyzw(x, y, z, w);
            let q = if q.length() > 0.0 {
                q.normalize()
            } else {
                DQuat::IDENTITY
            };
            let s = DVec3::from_array(g.log_scales[i].map(|v| (v as f64).exp()));
            let mu = DVec3::from_array(g.means[i].map(f64::from));
            let ls = g.log_scales[i].map(|v| v - 1.6f32.ln());
            for _ in 0..2 {
                let e = DVec3::new(normal(rng), normal(rng), normal(rng));
                let m = mu + q * (s * e);
                push_copy(g, i, m.as_vec3().to_array(), ls);
                sources.push(Source::New);
                remove.push(false);
            }
            remove[i] = true;
        }
    }
    // prune
    let alpha_cut = logit(p.min_opacity);
    for r in 0..g.len() {
        let tiny = g.opacity_logits[r] < alpha_cut;
        let too_big = big
            && (st_radius(st, &sources, r) > p.max_screen_radius
                || max_scale(g, r) > p.max_world_fraction * p.extent);
        if tiny || too_big {
            remove[r] = true;
        }
    }
    let keep: Vec<usize> = (0..g.len()).filter(|&r| !remove[r]).collect();
    *g = g.gather(&keep);
    let sources: Vec<Source> = keep.iter().map(|&r| sources[r]).collect();
    *st = AdcState::new(g.len());
    sources
}

fn st_radius(st: &AdcState, sources: &[Source], r: usize) -> f32 {
    match sources[r] {
        Source::Old(i) => st.max_radius[i],
        Source::New => 0.0,
    }
}

/// 3DGS's opacity reset: α ← min(α, 0.01) for every Gaussian.
pub fn reset_opacity(g: &mut Gaussians) {
    let cap = logit(0.01);
    for o in &mut g.opacity_logits {
        *o = o.min(cap);
    }
}

/// 3DGS's adaptive density control as a [`Strategy`] (see the module docs).
#[derive(Clone, Debug)]
pub struct Adc {
    params: AdcParams,
    state: AdcState,
    seed: u64,
    /// Densification runs while the iteration is below this.
    until: u64,
    /// Densify after this iteration…
    from: u64,
    /// …every this many.
    every: u64,
    /// The size prune after this iteration.
    big_after: u64,
    /// Opacity reset every this many iterations.
    reset_every: u64,
    /// A white background's extra reset at this iteration.
    white_reset_at: Option<u64>,
}

impl Adc {
    /// The schedule of `p` for a model of `n` Gaussians.
    pub fn new(p: &GaussianParams, n: usize) -> Self {
        Adc {
            params: p.adc.clone(),
            state: AdcState::new(n),
            seed: p.seed,
            until: p.densify_until(),
            from: p.at(500),
            every: p.at(100),
            big_after: p.at(3_000),
            reset_every: p.at(3_000),
            white_reset_at: p.white_background.then(|| p.at(500)),
        }
    }
}

/// RNG tag of the split offsets (the stream is `(seed ^ tag, iteration)`).
const RNG_TAG: u64 = 0x0041_4443;

/// Checkpoint group names of the statistics.
const KEYS: [&str; 3] = ["state/grad_sum", "state/count", "state/max_radius"];

impl Strategy<Gaussians> for Adc {
    fn name(&self) -> &'static str {
        "adc"
    }

    fn observes(&self, iteration: u64) -> bool {
        iteration < self.until
    }

    fn observe(&mut self, obs: &GaussianObservation) {
        self.state.observe(&obs.means2d_ndc, &obs.radii);
    }

    fn edit(&mut self, ctx: StepContext, g: &mut Gaussians) -> Vec<Edit> {
        let it = ctx.iteration;
        let mut edits = Vec::new();
        if it >= self.until {
            return edits;
        }
        if it > self.from && it.is_multiple_of(self.every) {
            let big = it > self.big_after;
            let mut rng = stream(self.seed ^ RNG_TAG, it);
            let src = densify_and_prune(g, &mut self.state, &self.params, big, &mut rng);
            let new = src.iter().filter(|s| **s == Source::New).count();
            edits.push(Edit {
                kind: "densify",
                detail: format!("{} kept, {new} new", src.len() - new),
                moments: Moments::Remap(src),
            });
        }
        if it.is_multiple_of(self.reset_every) || self.white_reset_at == Some(it) {
            reset_opacity(g);
            edits.push(Edit {
                kind: "opacity reset",
                detail: String::new(),
                moments: Moments::ZeroGroup("opacity"),
            });
        }
        edits
    }

    fn remap(&mut self, sources: &[Source]) {
        self.state.remap(sources);
    }

    fn save(&self, out: &mut Vec<GroupState>) {
        let st = &self.state;
        for (k, v) in KEYS.iter().zip([&st.grad_sum, &st.count, &st.max_radius]) {
            out.push(GroupState::values(k, v.clone()));
        }
    }

    fn load(&mut self, groups: &[GroupState], n: usize) -> crate::Result<()> {
        let get = |name: &str| find_values(groups, name, n, "Gaussian");
        self.state = AdcState {
            grad_sum: get(KEYS[0])?,
            count: get(KEYS[1])?,
            max_radius: get(KEYS[2])?,
        };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::rng::seeded;

    fn gs(scales: &[f32], opac: &[f32]) -> Gaussians {
        let n = scales.len();
        Gaussians {
            means: (0..n).map(|i| [i as f32, 0.0, 0.0]).collect(),
            normals: None,
            sh_degree: 0,
            sh_dc: vec![[0.1, 0.2, 0.3]; n],
            sh_rest: vec![],
            opacity_logits: opac.iter().map(|&o| logit(o)).collect(),
            log_scales: scales
                .iter()
                .map(|&s| [s.ln(), (0.5 * s).ln(), (0.1 * s).ln()])
                .collect(),
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
            extras: Default::default(),
        }
    }

    /// Thresholds: grad ≥ 2e-4 with max scale ≤ 0.01·extent clones, above
    /// splits into 2 children at scale / 1.6 (parent removed); below the
    /// gradient threshold nothing happens; opacity < 0.005 is pruned; with
    /// `big`, radius > 20 px or scale > 0.1·extent is pruned.
    #[test]
    fn clone_split_prune_thresholds() {
        // extent 10: clone limit 0.1, world limit 1.0
        let mut g = gs(
            &[0.05, 0.5, 0.5, 0.05, 0.05, 2.0],
            &[0.5, 0.5, 0.5, 0.004, 0.5, 0.5],
        );
        let mut st = AdcState::new(6);
        let ndc = vec![
            [3e-4, 0.0],
            [0.0, 3e-4],
            [1e-4, 0.0],
            [0.0, 0.0],
            [0.0, 0.0],
            [0.0, 0.0],
        ];
        let mut radii = vec![5.0; 6];
        radii[4] = 25.0;
        st.observe(&ndc, &radii);
        let p = AdcParams {
            extent: 10.0,
            ..Default::default()
        };
        let before = g.clone();
        let src = densify_and_prune(&mut g, &mut st, &p, true, &mut seeded(1));
        // kept: 0 (cloned), 2 (grad too small); removed: 1 (split), 3
        // (opacity), 4 (radius), 5 (world size); new: clone of 0, 2 children of 1
        assert_eq!(&src[..2], &[Source::Old(0), Source::Old(2)]);
        assert_eq!(&src[2..], &[Source::New; 3]);
        assert_eq!(g.means[2], before.means[0]);
        assert_eq!(g.log_scales[2], before.log_scales[0]);
        for c in 3..5 {
            for k in 0..3 {
                assert!(
                    (g.log_scales[c][k] - (before.log_scales[1][k] - 1.6f32.ln())).abs() < 1e-6
                );
            }
            // within a few standard deviations of the parent
            assert!((g.means[c][0] - 1.0).abs() < 5.0 * 0.5);
        }
        assert_eq!(st, AdcState::new(5));
        // without `big` the radius and world-size rules are off
        let mut g = gs(&[0.05, 2.0], &[0.5, 0.5]);
        let mut st = AdcState::new(2);
        st.observe(&[[0.0; 2]; 2], &[30.0, 5.0]);
        assert_eq!(
            densify_and_prune(&mut g, &mut st, &p, false, &mut seeded(1)).len(),
            2
        );
    }

    /// The gradient is averaged over the views where the Gaussian was
    /// visible only.
    #[test]
    fn gradient_average_over_visible_views() {
        let mut st = AdcState::new(2);
        st.observe(&[[3.0, 4.0], [1.0, 0.0]], &[1.0, 0.0]);
        st.observe(&[[0.0, 1.0], [1.0, 0.0]], &[1.0, 2.0]);
        assert_eq!(st.mean_grad(), vec![3.0, 1.0]);
        assert_eq!(st.max_radius, vec![1.0, 2.0]);
    }

    /// Reset caps opacity at 0.01 and leaves lower ones.
    #[test]
    fn opacity_reset() {
        let mut g = gs(&[1.0, 1.0], &[0.9, 0.001]);
        reset_opacity(&mut g);
        assert!((g.opacity(0) - 0.01).abs() < 1e-6);
        assert!((g.opacity(1) - 0.001).abs() < 1e-6);
    }
}
