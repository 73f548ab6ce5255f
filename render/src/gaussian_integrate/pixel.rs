//! The pixel pass of GOF's `integrateCUDA` (five rays per pixel, the
//! contributor list) for the pixels of one tile that hold points.
//!
//! A ray's α for a Gaussian does not depend on the pixel's state, and the
//! corner rays of neighbouring pixels are the same rays (the corner at
//! i + 0.5 + 0.5 of pixel i and at (i + 1) + 0.5 − 0.5 of pixel i + 1 are
//! the same f32), so [`tile_pass`] evaluates each Gaussian once per ray
//! point of the tile's (17 × 17 corners, 16 × 16 centres) grid that an
//! occupied pixel uses, and each pixel then applies its own transmittance
//! tests in list order: the same operations as the per-pixel kernel.

use super::view::ViewGaussian;
use super::{MAX_CONTRIBUTORS, Pass, PreparedView, RAY_NEAR, quadratic};
use crate::tiles::TILE;

/// The state-independent part of one ray's step: α of Gaussian `g` on ray
/// `r`, or `None` where the kernel skips it (t ≤ 0.2, a NaN t, α < 1/255).
#[inline]
pub(super) fn ray_alpha(g: &ViewGaussian, r: [f32; 2]) -> Option<f32> {
    let v = &g.v2g;
    let (aa, bb) = quadratic(v, r);
    let t = -bb / (2.0 * aa);
    if (t as f64) <= RAY_NEAR || t.is_nan() {
        return None;
    }
    let min_value = -((bb / aa) as f64) * (bb as f64 / 4.0) + v[9] as f64;
    let power = ((-0.5 * min_value) as f32).min(0.0);
    // (f32::min never returns NaN, as CUDA's fminf)
    let alpha = (g.opacity * power.exp()).min(0.99);
    (alpha >= 1.0 / 255.0).then_some(alpha)
}

/// One pixel's running state in the pixel pass.
#[derive(Clone)]
pub(super) struct PixelState {
    ts: [f32; 5],
    c: [f32; 3],
    contributor: u32,
    last: u32,
    /// Contributors' list positions as the kernel stores them (u16).
    ids: Vec<u16>,
    done: bool,
}

impl PixelState {
    pub(super) fn new() -> Self {
        PixelState {
            ts: [1.0; 5],
            c: [0.0; 3],
            contributor: 0,
            last: 0,
            ids: Vec::new(),
            done: false,
        }
    }

    /// List entry `g` at 1-based list position `pos` (increasing from call
    /// to call; entries in between are ones all five rays skip) with its
    /// five rays' α (centre first); nothing once the pixel is done.
    #[inline]
    pub(super) fn step(&mut self, g: &ViewGaussian, pos: u32, alphas: [Option<f32>; 5]) {
        if self.done {
            return;
        }
        self.contributor = pos;
        let mut used = false;
        for (k, a) in alphas.iter().enumerate() {
            let Some(alpha) = *a else { continue };
            let test_t = self.ts[k] * (1.0 - alpha);
            if test_t < 1e-4 {
                continue;
            }
            if k == 0 {
                for (ch, cc) in self.c.iter_mut().enumerate() {
                    *cc += g.rgb[ch] * alpha * self.ts[0];
                }
            }
            self.ts[k] = test_t;
            used = true;
        }
        if used {
            self.last = self.contributor;
            // the kernel stores list positions as u16 (they wrap past 65535)
            self.ids.push(self.contributor as u16);
            if self.ids.len() >= MAX_CONTRIBUTORS {
                self.done = true;
            }
        }
    }

    /// The point pass's walk over `list` (list positions 1..=last equal to
    /// the next stored id, as u32, exactly as the kernel matches them) and
    /// the pixel's colour over `bg`; `gaussians` are the view's records the
    /// list indexes (for the walk's depth bounds).
    pub(super) fn finish(&self, list: &[u32], bg: [f32; 3], gaussians: &[ViewGaussian]) -> Pass {
        let mut walk = Vec::with_capacity(self.ids.len());
        let mut next = 0usize;
        for (pos, &gi) in list.iter().enumerate() {
            let n = pos as u32 + 1;
            if n > self.last {
                break;
            }
            if n != self.ids.get(next).copied().unwrap_or(0) as u32 {
                continue;
            }
            next += 1;
            walk.push(gi);
        }
        let rgb = std::array::from_fn(|ch| self.c[ch] + self.ts[0] * bg[ch]);
        let mut tail_near = vec![f32::INFINITY; walk.len()];
        let mut m = f32::INFINITY;
        for (t, &gi) in tail_near.iter_mut().zip(&walk).rev() {
            m = m.min(gaussians[gi as usize].near);
            *t = m;
        }
        Pass {
            walk,
            tail_near,
            rgb,
        }
    }
}

