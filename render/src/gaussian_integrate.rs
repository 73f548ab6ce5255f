//! Gaussian Opacity Fields' opacity of 3-D points: the `integrate` pass of
//! GOF's rasteriser (`integrateCUDA` in its `forward.cu`) on the CPU, and the
//! combination over views of its `extract_mesh.py` (`evaluage_alpha`).
//!
//! Inputs: [`Gaussians3`] with activated values (σ scales, opacities in
//! [0, 1], quaternions (w, x, y, z), normalised here as GOF's `get_rotation`),
//! taken to be the 3-D-filtered values GOF passes
//! (`get_scaling_with_3D_filter`, `get_opacity_with_3D_filter`); pinhole
//! [`Camera`]s (OpenCV axes, pixel centres at integer + 0.5); world points.
//!
//! Per view, the rules of GOF's kernels (line numbers: `forward.cu`,
//! `auxiliary.h`, `rasterizer_impl.cu` of its `diff-gaussian-rasterization`):
//! - Gaussians (`preprocessCUDA`, 284–404): culled at view z ≤ 0.2
//!   (`in_frustum`, `auxiliary.h` 192); 2-D covariance by EWA with the
//!   1.3·tan(fov/2) clamp, the 2-D Mip filter `kernel_size` k (GOF's default
//!   0) and its opacity coef (`computeCov2D`, 74–124); dropped when det = 0;
//!   radius ⌈3·√λ_max⌉ with λ from max(0.1, mid² − det); tiles by `getRect`
//!   on the `ndc2Pix` centre (pixel centres at integers); colour from SH at
//!   the camera centre, + 0.5, clamped at 0; the ten `computeView2Gaussian`
//!   values (168–279); `getRect` and `ndc2Pix`: `auxiliary.h` 59–75. Tile
//!   lists sorted by (depth, index) (stable radix sort of `tile | depth`
//!   keys, `duplicateWithKeys`).
//! - Points (`preprocessPointsCUDA`, 723–766, pixel coordinates 756): culled
//!   at view z ≤ 0.2; pixel coordinates x = fx·X/(Z + 1e-7) + W/2 (no −0.5),
//!   dropped unless 0 ≤ x < W and 0 ≤ y < H; binned to tile ⌊x/16⌋
//!   (`createWithKeys`, `rasterizer_impl.cu` 135) and taken by the pixel
//!   whose [i, i + 1) × [j, j + 1) holds them (the half-open test against
//!   `pixf ± 0.5`, 1071–1072): pixel (⌊x⌋, ⌊y⌋).
//! - Pixel pass (838–993, rays 919–980, contributor list 983–990): five rays
//!   through (i + 0.5 + dx, j + 0.5 + dy), (dx, dy) ∈ {(0, 0), (±0.5, ±0.5)},
//!   direction ((u − W/2)/fx, (v − H/2)/fy, 1); per Gaussian in list order
//!   and per ray: t = −B/(2A) skipped if ≤ 0.2; power = −½(C − B²/(4A))
//!   capped at 0; α = min(0.99, o·exp(power)), skipped below 1/255; skipped
//!   if T·(1 − α) < 1e-4 (no early exit); otherwise T ← T(1 − α) for that
//!   ray. A Gaussian any ray used is a contributor; at 4·256 contributors the
//!   pixel stops. The pixel's colour is Σ c α T of the centre ray +
//!   T·background.
//! - Point pass (1130–1196, t clamp 1172–1175, output 1205): each point of
//!   the pixel walks the pixel's contributors (`contributed_ids`, kept as u16
//!   list positions as the kernel does) with its own ray through its (x, y),
//!   t = −B/(2A) clamped at the point's view depth, power = −½(A t² + B t +
//!   C) (no cap), α as above, skipped below 1/255 (no T test):
//!   alpha_integrated = Σ α T. The point's colour is the pixel's colour.
//! - Points no pixel takes keep the output's initial value
//!   (`IntegrateGaussiansToPointsCUDA` in `rasterize_points.cu`:
//!   alpha_integrated 1, colour 0).
//!
//! Departures, each documented where it happens:
//! - the principal point is the camera's (cx, cy) wherever GOF uses (W/2,
//!   H/2) (rays, point pixels, `ndc2Pix`); GOF's cameras always have it at
//!   the centre, where the two agree;
//! - the per-Gaussian preprocessing is evaluated in f64 and rounded to f32
//!   (GOF: f32 with a few f64 steps), so ties at tile or pixel boundaries can
//!   fall differently by one rounding; the per-ray and per-point arithmetic
//!   follows the kernel's f32 / f64 operations;
//! - non-finite Gaussian depths, determinants or radii, and points with a
//!   non-finite pixel or depth, are dropped (the kernel's result there is
//!   undefined), and a NaN ray parameter t skips the ray in the pixel pass
//!   (the kernel would blend α = 0.99 there, as `fminf` drops the NaN);
//! - the kernel's `MAX_NUM_PROJECTED` chunking of a pixel's points changes no
//!   value and is not reproduced.
//!
//! Speed-ups that change no value (tests `reach_skip_is_exact` and
//! `tile_pass_matches_pixel_pass` check bit-equal results on random scenes):
//! - a ray whose pixel position lies off the box of a Gaussian's α ≥ 1/255
//!   region (the image of its ellipsoid at that level, widened for f32
//!   rounding and by a pixel) is not evaluated for it: the kernel would skip
//!   it (the Gaussian still counts as a list position);
//! - the pixel pass runs per tile, evaluating each ray point of the tile
//!   (corners shared by neighbouring pixels) once per Gaussian, each pixel
//!   then applying its own transmittance tests in list order (`pixel`).
//!
//! Parallel over the pixels that hold points; each point's value is computed
//! by one sequential loop, so results do not depend on the thread count.
//!
//! Pixel passes are kept between [`PreparedView::integrate`] calls, within
//! [`IntegrateSettings::cache_bytes`]: a pixel's pass depends on the view
//! alone, so the binary search's later evaluations reuse the passes of the
//! pixels their points fall in (GOF's kernel recomputes them every call;
//! the results are the same bit for bit, tested).

