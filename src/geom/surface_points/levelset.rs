//! SuGaR's level-set sampling of a 3DGS scene (Guédon & Lepetit, CVPR 2024;
//! `sugar_extractors/coarse_mesh.py::compute_level_surface_points_from_camera_fast`),
//! on the CPU: oriented, coloured points on {d = λ} of the Gaussian density
//! d(p) = min(1, Σ_g α_g exp(−½ (p−μ_g)ᵀ Σ_g⁻¹ (p−μ_g))).
//!
//! Per camera:
//! 1. depth and hit-Gaussian buffer: each Gaussian becomes a "diamond" (two
//!    triangles through μ ± 2·s_k·a_k on its two largest axes) whose vertices
//!    slide along their camera rays onto the plane through μ orthogonal to
//!    the view direction (camera-facing, constant depth, same footprint), and
//!    an opaque z-buffer gives the nearest diamond per pixel
//!    ([`DepthSource::Diamonds`], SuGaR's default); or SuGaR's
//!    `use_gaussian_depth` mode, the 3DGS-blended view z over a background of
//!    −1 ([`DepthSource::Gaussian`], see [`gaussian_depth`]); or the
//!    alpha-blended median depth ([`DepthSource::Median`], not in SuGaR); for
//!    the two blended depths the hit Gaussian is the centre nearest the
//!    back-projected point;
//! 2. random covered pixels (twice the per-view cap, seeded per camera) are
//!    back-projected through their pixel centre to p;
//! 3. along the ray through p, 21 samples over ±3σ, σ = √(vᵀΣv) the hit
//!    Gaussian's standard deviation along the direction v to the camera;
//! 4. d at the samples over 16 neighbours, clamped at 1: the 16 nearest
//!    centres of the hit Gaussian (itself included) for `Diamonds` and
//!    `Median`, the 16 nearest centres of p for `Gaussian` (as SuGaR's
//!    `use_gaussian_depth` branch takes them); a ray counts when d starts
//!    below λ and later exceeds it; the first crossing is interpolated
//!    linearly;
//! 5. normal: ∇d at the point (same neighbours), normalised and turned
//!    toward the camera (SuGaR's own sign points into the surface, which
//!    turns Poisson meshes inside out);
//! 6. colour: the pixel of a DC-only render (black background).
//!
//! At most ⌊max_points / cameras⌋ + 1 points per view and level are kept (the
//! first valid rays in sampled order). Output order: camera, then level, then
//! ray; deterministic for a given seed whatever the thread count.

use rand::RngExt;
use rayon::prelude::*;
use splatkit_render::gaussian::{self, Filter2d, Gaussians3, RasterSettings, RenderOutput};

use crate::geom::sampling::knn::NnIndex;
use crate::geom::surface_points::diamond_zbuffer::{diamond_zbuffer, frame};
use crate::model::rng;
use crate::model::{Camera, Column, PointCloud, Property, ScalarData, rig};
use crate::{Error, Result};

/// A point and its unit normal.
type Oriented = ([f64; 3], [f64; 3]);

/// Where the per-pixel depth and hit Gaussian come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthSource {
    /// Camera-facing ±2σ diamonds in a z-buffer (SuGaR's default): the depth
    /// of the nearest diamond, and its Gaussian as the hit; the density
    /// neighbours are the hit Gaussian's 16 nearest centres.
    Diamonds,
    /// SuGaR's `use_gaussian_depth_for_surface_levels=True`: the 3DGS
    /// rasteriser run with each Gaussian's view z as its colour over a
    /// background of −1, i.e. Σ wᵢzᵢ − T (not divided by the alpha; see
    /// [`gaussian_depth`]); pixels at or below 0 are dropped. The hit is the
    /// centre nearest the back-projected point p, and the density neighbours
    /// are p's 16 nearest centres. Where the alpha is below 1 the value is
    /// pulled toward the camera by T·(z + 1), so translucent pixels start
    /// their rays in front of the surface and often find no crossing.
    Gaussian,
    /// The alpha-blended median depth where the alpha reaches 0.5 (not a
    /// SuGaR mode): the hit is the centre nearest the back-projected point,
    /// the density neighbours are the hit Gaussian's 16 nearest centres.
    Median,
}

/// SuGaR's Gaussian depth per pixel, in camera z (scene units): what the
/// 3DGS rasteriser returns with the Gaussians' view z as colours and a
/// background of −1, Σ wᵢ zᵢ + T·(−1) with wᵢ = αᵢTᵢ and T = 1 − alpha the
/// final transmittance. From the renderer's expected depth E = Σwz/Σw and
/// alpha A = Σw: E·A − (1 − A). Uncovered pixels give exactly −1; a value
/// is a plain weighted sum, not normalised, so it lies between −1 and the
/// blended depths, below them wherever A < 1.
pub fn gaussian_depth(img: &RenderOutput) -> Vec<f32> {
    img.expected_depth
        .iter()
        .zip(&img.alpha)
        .map(|(&e, &a)| e * a - (1.0 - a))
        .collect()
}