/// A grid point of a tile: its pixel position (u, v) and its ray.
type GridPoint = (f32, f32, [f32; 2]);

/// Whether pixel position (u, v) lies off Gaussian `g`'s reach box.
#[inline]
fn off_box(b: &[f32; 4], u: f32, v: f32) -> bool {
    u < b[0] || u > b[2] || v < b[1] || v > b[3]
}

/// The pixel pass of the occupied pixels `pixels` (local (x, y) in tile
/// `tile`, any order): per pixel, its walk and colour.
pub(super) fn tile_pass(view: &PreparedView, tile: usize, pixels: &[(usize, usize)]) -> Vec<Pass> {
    const G: usize = TILE + 1;
    let list = view.binned.lists.list(tile);
    let (x0, y0) = ((tile % view.tiles_x) * TILE, (tile / view.tiles_x) * TILE);
    // the grid points the occupied pixels use
    let mut need_corner = [false; G * G];
    let mut need_centre = [false; TILE * TILE];
    for &(lx, ly) in pixels {
        need_centre[ly * TILE + lx] = true;
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            need_corner[(ly + dy) * G + lx + dx] = true;
        }
    }
    // (position u, v, ray) of each needed grid point
    let point = |u: f32, v: f32| (u, v, view.ray(u, v));
    let corners: Vec<(usize, GridPoint)> = (0..G * G)
        .filter(|&q| need_corner[q])
        .map(|q| (q, point((x0 + q % G) as f32, (y0 + q / G) as f32)))
        .collect();
    let centres: Vec<(usize, GridPoint)> = (0..TILE * TILE)
        .filter(|&q| need_centre[q])
        .map(|q| {
            (
                q,
                point((x0 + q % TILE) as f32 + 0.5, (y0 + q / TILE) as f32 + 0.5),
            )
        })
        .collect();
    let mut alpha_corner = [None; G * G];
    let mut alpha_centre = [None; TILE * TILE];
    let mut states = vec![PixelState::new(); pixels.len()];
    // the span of the tile's grid points: a Gaussian whose reach box misses
    // it is off the box at every grid point
    let span = [x0 as f32, y0 as f32, (x0 + TILE) as f32, (y0 + TILE) as f32];
    for (n, &gi) in list.iter().enumerate() {
        let g = &view.binned.gaussians[gi as usize];
        let b = &g.reach;
        if view.use_reach && (b[2] < span[0] || b[0] > span[2] || b[3] < span[1] || b[1] > span[3])
        {
            continue;
        }
        let mut any = false;
        for &(q, (u, v, r)) in &corners {
            let a = if view.use_reach && off_box(b, u, v) {
                None
            } else {
                ray_alpha(g, r)
            };
            alpha_corner[q] = a;
            any |= a.is_some();
        }
        for &(q, (u, v, r)) in &centres {
            let a = if view.use_reach && off_box(b, u, v) {
                None
            } else {
                ray_alpha(g, r)
            };
            alpha_centre[q] = a;
            any |= a.is_some();
        }
        if !any {
            continue;
        }
        let mut all_done = true;
        for (s, &(lx, ly)) in states.iter_mut().zip(pixels) {
            let c = |dx: usize, dy: usize| alpha_corner[(ly + dy) * G + lx + dx];
            s.step(
                g,
                n as u32 + 1,
                [
                    alpha_centre[ly * TILE + lx],
                    c(0, 0),
                    c(1, 0),
                    c(0, 1),
                    c(1, 1),
                ],
            );
            all_done &= s.done;
        }
        if all_done {
            break;
        }
    }
    states
        .iter()
        .map(|s| s.finish(list, view.background, &view.binned.gaussians))
        .collect()
}