mod pixel;
mod view;

use rayon::prelude::*;

use crate::Camera;
use crate::gaussian::{Gaussians3, rotation_rows};
use crate::tiles::TILE;
pub use view::CULL_NEAR;
use view::{Binned, ViewGaussian, bin};

/// The contributor cap of a pixel: `MAX_NUM_CONTRIBUTORS * 4` (1024).
pub const MAX_CONTRIBUTORS: usize = 256 * 4;

/// GOF's `NEAR_PLANE` (`auxiliary.h`): a ray's closest approach to a
/// Gaussian at t ≤ this is skipped in the pixel pass.
pub const RAY_NEAR: f64 = 0.2;

/// Sub-pixel offsets of the five pixel-pass rays (centre, then corners).
#[cfg(test)]
const OFFSETS: [(f32, f32); 5] = [
    (0.0, 0.0),
    (-0.5, -0.5),
    (0.5, -0.5),
    (-0.5, 0.5),
    (0.5, 0.5),
];

/// Settings of GOF's integration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegrateSettings {
    /// Background colour added to a pixel's colour (`bg_color`: GOF uses
    /// white with `--white_background`, else black).
    pub background: [f32; 3],
    /// The 2-D Mip filter's `kernel_size`, pixels² (GOF's default 0).
    pub kernel_size: f32,
    /// Bytes a [`PreparedView`] may keep of pixel passes between
    /// [`PreparedView::integrate`] calls (a pixel's pass depends on the view
    /// only, so later calls on points in the same pixels reuse it; results
    /// are the same bit for bit). 0 keeps none.
    pub cache_bytes: usize,
}

impl Default for IntegrateSettings {
    fn default() -> Self {
        IntegrateSettings {
            background: [0.0; 3],
            kernel_size: 0.0,
            cache_bytes: 64 << 20,
        }
    }
}

/// A pixel's pass: the Gaussians its points walk, and its colour.
#[derive(Debug, PartialEq)]
struct Pass {
    /// The contributors (indices into the view's kept Gaussians), in list
    /// order.
    walk: Vec<u32>,
    /// Per walk position k, the smallest [`ViewGaussian::near`] of the walk
    /// from k on: a point shallower than it gets nothing more from the walk.
    tail_near: Vec<f32>,
    /// The pixel's colour over the background.
    rgb: [f32; 3],
}