/// The hit index of a pixel whose Gaussian is found per ray, from the
/// back-projected point (the blended-depth sources).
const HIT_FROM_POINT: u32 = u32::MAX;

/// Options of [`sample_levelset`] (SuGaR's defaults).
#[derive(Clone, Debug)]
pub struct LevelsetOptions {
    /// Levels λ of the density.
    pub levels: Vec<f32>,
    /// Total point cap over all views (per level).
    pub max_points: usize,
    /// Gaussians with opacity ≤ this are dropped first.
    pub min_opacity: f32,
    /// Samples per ray.
    pub samples: usize,
    /// Half-range of the ray samples, in σ along the ray.
    pub range: f64,
    /// Neighbours of the hit Gaussian in the density sum.
    pub knn: usize,
    pub depth: DepthSource,
    pub seed: u64,
    /// Near plane for the depth renders.
    pub near: f64,
    /// The 2-D filter of the renders (3DGS's dilation by default; the Mip
    /// filter for Mip-Splatting / GOF models).
    pub filter_2d: Filter2d,
}

impl Default for LevelsetOptions {
    fn default() -> Self {
        LevelsetOptions {
            levels: vec![0.3],
            max_points: 10_000_000,
            min_opacity: 0.5,
            samples: 21,
            range: 3.0,
            knn: 16,
            depth: DepthSource::Diamonds,
            seed: 0,
            near: 0.2,
            filter_2d: Filter2d::default(),
        }
    }
}

/// Sampled points with their provenance.
#[derive(Clone, Debug, Default)]
pub struct LevelPoints {
    pub positions: Vec<[f32; 3]>,
    /// Unit normals facing the camera that sampled the point.
    pub normals: Vec<[f32; 3]>,
    pub colors: Vec<[u8; 3]>,
    /// The level λ of each point.
    pub level: Vec<f32>,
    /// Index of the camera that sampled each point.
    pub camera: Vec<u32>,
}

/// The density field of a set of Gaussians around each Gaussian.
pub struct Density {
    means: Vec<[f64; 3]>,
    /// Σ⁻¹, row-major.
    inv_cov: Vec<[f64; 9]>,
    /// Σ, row-major.
    cov: Vec<[f64; 9]>,
    opacity: Vec<f64>,
    /// The k nearest centres of each Gaussian (itself first).
    neighbours: Vec<Vec<u32>>,
}

impl Density {
    /// Builds the field: covariances and the k-nearest-centre table.
    pub fn new(g: &Gaussians3, k: usize) -> Result<Density> {
        let means: Vec<[f64; 3]> = g.means.iter().map(|m| m.map(f64::from)).collect();
        let index = NnIndex::new(&means)?;
        let neighbours = means
            .par_iter()
            .map(|m| {
                index
                    .k_nearest(m, k)
                    .into_iter()
                    .map(|i| i as u32)
                    .collect()
            })
            .collect();
        let (cov, inv_cov): (Vec<[f64; 9]>, Vec<[f64; 9]>) = (0..g.len())
            .into_par_iter()
            .map(|i| {
                let (r, s) = frame(g, i);
                let mut c = [0.0; 9];
                let mut ci = [0.0; 9];
                for a in 0..3 {
                    for b in 0..3 {
                        for k in 0..3 {
                            c[3 * a + b] += r[a][k] * r[b][k] * s[k] * s[k];
                            ci[3 * a + b] += r[a][k] * r[b][k] / (s[k] * s[k]);
                        }
                    }
                }
                (c, ci)
            })
            .unzip();
        Ok(Density {
            means,
            inv_cov,
            cov,
            opacity: g.opacities.iter().map(|&o| o as f64).collect(),
            neighbours,
        })
    }

    /// d(p) over the neighbours of Gaussian `hit`, clamped at 1, and the
    /// unclamped gradient ∇d.
    pub fn at(&self, hit: usize, p: [f64; 3]) -> (f64, [f64; 3]) {
        self.at_over(&self.neighbours[hit], p)
    }

    /// The k nearest centres of Gaussian `i` (itself first).
    pub fn neighbours(&self, i: usize) -> &[u32] {
        &self.neighbours[i]
    }

