//! SuGaR's sample set P: points drawn around Gaussians near the rendered
//! surface of the current view.

use glam::DVec3;
use rand::RngExt;

use super::geometry::geometry;
use crate::model::rng::Rng;
use crate::model::{Camera, Gaussians};

/// Points sampled around Gaussians: `points[i] = μ_o + R_o(1.5·s_o ⊙ eps[i])`
/// with `o = owner[i]` (world space, scene units; `eps` are standard normal
/// draws in the owner's local axes).
///
/// Gradients flow through the points, as in SuGaR: the regularisers
/// recompute each point from `owner` and `eps` with the current parameters,
/// so `p` is a function of the owner's μ, R and s with ε fixed. `points`
/// holds the values at sampling time, for callers that only need positions.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Samples {
    pub points: Vec<[f32; 3]>,
    pub owner: Vec<u32>,
    pub eps: Vec<[f32; 3]>,
}

impl Samples {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.owner.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.owner.is_empty()
    }
}

/// Draws `n` samples (SuGaR: 1,000,000 per iteration): each picks its owner
/// uniformly among `candidates` (not in proportion to volume), then
/// ε ~ N(0, I) (Box–Muller on the generator's uniforms) and
/// `p = μ + R(1.5·s ⊙ ε)`. Sequential on `rng`, so reproducible from its
/// seed. Empty `candidates` give no samples.
pub fn sample_points(g: &Gaussians, candidates: &[u32], n: usize, rng: &mut Rng) -> Samples {
    super::check(g);
    let mut out = Samples::default();
    if candidates.is_empty() {
        return out;
    }
    let geo = geometry(g);
    out.points.reserve(n);
    out.owner.reserve(n);
    out.eps.reserve(n);
    for _ in 0..n {
        let o = candidates[rng.random_range(0..candidates.len())];
        let (e0, e1) = gauss_pair(rng);
        let (e2, _) = gauss_pair(rng);
        let eps = [e0 as f32, e1 as f32, e2 as f32];
        let p = super::density::sample_point(&geo[o as usize], eps.map(f64::from));
        out.points.push(p.map(|v| v as f32));
        out.owner.push(o);
        out.eps.push(eps);
    }
    out
}

/// Two independent standard normal values (Box–Muller).
fn gauss_pair(rng: &mut Rng) -> (f64, f64) {
    // u1 in (0, 1] so that ln(u1) is finite
    let u1 = 1.0 - rng.random::<f64>();
    let u2 = rng.random::<f64>();
    let r = (-2.0 * u1.ln()).sqrt();
    let t = std::f64::consts::TAU * u2;
    (r * t.cos(), r * t.sin())
}

/// The Gaussians SuGaR samples around in a view: those whose centre
/// projects into the image in front of the camera (z > 0; this stands in
/// for the rasteriser's "rendered with a positive radius"), where the
/// rendered `depth` (view-space z, row-major `width × height`, 0 = none) at
/// the centre's pixel (the pixel containing the projection, centres at
/// integer + 0.5) is positive, and whose centre's view z lies within
/// `n_sigma` (SuGaR: 2) standard deviations of that depth:
/// `|depth − z| < n_sigma·σ`, with σ = sqrt(vᵀΣv) the Gaussian's standard
/// deviation along the unit viewing direction v from the camera centre to
/// its centre (SuGaR's choice; not the largest scale). Indices ascending.
///
/// Panics when `depth.len() != width·height`.
pub fn visible_candidates(g: &Gaussians, cam: &Camera, depth: &[f32], n_sigma: f64) -> Vec<u32> {
    super::check(g);
    let (w, h) = (cam.width as usize, cam.height as usize);
    assert_eq!(depth.len(), w * h, "depth size must be width × height");
    let geo = geometry(g);
    let eye = cam.center();
    let mut out = Vec::new();
    for (i, ge) in geo.iter().enumerate() {
        let mu = DVec3::from_array(ge.mu);
        let Some((px, z)) = cam.project(mu) else {
            continue;
        };
        let Some(pix) = pixel_index(px.x, px.y, w, h) else {
            continue;
        };
        let d = depth[pix] as f64;
        if d <= 0.0 || !d.is_finite() {
            continue;
        }
        let v = (mu - eye).normalize_or_zero().to_array();
        // σ² = Σ_k s_k² ⟨R_k, v⟩²
        let var: f64 = (0..3)
            .map(|k| {
                let c = ge.r[0][k] * v[0] + ge.r[1][k] * v[1] + ge.r[2][k] * v[2];
                ge.s[k] * ge.s[k] * c * c
            })
            .sum();
        if (d - z).abs() < n_sigma * var.sqrt() {
            out.push(i as u32);
        }
    }
    out
}

/// Row-major index of the pixel containing pixel coordinates (u, v)
/// (pixel (x, y) covers [x, x+1) × [y, y+1)); `None` outside the image.
pub(super) fn pixel_index(u: f64, v: f64, w: usize, h: usize) -> Option<usize> {
    if !(u >= 0.0 && v >= 0.0 && u < w as f64 && v < h as f64) {
        return None;
    }
    Some(v as usize * w + u as usize)
}