/// The pixel passes a view keeps (by pixel id), within a byte limit.
#[derive(Default)]
struct PassCache {
    passes: std::sync::Mutex<std::collections::HashMap<u32, std::sync::Arc<Pass>>>,
    bytes: std::sync::atomic::AtomicUsize,
    limit: usize,
}

/// Per point, what one view's integration gives.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Integrated {
    /// GOF's `alpha_integrated`: the opacity accumulated along the point's
    /// ray up to the point; 1 for points no pixel takes.
    pub alpha: Vec<f32>,
    /// GOF's `color_integrated`: the colour of the pixel that took the
    /// point (linear RGB); 0 for points no pixel takes.
    pub rgb: Vec<[f32; 3]>,
}

/// One view prepared for integration: the Gaussians preprocessed and binned
/// once, reused by every [`PreparedView::integrate`] call.
pub struct PreparedView {
    w: usize,
    h: usize,
    tiles_x: usize,
    /// Focal lengths as the kernel holds them (f32).
    fx: f32,
    fy: f32,
    cx: f64,
    cy: f64,
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
    background: [f32; 3],
    binned: Binned,
    /// Skip Gaussians whose reach box misses the pixel (same results; off
    /// only in the test that checks this).
    use_reach: bool,
    /// Pixel passes kept between calls.
    cache: PassCache,
}

/// One point's place in a view: pixel id, pixel coordinates, view depth.
type Located = (u32, f32, f32, f32);

impl PreparedView {
    /// Preprocesses and bins `g` for `cam` (see the module doc).
    ///
    /// Panics if `g`'s arrays disagree in length (a caller's bug).
    pub fn new(g: &Gaussians3, cam: &Camera, s: &IntegrateSettings) -> Self {
        let binned = bin(g, cam, s.kernel_size as f64);
        PreparedView {
            w: cam.width as usize,
            h: cam.height as usize,
            tiles_x: (cam.width as usize).div_ceil(TILE),
            fx: cam.fx as f32,
            fy: cam.fy as f32,
            cx: cam.cx,
            cy: cam.cy,
            rotation: rotation_rows(cam),
            translation: cam.translation.to_array(),
            background: s.background,
            binned,
            use_reach: true,
            cache: PassCache {
                limit: s.cache_bytes,
                ..Default::default()
            },
        }
    }

    /// Number of Gaussians kept in this view.
    pub fn kept(&self) -> usize {
        self.binned.gaussians.len()
    }

    /// Approximate heap bytes held (for a caller's memory budget).
    pub fn heap_bytes(&self) -> usize {
        let lists = &self.binned.lists;
        let entries: usize = (0..lists.len()).map(|t| lists.list(t).len()).sum();
        // per kept Gaussian: its record and the binning's rectangle and start;
        // per list entry: the entry and its position
        self.binned.gaussians.len() * (std::mem::size_of::<ViewGaussian>() + 24)
            + entries * 8
            + lists.len() * 8
    }

    /// Where `p` lands: `preprocessPointsCUDA` (z ≤ 0.2 and points outside
    /// [0, W) × [0, H) are dropped), then the half-open pixel test.
    fn locate(&self, p: [f32; 3]) -> Option<Located> {
        let pw = p.map(f64::from);
        let c: [f32; 3] = std::array::from_fn(|i| {
            let r = self.rotation[i];
            (r[0] * pw[0] + r[1] * pw[1] + r[2] * pw[2] + self.translation[i]) as f32
        });
        if !c[2].is_finite() || c[2] <= CULL_NEAR {
            return None;
        }
        // f32 projection, then + the principal point in f64 (GOF: + W/2.)
        let x = ((self.fx * c[0] / (c[2] + 1e-7)) as f64 + self.cx) as f32;
        let y = ((self.fy * c[1] / (c[2] + 1e-7)) as f64 + self.cy) as f32;
        if !(x >= 0.0 && x < self.w as f32 && y >= 0.0 && y < self.h as f32) {
            return None;
        }
        // the pixel whose [i, i + 1) holds x; guard x = W − ε rounding to W
        let (i, j) = ((x as usize).min(self.w - 1), (y as usize).min(self.h - 1));
        Some(((j * self.w + i) as u32, x, y, c[2]))
    }