    /// d(p) summed over the Gaussians `set`, clamped at 1, and the unclamped
    /// gradient ∇d. A term whose Mahalanobis square q exceeds 80 is left out:
    /// it is below α·e^{−40} ≈ 4.2e−18·α.
    pub fn at_over(&self, set: &[u32], p: [f64; 3]) -> (f64, [f64; 3]) {
        let mut d = 0.0;
        let mut grad = [0.0; 3];
        for &j in set {
            let j = j as usize;
            let m = self.means[j];
            let x = [p[0] - m[0], p[1] - m[1], p[2] - m[2]];
            let ci = &self.inv_cov[j];
            let y = [
                ci[0] * x[0] + ci[1] * x[1] + ci[2] * x[2],
                ci[3] * x[0] + ci[4] * x[1] + ci[5] * x[2],
                ci[6] * x[0] + ci[7] * x[1] + ci[8] * x[2],
            ];
            let q = x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
            if q > 80.0 {
                continue; // e^{-40} < 5e-18: below f64 resolution of d ≤ 1
            }
            let w = self.opacity[j] * (-0.5 * q).exp();
            d += w;
            for k in 0..3 {
                grad[k] -= w * y[k];
            }
        }
        (d.min(1.0), grad)
    }

    /// Standard deviation of Gaussian `i` along unit direction `v`: √(vᵀΣv).
    pub fn sigma_along(&self, i: usize, v: [f64; 3]) -> f64 {
        let c = &self.cov[i];
        let cv = [
            c[0] * v[0] + c[1] * v[1] + c[2] * v[2],
            c[3] * v[0] + c[4] * v[1] + c[5] * v[2],
            c[6] * v[0] + c[7] * v[1] + c[8] * v[2],
        ];
        (v[0] * cv[0] + v[1] * cv[1] + v[2] * cv[2]).max(0.0).sqrt()
    }
}

/// Per pixel: camera z and hit Gaussian (`None` where nothing is hit;
/// [`HIT_FROM_POINT`] where the hit is found per ray).
fn depth_and_hits(
    g: &Gaussians3,
    cam: &Camera,
    opts: &LevelsetOptions,
    centres: &NnIndex,
) -> Vec<Option<(f32, u32)>> {
    match opts.depth {
        DepthSource::Diamonds => diamond_zbuffer(g, cam, opts.near),
        DepthSource::Gaussian => {
            let s = RasterSettings {
                background: [0.0; 3],
                near: opts.near,
                filter_2d: opts.filter_2d,
                ..Default::default()
            };
            // SuGaR drops depth < 0; a depth of exactly 0 would put p at the
            // camera centre (no ray direction), so it is dropped too
            gaussian_depth(&gaussian::render(g, cam, &s))
                .into_iter()
                .map(|d| (d > 0.0).then_some((d, HIT_FROM_POINT)))
                .collect()
        }
        DepthSource::Median => {
            let s = RasterSettings {
                background: [0.0; 3],
                near: opts.near,
                filter_2d: opts.filter_2d,
                ..Default::default()
            };
            let img = gaussian::render(g, cam, &s);
            let w = cam.width as usize;
            img.opaque_median_depth()
                .par_iter()
                .enumerate()
                .map(|(o, &d)| {
                    if d <= 0.0 {
                        return None;
                    }
                    let p = rig::back_project(cam, o % w, o / w, d as f64).to_array();
                    centres.nearest(&p).map(|(i, _)| (d, i as u32))
                })
                .collect()
        }
    }
}

/// The Gaussians with opacity > `min_opacity` and a finite centre, with
/// their SH cut to the DC term: (their indices in `g`, the subset).
pub fn opaque_dc_subset(g: &Gaussians3, min_opacity: f32) -> (Vec<usize>, Gaussians3) {
    let keep: Vec<usize> = (0..g.len())
        .filter(|&i| g.opacities[i] > min_opacity && g.means[i].iter().all(|v| v.is_finite()))
        .collect();
    let nc = (g.sh_degree + 1) * (g.sh_degree + 1);
    let kept = Gaussians3 {
        means: keep.iter().map(|&i| g.means[i]).collect(),
        scales: keep.iter().map(|&i| g.scales[i]).collect(),
        rotations: keep.iter().map(|&i| g.rotations[i]).collect(),
        opacities: keep.iter().map(|&i| g.opacities[i]).collect(),
        sh: keep.iter().map(|&i| g.sh[i * nc]).collect(),
        sh_degree: 0,
    };
    (keep, kept)
}