    /// The passes of `pixels` (local (x, y) in `tile`): those kept from
    /// earlier calls, the others computed by [`pixel::tile_pass`] (whose
    /// per-pixel results do not depend on which pixels it is given) and kept
    /// while the cache is under its limit.
    fn cached_passes(&self, tile: usize, pixels: &[(usize, usize)]) -> Vec<std::sync::Arc<Pass>> {
        use std::sync::atomic::Ordering;
        let (x0, y0) = ((tile % self.tiles_x) * TILE, (tile / self.tiles_x) * TILE);
        let id = |&(lx, ly): &(usize, usize)| ((y0 + ly) * self.w + x0 + lx) as u32;
        let mut found: Vec<Option<std::sync::Arc<Pass>>> = if self.cache.limit > 0 {
            let c = self.cache.passes.lock().expect("cache lock");
            pixels.iter().map(|p| c.get(&id(p)).cloned()).collect()
        } else {
            vec![None; pixels.len()]
        };
        let missing: Vec<(usize, usize)> = pixels
            .iter()
            .zip(&found)
            .filter(|(_, f)| f.is_none())
            .map(|(p, _)| *p)
            .collect();
        if missing.is_empty() {
            return found.into_iter().map(|f| f.expect("found")).collect();
        }
        let fresh: Vec<std::sync::Arc<Pass>> = pixel::tile_pass(self, tile, &missing)
            .into_iter()
            .map(std::sync::Arc::new)
            .collect();
        if self.cache.limit > 0 {
            let add: usize = fresh.iter().map(|p| p.walk.len() * 8 + 80).sum();
            if self.cache.bytes.fetch_add(add, Ordering::Relaxed) + add <= self.cache.limit {
                let mut c = self.cache.passes.lock().expect("cache lock");
                for (p, f) in missing.iter().zip(&fresh) {
                    c.insert(id(p), f.clone());
                }
            } else {
                self.cache.bytes.fetch_sub(add, Ordering::Relaxed);
            }
        }
        let mut fresh = fresh.into_iter();
        for f in found.iter_mut() {
            if f.is_none() {
                *f = fresh.next();
            }
        }
        found.into_iter().map(|f| f.expect("computed")).collect()
    }

    /// The camera-space ray direction (x, y, 1) through pixel coordinates
    /// (u, v): ((u − cx)/fx, (v − cy)/fy) in f64, stored as f32.
    #[inline]
    fn ray(&self, u: f32, v: f32) -> [f32; 2] {
        [
            ((u as f64 - self.cx) / self.fx as f64) as f32,
            ((v as f64 - self.cy) / self.fy as f64) as f32,
        ]
    }

    /// The pixel pass of pixel (i, j) alone: the Gaussians (indices into the
    /// kept list) the point pass walks, in order, and the pixel's colour
    /// (the reference [`pixel::tile_pass`] is tested against).
    #[cfg(test)]
    fn pixel_pass(&self, i: usize, j: usize) -> Pass {
        let tile = (j / TILE) * self.tiles_x + i / TILE;
        let list = self.binned.lists.list(tile);
        let (pxf, pyf) = (i as f32 + 0.5, j as f32 + 0.5);
        let rays: [[f32; 2]; 5] = OFFSETS.map(|(dx, dy)| self.ray(pxf + dx, pyf + dy));
        let mut s = pixel::PixelState::new();
        for (n, &gi) in list.iter().enumerate() {
            let g = &self.binned.gaussians[gi as usize];
            s.step(g, n as u32 + 1, rays.map(|r| pixel::ray_alpha(g, r)));
        }
        s.finish(list, self.background, &self.binned.gaussians)
    }

    /// The point pass: alpha_integrated of a point at pixel coordinates
    /// (x, y) and view depth `depth` over the pixel's walk.
    ///
    /// Two exits and a skip give the kernel's value bit for bit with less work (off
    /// with `use_reach = false`, as the test that checks them sets it):
    /// - the walk ends where every remaining Gaussian's ellipsoid lies behind
    ///   the point (`depth < tail_near`): each would have α < 1/255 and be
    ///   skipped;
    /// - it ends once the transmittance is below 2⁻²⁶ with acc ≥ 0.5: every
    ///   later term α·T (α ≤ 0.99, T never grows) is then below half an ulp
    ///   of acc (≥ 2⁻²⁵), so adding it rounds back to acc;
    /// - an exponent below [`ViewGaussian::skip_below`] is skipped without
    ///   evaluating the exponential.
    fn point_alpha(&self, pass: &Pass, x: f32, y: f32, depth: f32) -> f32 {
        const TINY: f32 = 1.0 / (1u64 << 26) as f32;
        let r = self.ray(x, y);
        let mut acc = 0.0f32;
        let mut tr = 1.0f32;
        for (&gi, &tail_near) in pass.walk.iter().zip(&pass.tail_near) {
            let g = &self.binned.gaussians[gi as usize];
            if self.use_reach {
                if depth < tail_near {
                    break;
                }
                if depth < g.near {
                    continue;
                }
            }
            let v = &g.v2g;
            let (aa, bb) = quadratic(v, r);
            let mut t = -bb / (2.0 * aa);
            if t > depth {
                t = depth;
            }
            let power = -0.5f32 * (aa * t * t + bb * t + v[9]);
            if self.use_reach && power < g.skip_below {
                continue;
            }
            let alpha = (g.opacity * power.exp()).min(0.99);
            if alpha < 1.0 / 255.0 {
                continue;
            }
            acc += alpha * tr;
            tr *= 1.0 - alpha;
            if self.use_reach && tr < TINY && acc >= 0.5 {
                break;
            }
        }
        acc
    }

    /// GOF's `integrate` of `points` in this view: per point its
    /// `alpha_integrated` and `color_integrated` (see [`Integrated`]).
    ///
    /// Panics if there are 2³² points or more.
    pub fn integrate(&self, points: &[[f32; 3]]) -> Integrated {
        assert!(points.len() < (1usize << 32), "fewer than 2^32 points");
        let mut out = Integrated {
            alpha: vec![1.0; points.len()],
            rgb: vec![[0.0; 3]; points.len()],
        };
        if self.w == 0 || self.h == 0 {
            return out;
        }
        let located: Vec<Option<Located>> = points.par_iter().map(|&p| self.locate(p)).collect();
        // points grouped by tile, then pixel in the tile, then index
        let key = |pix: u32| {
            let (i, j) = (pix as usize % self.w, pix as usize / self.w);
            let tile = (j / TILE) * self.tiles_x + i / TILE;
            (tile * TILE * TILE + (j % TILE) * TILE + i % TILE) as u64
        };
        let mut keys: Vec<(u64, u32)> = located
            .iter()
            .enumerate()
            .filter_map(|(i, l)| l.map(|l| (key(l.0), i as u32)))
            .collect();
        keys.par_sort_unstable();
        let tile_of = |k: u64| k as usize / (TILE * TILE);
        let mut runs: Vec<(usize, usize)> = Vec::new();
        let mut start = 0;
        for k in 1..=keys.len() {
            if k == keys.len() || tile_of(keys[k].0) != tile_of(keys[start].0) {
                runs.push((start, k));
                start = k;
            }
        }
        let results: Vec<Vec<(u32, f32, [f32; 3])>> = runs
            .par_iter()
            .map(|&(a, b)| {
                let run = &keys[a..b];
                // the occupied pixels, and where each one's points start
                let mut pixels = Vec::new();
                let mut first = Vec::new();
                for (n, &(k, _)) in run.iter().enumerate() {
                    if n == 0 || run[n - 1].0 != k {
                        let local = k as usize % (TILE * TILE);
                        pixels.push((local % TILE, local / TILE));
                        first.push(n);
                    }
                }
                first.push(run.len());
                let tile = tile_of(run[0].0);
                let passes = self.cached_passes(tile, &pixels);
                let mut out = Vec::with_capacity(run.len());
                for (p, pass) in passes.iter().enumerate() {
                    for &(_, idx) in &run[first[p]..first[p + 1]] {
                        let (_, x, y, d) = located[idx as usize].expect("located");
                        out.push((idx, self.point_alpha(pass, x, y, d), pass.rgb));
                    }
                }
                out
            })
            .collect();
        for (idx, a, rgb) in results.into_iter().flatten() {
            out.alpha[idx as usize] = a;
            out.rgb[idx as usize] = rgb;
        }
        out
    }
}