/// Samples oriented points on the level sets of `g` (activated values) seen
/// from `cams`.
pub fn sample_levelset(
    g: &Gaussians3,
    cams: &[Camera],
    opts: &LevelsetOptions,
    mut progress: impl FnMut(usize),
) -> Result<LevelPoints> {
    if cams.is_empty() {
        return Err(Error::invalid("no cameras to sample from"));
    }
    if opts.samples < 2 || opts.knn == 0 || opts.range.is_nan() || opts.range <= 0.0 {
        return Err(Error::invalid(
            "need at least 2 samples per ray, 1 neighbour and a positive range",
        ));
    }
    if let Some(l) = opts.levels.iter().find(|l| !(**l > 0.0 && **l < 1.0)) {
        return Err(Error::invalid(format!("level {l} is not in (0, 1)")));
    }
    // 1. opacity filter
    let (_, kept) = opaque_dc_subset(g, opts.min_opacity);
    let mut out = LevelPoints::default();
    if kept.is_empty() {
        return Ok(out);
    }
    let field = Density::new(&kept, opts.knn)?;
    let centres = NnIndex::new(&field.means)?;
    let per_view = opts.max_points / cams.len() + 1;
    let colour_settings = RasterSettings {
        background: [0.0; 3],
        near: opts.near,
        filter_2d: opts.filter_2d,
        ..Default::default()
    };
    for (ci, cam) in cams.iter().enumerate() {
        let w = cam.width as usize;
        let hits = depth_and_hits(&kept, cam, opts, &centres);
        let covered: Vec<u32> = (0..hits.len())
            .filter(|&o| hits[o].is_some())
            .map(|o| o as u32)
            .collect();
        if covered.is_empty() {
            progress(ci);
            continue;
        }
        // 2·cap random covered pixels, without replacement (partial shuffle)
        let mut rng = rng::golden_stream(opts.seed, ci as u64);
        let mut pool = covered;
        let take = (2 * per_view).min(pool.len());
        for k in 0..take {
            let j = rng.random_range(k..pool.len());
            pool.swap(k, j);
        }
        pool.truncate(take);
        // DC colour at the chosen pixels only (same values as a full render)
        let rgb = gaussian::render_pixels(&kept, cam, &colour_settings, &pool);
        let eye = cam.center();
        let eye = [eye.x, eye.y, eye.z];
        // per ray: the crossing for each level
        let rays: Vec<Vec<Option<Oriented>>> = pool
            .par_iter()
            .map(|&o| {
                let o = o as usize;
                let (z, hit) = hits[o].expect("covered");
                let p = rig::back_project(cam, o % w, o / w, z as f64).to_array();
                // the density neighbours: the hit Gaussian's, or p's own
                let own: Vec<u32>;
                let (hit, set) = if hit == HIT_FROM_POINT {
                    own = centres
                        .k_nearest(&p, opts.knn)
                        .into_iter()
                        .map(|i| i as u32)
                        .collect();
                    // no neighbour (a non-finite depth from a corrupt
                    // scene): this ray crosses no level
                    let Some(&first) = own.first() else {
                        return opts.levels.iter().map(|_| None).collect();
                    };
                    (first as usize, own.as_slice())
                } else {
                    (hit as usize, field.neighbours(hit as usize))
                };
                let mu = field.means[hit];
                let v = unit([eye[0] - mu[0], eye[1] - mu[1], eye[2] - mu[2]]);
                let dir = unit([p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]]);
                let sigma = field.sigma_along(hit, v);
                let n = opts.samples;
                let ts: Vec<f64> = (0..n)
                    .map(|i| opts.range * sigma * (2.0 * i as f64 / (n - 1) as f64 - 1.0))
                    .collect();
                let at = |t: f64| [p[0] + t * dir[0], p[1] + t * dir[1], p[2] + t * dir[2]];
                // densities along the ray, evaluated only as far as the
                // crossings need (the first crossing of every level)
                let mut ds: Vec<f64> = Vec::with_capacity(n);
                let mut density = |j: usize| -> f64 {
                    while ds.len() <= j {
                        ds.push(field.at_over(set, at(ts[ds.len()])).0);
                    }
                    ds[j]
                };
                opts.levels
                    .iter()
                    .map(|&lam| {
                        let lam = lam as f64;
                        let d0 = density(0);
                        if d0.is_nan() || d0 >= lam {
                            return None;
                        }
                        let j = (1..n).find(|&j| density(j) > lam)?;
                        let ds = [density(j - 1), density(j)];
                        let t = ts[j - 1] + (lam - ds[0]) / (ds[1] - ds[0]) * (ts[j] - ts[j - 1]);
                        let x = at(t);
                        let (_, gr) = field.at_over(set, x);
                        let l = (gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]).sqrt();
                        if !(l > 0.0 && l.is_finite()) {
                            return None;
                        }
                        let mut nrm = gr.map(|c| c / l);
                        let to_cam = [eye[0] - x[0], eye[1] - x[1], eye[2] - x[2]];
                        if nrm[0] * to_cam[0] + nrm[1] * to_cam[1] + nrm[2] * to_cam[2] < 0.0 {
                            nrm = nrm.map(|c| -c);
                        }
                        Some((x, nrm))
                    })
                    .collect()
            })
            .collect();
        for (li, &lam) in opts.levels.iter().enumerate() {
            let mut n = 0;
            for (ri, r) in rays.iter().enumerate() {
                if n == per_view {
                    break;
                }
                let Some((x, nrm)) = r[li] else {
                    continue;
                };
                let c = rgb[ri];
                out.positions.push(x.map(|v| v as f32));
                out.normals.push(nrm.map(|v| v as f32));
                out.colors
                    .push(c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8));
                out.level.push(lam);
                out.camera.push(ci as u32);
                n += 1;
            }
        }
        progress(ci);
    }
    Ok(out)
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 { v.map(|c| c / l) } else { v }
}