/// A and B of the ray's quadratic A t² + B t + C for ray (x, y, 1), in the
/// kernel's f32 operation order.
#[inline]
fn quadratic(v: &[f32; 10], r: [f32; 2]) -> (f32, f32) {
    let n0 = v[0] * r[0] + v[1] * r[1] + v[2];
    let n1 = v[1] * r[0] + v[3] * r[1] + v[4];
    let n2 = v[2] * r[0] + v[4] * r[1] + v[5];
    let aa = r[0] * n0 + r[1] * n1 + n2;
    let bb = 2.0 * (v[6] * r[0] + v[7] * r[1] + v[8]);
    (aa, bb)
}

/// Folds one view's values into the running minimum as `evaluage_alpha`
/// does: the colour is taken where the view's alpha is strictly below the
/// running one, then the running alpha becomes the minimum (NaN spreads, as
/// `torch.min`).
fn fold_view(alpha: &mut [f32], rgb: &mut [[f32; 3]], view: &Integrated) {
    alpha
        .par_iter_mut()
        .zip(rgb.par_iter_mut())
        .zip(view.alpha.par_iter().zip(view.rgb.par_iter()))
        .for_each(|((fa, fc), (&a, &c))| {
            if a < *fa {
                *fc = c;
            }
            *fa = if a.is_nan() || fa.is_nan() {
                f32::NAN
            } else {
                fa.min(a)
            };
        });
}

/// GOF's opacity field over several views (`evaluage_alpha`), with every
/// view prepared once and reused by each [`OpacityField::evaluate`] call (the
/// marching-tetrahedra binary search evaluates new point sets nine times).
pub struct OpacityField {
    views: Vec<PreparedView>,
}

impl OpacityField {
    /// Prepares every camera's view of `g` (see [`PreparedView::new`]).
    pub fn new(g: &Gaussians3, cams: &[Camera], s: &IntegrateSettings) -> Self {
        OpacityField {
            views: cams.iter().map(|c| PreparedView::new(g, c, s)).collect(),
        }
    }

    /// The prepared views, in camera order.
    pub fn views(&self) -> &[PreparedView] {
        &self.views
    }

    /// Approximate heap bytes held by all views.
    pub fn heap_bytes(&self) -> usize {
        self.views.iter().map(PreparedView::heap_bytes).sum()
    }

    /// Per point: alpha = 1 − min(1, min over views of alpha_integrated),
    /// and the colour of the first view with the smallest alpha_integrated
    /// (1, 1, 1 where no view's is below 1). GOF takes sdf = alpha − 0.5.
    pub fn evaluate(&self, points: &[[f32; 3]]) -> (Vec<f32>, Vec<[f32; 3]>) {
        let mut alpha = vec![1.0f32; points.len()];
        let mut rgb = vec![[1.0f32; 3]; points.len()];
        for v in &self.views {
            fold_view(&mut alpha, &mut rgb, &v.integrate(points));
        }
        alpha.par_iter_mut().for_each(|a| *a = 1.0 - *a);
        (alpha, rgb)
    }
}

/// [`OpacityField::evaluate`] without keeping the views: each camera's view
/// is prepared, used and dropped in turn (memory for one view at a time).
pub fn opacity_field(
    g: &Gaussians3,
    cams: &[Camera],
    points: &[[f32; 3]],
    s: &IntegrateSettings,
) -> (Vec<f32>, Vec<[f32; 3]>) {
    let mut alpha = vec![1.0f32; points.len()];
    let mut rgb = vec![[1.0f32; 3]; points.len()];
    for cam in cams {
        let v = PreparedView::new(g, cam, s);
        fold_view(&mut alpha, &mut rgb, &v.integrate(points));
    }
    alpha.par_iter_mut().for_each(|a| *a = 1.0 - *a);
    (alpha, rgb)
}

#[cfg(test)]
mod tests;