/// The output cloud, with `level` / `camera` properties when asked.
pub fn to_point_cloud(p: LevelPoints, provenance: bool) -> PointCloud {
    let mut pc = PointCloud {
        positions: p.positions,
        normals: Some(p.normals),
        colors: Some(p.colors),
        ..Default::default()
    };
    if provenance {
        pc.extras.item.push(Property {
            name: "level".into(),
            data: Column::Scalar(ScalarData::F32(p.level)),
        });
        pc.extras.item.push(Property {
            name: "camera".into(),
            data: Column::Scalar(ScalarData::U32(p.camera)),
        });
    }
    pc
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DVec3};

    fn camera_at_origin(w: u32, f: f64) -> Camera {
        Camera::pinhole(
            "c",
            w,
            w,
            f,
            f,
            w as f64 / 2.0,
            w as f64 / 2.0,
            DMat3::IDENTITY,
            DVec3::ZERO,
        )
    }

    /// One flat, camera-facing Gaussian on the optical axis at depth `z0`
    /// (in-plane σ `sig`, thickness `s`, opacity `op`, identity rotation).
    fn flat_gaussian(z0: f32, sig: f32, s: f32, op: f32) -> Gaussians3 {
        Gaussians3 {
            means: vec![[0.0, 0.0, z0]],
            scales: vec![[sig, sig, s]],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]],
            opacities: vec![op],
            sh: vec![[1.0, 0.0, 0.0]],
            sh_degree: 0,
        }
    }

    /// Checks every point of [`flat_gaussian`]`(z0, sig, s, op)` against the
    /// closed form. Along a ray through the point at in-plane radius r the
    /// density is op·e^{−r²/(2σ²)}·e^{−h²/(2s²)}, so the first crossing of λ
    /// lies at h = s·√(−2 ln(λ / (op·e^{−r²/2σ²}))) in front of the plane.
    /// Linear interpolation between samples 0.3 s apart errs by well under
    /// 0.05 s. Normals are the closed-form ∇d = −d·Σ⁻¹(x − μ), normalised and
    /// turned to the camera (−z here).
    fn assert_on_flat_gaussian(pts: &LevelPoints, z0: f64, sig: f64, s: f64, op: f64, what: &str) {
        for i in 0..pts.positions.len() {
            let [x, y, z] = pts.positions[i].map(f64::from);
            let lam = pts.level[i] as f64;
            let r2 = x * x + y * y;
            let peak = op * (-r2 / (2.0 * sig * sig)).exp();
            let want = s * (-2.0 * (lam / peak).ln()).sqrt();
            let h = z0 - z;
            assert!(
                (h - want).abs() < 0.05 * s,
                "{what} λ {lam} r² {r2:.3}: h {h} vs {want}"
            );
            let n = pts.normals[i].map(f64::from);
            let gr = [x / (sig * sig), y / (sig * sig), (z - z0) / (s * s)];
            let l = (gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]).sqrt();
            // (z − z0) < 0 on the camera side: +Σ⁻¹(x−μ) already faces −z
            let want = gr.map(|c| c / l);
            let dot = n[0] * want[0] + n[1] * want[1] + n[2] * want[2];
            assert!(dot > 1.0 - 1e-6, "{what}: normal {n:?} vs {want:?}");
            assert!(n[2] < -0.9);
        }
    }

    /// One flat Gaussian (in-plane σ 0.5, thickness s = 0.02, opacity 0.9)
    /// at z = 5 facing a camera at the origin: the diamond and median depths
    /// start their rays on the plane, and every point follows the closed
    /// form of [`assert_on_flat_gaussian`].
    #[test]
    fn one_flat_gaussian_matches_the_closed_form() {
        let g = flat_gaussian(5.0, 0.5, 0.02, 0.9);
        let cams = [camera_at_origin(64, 64.0)];
        for depth in [DepthSource::Diamonds, DepthSource::Median] {
            let opts = LevelsetOptions {
                levels: vec![0.3, 0.5],
                max_points: 400,
                depth,
                ..Default::default()
            };
            let pts = sample_levelset(&g, &cams, &opts, |_| ()).unwrap();
            assert!(
                pts.positions.len() > 300,
                "{depth:?}: {}",
                pts.positions.len()
            );
            assert_on_flat_gaussian(&pts, 5.0, 0.5, 0.02, 0.9, &format!("{depth:?}"));
        }
    }

    /// The rendered alpha of [`flat_gaussian`] at pixel (x, y) of
    /// [`camera_at_origin`]`(w, f)`, in closed form: on the axis the EWA
    /// Jacobian is diag(f/z0) (its depth column vanishes), so the screen
    /// covariance is ((f/z0)²σ² + 0.3)·I and α = min(0.99, op·e^{−r²/(2·that)})
    /// with r the pixel centre's distance to the principal point.
    fn flat_alpha(x: usize, y: usize, w: u32, f: f64, z0: f64, sig: f64, op: f64) -> f64 {
        let var = (f / z0 * sig).powi(2) + 0.3;
        let c = w as f64 / 2.0;
        let r2 = (x as f64 + 0.5 - c).powi(2) + (y as f64 + 0.5 - c).powi(2);
        (op * (-0.5 * r2 / var).exp()).min(0.99)
    }

    /// SuGaR's Gaussian depth on one flat Gaussian at z = 5 (opacity 0.9):
    /// a single layer blends to z·α + (1 − α)·(−1) = 6α − 1 with α in closed
    /// form ([`flat_alpha`]); within 15 px of the centre (well inside the
    /// rasteriser's 3σ box of 20 px) it matches to 1e-5 (f32 evaluation of
    /// the kernel: α to ~1e-7 relative, times 6); uncovered pixels are −1
    /// exactly; and the level-set buffer keeps exactly the pixels above 0
    /// (α > 1/6), with their hit left to the back-projected point.
    #[test]
    fn gaussian_depth_is_blended_z_over_minus_one() {
        let g = flat_gaussian(5.0, 0.5, 0.02, 0.9);
        let cam = camera_at_origin(64, 64.0);
        let s = RasterSettings::default();
        let img = gaussian::render(&g, &cam, &s);
        let d = gaussian_depth(&img);
        let mut checked = 0;
        for y in 0..64 {
            for x in 0..64 {
                let o = y * 64 + x;
                if img.alpha[o] == 0.0 {
                    assert_eq!(d[o], -1.0, "uncovered ({x},{y})");
                    continue;
                }
                let r2 = (x as f64 - 31.5).powi(2) + (y as f64 - 31.5).powi(2);
                if r2 < 15.0 * 15.0 {
                    let a = flat_alpha(x, y, 64, 64.0, 5.0, 0.5, 0.9);
                    let want = 6.0 * a - 1.0;
                    assert!(
                        (d[o] as f64 - want).abs() < 1e-5,
                        "({x},{y}): {} vs {want}",
                        d[o]
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 600, "{checked}");
        let opts = LevelsetOptions {
            depth: DepthSource::Gaussian,
            ..Default::default()
        };
        let centres = NnIndex::new(&[[0.0, 0.0, 5.0]]).unwrap();
        let hits = depth_and_hits(&g, &cam, &opts, &centres);
        for (o, h) in hits.iter().enumerate() {
            match h {
                Some((z, hit)) => {
                    assert_eq!((*z, *hit), (d[o], HIT_FROM_POINT));
                    assert!(*z > 0.0);
                }
                None => assert!(d[o] <= 0.0, "pixel {o}: {}", d[o]),
            }
        }
    }

    /// SuGaR's Gaussian-depth mode on one nearly opaque flat Gaussian
    /// (opacity 0.999, α capped at 0.99) at z0 = 2, thickness s = 0.05: the
    /// ray of a pixel starts at camera z D = 3α − 1, i.e. 3(1 − α) in front
    /// of the plane (the −1 background pulls it toward the camera), and its
    /// 21 samples span ±3s along the ray (σ along the view is s: the view
    /// from the centre is the z axis), i.e. camera z D ± 3s·c with c the z
    /// component of the ray direction. The ray finds the crossing at
    /// 2 − h(r) only if |D − (2 − h)| < 3s·c. So: every point follows the
    /// closed form of [`assert_on_flat_gaussian`], and the number of points
    /// per level lies between the pixels that satisfy that condition with a
    /// margin of one sample spacing (0.3 s) and those within it plus the
    /// margin (the margin absorbs the in-plane drift of r along the ray and
    /// where the interpolated crossing falls between samples).
    #[test]
    fn one_flat_gaussian_gaussian_depth() {
        let (z0, sig, s, op) = (2.0, 0.5, 0.05, 0.999);
        let g = flat_gaussian(z0 as f32, sig as f32, s as f32, op as f32);
        let (w, f) = (64u32, 64.0);
        let cams = [camera_at_origin(w, f)];
        let levels = [0.3f32, 0.5];
        let opts = LevelsetOptions {
            levels: levels.to_vec(),
            max_points: 100_000, // every covered pixel becomes a ray
            depth: DepthSource::Gaussian,
            ..Default::default()
        };
        let pts = sample_levelset(&g, &cams, &opts, |_| ()).unwrap();
        assert_on_flat_gaussian(&pts, z0, sig, s, op, "Gaussian");
        for lam in levels {
            let (mut sure, mut maybe) = (0, 0);
            for y in 0..w as usize {
                for x in 0..w as usize {
                    let a = flat_alpha(x, y, w, f, z0, sig, op);
                    let d = 3.0 * a - 1.0;
                    if d <= 0.0 {
                        continue;
                    }
                    let (u, v) = ((x as f64 + 0.5 - 32.0) / f, (y as f64 + 0.5 - 32.0) / f);
                    let c = 1.0 / (1.0 + u * u + v * v).sqrt();
                    let r2 = (u * u + v * v) * z0 * z0;
                    let peak = op * (-r2 / (2.0 * sig * sig)).exp();
                    if peak <= lam as f64 {
                        continue;
                    }
                    let h = s * (2.0 * (peak / lam as f64).ln()).sqrt();
                    let gap = (d - (z0 - h)).abs();
                    if gap < 3.0 * s * c - 0.3 * s {
                        sure += 1;
                    }
                    if gap < 3.0 * s * c + 0.3 * s {
                        maybe += 1;
                    }
                }
            }
            let got = pts.level.iter().filter(|&&l| l == lam).count();
            assert!(sure > 50, "λ {lam}: only {sure} pixels predicted");
            assert!(
                (sure..=maybe).contains(&got),
                "λ {lam}: {got} points, predicted {sure}..={maybe}"
            );
        }
    }

    /// The three depth sources on one flat Gaussian (opacity 0.9, z = 5,
    /// screen σ ≈ 6.4 px) at the centre pixel (α = 0.9) and at a
    /// translucent pixel 8.5 px off (α = 0.9·e^{−72.5/82.5} ≈ 0.37, inside
    /// the diamond's 2σ = 12.8 px reach): the diamond gives the plane's depth
    /// 5 at both; the median gives 5 at the centre and nothing at the
    /// translucent pixel (alpha below 0.5); SuGaR's Gaussian depth gives
    /// 6α − 1: 4.4 and ≈ 1.24. As a consequence the Gaussian-depth mode
    /// samples no point at all here (every ray starts ≥ 0.6 = 30 s in front
    /// of the plane, beyond its ±3 s window), while the other two do.
    #[test]
    fn depth_sources_differ_on_a_translucent_pixel() {
        let g = flat_gaussian(5.0, 0.5, 0.02, 0.9);
        let cam = camera_at_origin(64, 64.0);
        let centres = NnIndex::new(&[[0.0, 0.0, 5.0]]).unwrap();
        let buf = |depth| {
            let opts = LevelsetOptions {
                depth,
                ..Default::default()
            };
            depth_and_hits(&g, &cam, &opts, &centres)
        };
        let (dia, med, gau) = (
            buf(DepthSource::Diamonds),
            buf(DepthSource::Median),
            buf(DepthSource::Gaussian),
        );
        let (centre, side) = (32 * 64 + 32, 32 * 64 + 40);
        let a_side = flat_alpha(40, 32, 64, 64.0, 5.0, 0.5, 0.9);
        assert!((0.3..0.45).contains(&a_side), "{a_side}");
        for o in [centre, side] {
            let (z, hit) = dia[o].expect("diamond covers");
            assert!((z - 5.0).abs() < 1e-5 && hit == 0, "{z}");
        }
        assert_eq!(med[centre], Some((5.0, 0)));
        assert_eq!(med[side], None);
        let a_centre = flat_alpha(32, 32, 64, 64.0, 5.0, 0.5, 0.9);
        for (o, a) in [(centre, a_centre), (side, a_side)] {
            let (z, _) = gau[o].expect("above 0");
            assert!((z as f64 - (6.0 * a - 1.0)).abs() < 1e-5, "{z} vs α {a}");
        }
        let cams = [cam];
        let count = |depth| {
            let opts = LevelsetOptions {
                levels: vec![0.3, 0.5],
                max_points: 400,
                depth,
                ..Default::default()
            };
            sample_levelset(&g, &cams, &opts, |_| ())
                .unwrap()
                .positions
                .len()
        };
        assert_eq!(count(DepthSource::Gaussian), 0);
        assert!(count(DepthSource::Median) > 300);
    }

    /// Flat Gaussians tiling the unit sphere (3000, in-plane σ 0.04, thickness
    /// 0.004, opacity 0.95), seen by 6 orbit cameras. Every point lies within
    /// 0.02 of the sphere (level offset s·√(−2 ln 0.3) ≈ 0.006 plus the
    /// sagitta of flat discs, ≤ 0.005 at 2σ), and every normal points outward
    /// (toward the camera that saw it), 99% within 20° of the radial
    /// direction; for the diamond and the Gaussian depths.
    #[test]
    fn sphere_of_flat_gaussians() {
        let n = 3000;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let mut g = Gaussians3 {
            sh_degree: 0,
            ..Default::default()
        };
        for i in 0..n {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let t = golden * i as f64;
            let nrm = [r * t.cos(), r * t.sin(), z];
            g.means.push(nrm.map(|v| v as f32));
            let q = if nrm[2] > -0.999 {
                [1.0 + nrm[2], -nrm[1], nrm[0], 0.0]
            } else {
                [0.0, 1.0, 0.0, 0.0]
            };
            g.rotations.push(q.map(|v| v as f32));
            g.scales.push([0.04, 0.04, 0.004]);
            g.opacities.push(0.95);
            g.sh.push([0.5, 0.2, 0.1]);
        }
        let cams = crate::geom::scenes::orbit::orbit_cameras(
            &g.means,
            &crate::geom::scenes::orbit::OrbitRing {
                views: 6,
                width: 128,
                height: 128,
                fov_deg: 50.0,
                elevation_deg: 20.0,
                radius: Some(4.0),
                up: glam::DVec3::Z,
            },
        )
        .unwrap();
        let on_sphere = |pts: &LevelPoints, what: &str| {
            let mut off = 0;
            for (p, nv) in pts.positions.iter().zip(&pts.normals) {
                let p = p.map(f64::from);
                let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                assert!((l - 1.0).abs() < 0.02, "{what}: radius {l}");
                let cos = (nv[0] as f64 * p[0] + nv[1] as f64 * p[1] + nv[2] as f64 * p[2]) / l;
                assert!(cos > 0.0, "{what}: inward normal at {p:?}");
                if cos < 20f64.to_radians().cos() {
                    off += 1;
                }
            }
            assert!(
                off * 100 <= pts.positions.len(),
                "{what}: {off} normals beyond 20°"
            );
        };
        let opts = LevelsetOptions {
            max_points: 20_000,
            seed: 3,
            ..Default::default()
        };
        let pts = sample_levelset(&g, &cams, &opts, |_| ()).unwrap();
        assert!(pts.positions.len() > 10_000, "{}", pts.positions.len());
        on_sphere(&pts, "diamonds");
        // SuGaR's Gaussian depth, same bounds: the depth only places the
        // ray's window, the points are still density crossings (on these
        // overlapping, nearly opaque discs the views fill their caps too)
        let gau = LevelsetOptions {
            depth: DepthSource::Gaussian,
            ..opts.clone()
        };
        let gpts = sample_levelset(&g, &cams, &gau, |_| ()).unwrap();
        assert!(gpts.positions.len() > 10_000, "{}", gpts.positions.len());
        on_sphere(&gpts, "gaussian");
        // deterministic for a seed, whatever the thread count
        let again = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| sample_levelset(&g, &cams, &opts, |_| ()).unwrap());
        assert_eq!(again.positions, pts.positions);
    }

    /// A plane z = 5 tiled with overlapping flat Gaussians (spacing 0.1,
    /// in-plane σ 0.06, thickness s = 0.01) in front of a camera at the
    /// origin. Where the tiles overlap, the in-plane sum D lies between 1 and
    /// ~3.5, so the crossing sits at h = s·√(2 ln(D/λ)) ∈ [1.55 s, 2.5 s]
    /// in front of the plane; every point lies in that slab and every normal
    /// is −z within 2°.
    #[test]
    fn plane_of_flat_gaussians() {
        let mut g = Gaussians3 {
            sh_degree: 0,
            ..Default::default()
        };
        for j in -30..=30 {
            for i in -30..=30 {
                g.means.push([i as f32 * 0.1, j as f32 * 0.1, 5.0]);
                g.scales.push([0.06, 0.06, 0.01]);
                g.rotations.push([1.0, 0.0, 0.0, 0.0]);
                g.opacities.push(0.95);
                g.sh.push([0.0; 3]);
            }
        }
        let cams = [camera_at_origin(96, 100.0)];
        let opts = LevelsetOptions {
            max_points: 3000,
            ..Default::default()
        };
        let pts = sample_levelset(&g, &cams, &opts, |_| ()).unwrap();
        assert!(pts.positions.len() > 2500, "{}", pts.positions.len());
        for (p, n) in pts.positions.iter().zip(&pts.normals) {
            let h = 5.0 - p[2] as f64;
            assert!((0.0155..0.025).contains(&h), "h {h} at {p:?}");
            assert!(n[2] < -(2f32.to_radians().cos()), "normal {n:?}");
        }
    }
}
