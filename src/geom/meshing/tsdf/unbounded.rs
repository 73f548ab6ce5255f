//! 2DGS's unbounded TSDF (`extract_mesh_unbounded`, `fuse_unbounded.ply`) for
//! scenes that reach far from the cameras: the TSDF is sampled on a uniform
//! grid in *contracted* space and meshed there.
//!
//! Conventions (2DGS `utils/mesh_utils.py`, `utils/mcube_utils.py`):
//! - normalise x ↦ (x − centre)/radius (the cameras' focus point and radius,
//!   [`super::camera_sphere`]); contract(x) = x for ‖x‖ < 1, else
//!   (2 − 1/‖x‖)·x/‖x‖; uncontract(y) = y for ‖y‖ < 1, else
//!   y/(‖y‖(2 − ‖y‖)) (as written: samples with ‖y‖ > 2, in the corners of
//!   the box, map to mirrored world points, as in 2DGS);
//! - the grid spans [−R, R]³ in contracted space with R = min(q95 of
//!   ‖contract(normalise(p))‖ over the scene's points + 0.01, 1.9); for a
//!   resolution N that is a multiple of 512 it is (N/512)³ blocks of
//!   `linspace(min, max, 512)` sharing their faces, i.e. M = (N/512)·511 + 1
//!   samples per axis (other N: one block, M = N);
//! - voxel = 2·radius/N (world units); the truncation of a sample s is
//!   5·voxel, divided by 2 − min(‖s‖, 1.9) when ‖s‖ > 1;
//! - each sample starts at tsdf −1 with weight 1 (2DGS `1920a23`); per view,
//!   its world point is projected (z = view z, NDC of the pinhole; kept when
//!   −1 < NDC < 1 on both axes and z > 0), depth is sampled bilinearly with
//!   pixel = (NDC + 1)/2·(W − 1) (`grid_sample`, `align_corners=True`,
//!   border padding), sdf = depth − z (no ray factor, no mask), and when
//!   sdf > −trunc the sample's running mean takes clamp(sdf/trunc, −1, 1);
//! - marching cubes at level 0 in contracted space (inside = tsdf < 0),
//!   vertices uncontracted, unnormalised and clipped to ±`max_range` (32)
//!   per coordinate;
//! - vertex colours: each vertex's world point through the same per-view
//!   averaging with a constant truncation of 5·voxel, colours sampled
//!   bilinearly, starting from black with weight 1, clamped to [0, 1].
//!
//! Work and memory: the grid is cut into 16³-sample tiles. Per tile and
//! view, a bound of the tile's world points (the tile's corners scaled by
//! the least and greatest uncontraction factor) and the min / max depth
//! under its footprint (a min / max pyramid of each depth map) decide
//! whether the view skips every sample, adds +1 to every sample (free space
//! well in front of the surface), or must be evaluated sample by sample.
//! A tile with no per-sample view holds one value; only tiles near surfaces
//! hold 16³. The running mean is computed as the mean of all observations
//! (the same number; f64 sums instead of 2DGS's f32 running update, so
//! values agree to rounding, about 1e-7).
//!
//! Departures: the principal point is used as given (2DGS keeps only the
//! field of view, i.e. a centred principal point; identical for centred
//! cameras); vertices are welded by grid edge, not by trimesh's
//! `merge_vertices(digits_vertex=6)`; faces are counter-clockwise seen from
//! the positive (free-space) side.

use glam::{DMat4, DVec3, DVec4};
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use crate::geom::meshing::marching_cubes::{edge_corners, table, triangulate};
use crate::model::{Camera, Mesh};
use crate::{Error, Result};

/// Samples per tile side.
const T: usize = 16;

/// Settings of the unbounded fusion.
#[derive(Clone, Copy, Debug)]
pub struct UnboundedParams {
    /// Normalisation centre (2DGS: the cameras' focus point).
    pub center: DVec3,
    /// Normalisation radius (2DGS: the smallest camera distance to it).
    pub radius: f64,
    /// Grid resolution N (2DGS `--mesh_res`, 1024).
    pub resolution: usize,
    /// Half side R of the contracted box.
    pub bound: f64,
    /// Output coordinates are clipped to ±this (2DGS: 32).
    pub max_range: f64,
}

/// One view to fuse: camera, z-depth (0 = none) and optional RGB8.
#[derive(Clone, Copy, Debug)]
pub struct UnboundedView<'a> {
    pub camera: &'a Camera,
    pub depth: &'a [f32],
    pub rgb: Option<&'a [[u8; 3]]>,
}

/// contract(x) of 2DGS.
pub fn contract(x: DVec3) -> DVec3 {
    let m = x.length();
    if m < 1.0 {
        x
    } else {
        (2.0 - 1.0 / m) * (x / m)
    }
}

/// uncontract(y) of 2DGS (mirrored for ‖y‖ > 2, infinite at 2).
pub fn uncontract(y: DVec3) -> DVec3 {
    let m = y.length();
    if m < 1.0 { y } else { y / (m * (2.0 - m)) }
}

/// 2DGS's box half side from the scene's points: min(q95(‖contract(
/// normalise(p))‖) + 0.01, 1.9) (numpy's linear quantile); 1.9 without
/// points.
pub fn bound_from_points(points: &[[f32; 3]], center: DVec3, radius: f64) -> f64 {
    let mut r: Vec<f64> = points
        .iter()
        .map(|p| {
            contract((DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) - center) / radius).length()
        })
        .filter(|v| v.is_finite())
        .collect();
    if r.is_empty() {
        return 1.9;
    }
    r.sort_unstable_by(f64::total_cmp);
    let h = 0.95 * (r.len() - 1) as f64;
    let (lo, f) = (h.floor() as usize, h - h.floor());
    let q = if lo + 1 < r.len() {
        r[lo] + f * (r[lo + 1] - r[lo])
    } else {
        r[lo]
    };
    (q + 0.01).min(1.9)
}

/// Samples per axis for resolution `n`.
pub fn samples_per_axis(n: usize) -> usize {
    if n >= 512 && n.is_multiple_of(512) {
        (n / 512) * 511 + 1
    } else {
        n
    }
}

/// Bytes per grid tile [`fuse_unbounded`] may hold: a dense tile of 16³
/// f32 values (16,384), its key (24), its entry in the tile table (32) and
/// its share of the per-tile mesh lists (three empty vectors, 72).
pub const TILE_BYTES: u64 = (T * T * T * 4) as u64 + 24 + 32 + 72;

/// Bytes per pixel of each view [`fuse_unbounded`] holds (all at once):
/// the depth map (4), the RGB8 colours (3) and the min and max depth
/// pyramids (2 × 4 × 4/3, rounded up to 11).
pub const VIEW_BYTES_PER_PIXEL: u64 = 4 + 3 + 11;

/// Upper bound of the bytes of the contracted grid at resolution `n`
/// ([`UnboundedParams::resolution`]): every one of the ⌈M/16⌉³ tiles (M =
/// [`samples_per_axis`]) dense, × [`TILE_BYTES`]. Saturating. The mesh
/// extracted from the grid is not counted.
pub fn grid_bytes(n: usize) -> u64 {
    let nt = samples_per_axis(n).div_ceil(T) as u64;
    nt.saturating_mul(nt)
        .saturating_mul(nt)
        .saturating_mul(TILE_BYTES)
}

/// A view prepared for sampling.
struct PreparedView<'a> {
    w2c: DMat4,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    width: usize,
    height: usize,
    depth: &'a [f32],
    rgb: Option<&'a [[u8; 3]]>,
    /// Min / max depth pyramids, level 1 upward (level 0 is `depth`).
    mins: Vec<(usize, usize, Vec<f32>)>,
    maxs: Vec<(usize, usize, Vec<f32>)>,
}

fn pyramid(
    depth: &[f32],
    w: usize,
    h: usize,
    pick: fn(f32, f32) -> f32,
) -> Vec<(usize, usize, Vec<f32>)> {
    let mut out: Vec<(usize, usize, Vec<f32>)> = Vec::new();
    let (mut pw, mut ph) = (w, h);
    let mut prev: Vec<f32> = depth.to_vec();
    while pw > 1 || ph > 1 {
        let (nw, nh) = (pw.div_ceil(2), ph.div_ceil(2));
        let mut next = vec![0.0f32; nw * nh];
        for y in 0..nh {
            for x in 0..nw {
                let mut v = prev[(2 * y) * pw + 2 * x];
                for (dx, dy) in [(1, 0), (0, 1), (1, 1)] {
                    let (sx, sy) = (2 * x + dx, 2 * y + dy);
                    if sx < pw && sy < ph {
                        v = pick(v, prev[sy * pw + sx]);
                    }
                }
                next[y * nw + x] = v;
            }
        }
        out.push((nw, nh, next.clone()));
        prev = next;
        pw = nw;
        ph = nh;
    }
    out
}

impl<'a> PreparedView<'a> {
    fn new(v: &UnboundedView<'a>) -> Self {
        let c = v.camera;
        let (w, h) = (c.width as usize, c.height as usize);
        let r = c.rotation;
        PreparedView {
            w2c: DMat4::from_cols(
                r.x_axis.extend(0.0),
                r.y_axis.extend(0.0),
                r.z_axis.extend(0.0),
                c.translation.extend(1.0),
            ),
            fx: c.fx,
            fy: c.fy,
            cx: c.cx,
            cy: c.cy,
            width: w,
            height: h,
            depth: v.depth,
            rgb: v.rgb,
            mins: pyramid(v.depth, w, h, f32::min),
            maxs: pyramid(v.depth, w, h, f32::max),
        }
    }

    /// NDC of a camera-space point (z > 0).
    #[inline]
    fn ndc(&self, p: DVec3) -> (f64, f64) {
        (
            (self.fx * p.x / p.z + self.cx) * 2.0 / self.width as f64 - 1.0,
            (self.fy * p.y / p.z + self.cy) * 2.0 / self.height as f64 - 1.0,
        )
    }

    /// Min and max depth over pixels x0..=x1, y0..=y1 (a superset of them).
    fn range(&self, x0: usize, x1: usize, y0: usize, y1: usize) -> (f32, f32) {
        let mut k = 0usize;
        while (x1 >> k) - (x0 >> k) > 1 || (y1 >> k) - (y0 >> k) > 1 {
            k += 1;
        }
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for y in (y0 >> k)..=(y1 >> k) {
            for x in (x0 >> k)..=(x1 >> k) {
                let (a, b) = if k == 0 {
                    let v = self.depth[y * self.width + x];
                    (v, v)
                } else {
                    let (w, _, m) = &self.mins[k - 1];
                    let (_, _, mx) = &self.maxs[k - 1];
                    (m[y * w + x], mx[y * w + x])
                };
                lo = lo.min(a);
                hi = hi.max(b);
            }
        }
        (lo, hi)
    }

    /// Bilinear sample (`grid_sample`, align_corners, border) of a map at
    /// NDC (nx, ny).
    #[inline]
    fn sample<const C: usize>(&self, nx: f64, ny: f64, at: impl Fn(usize) -> [f32; C]) -> [f32; C] {
        let u = ((nx + 1.0) * 0.5 * (self.width - 1) as f64).clamp(0.0, (self.width - 1) as f64);
        let v = ((ny + 1.0) * 0.5 * (self.height - 1) as f64).clamp(0.0, (self.height - 1) as f64);
        let (x0, y0) = (u.floor() as usize, v.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = ((u - x0 as f64) as f32, (v - y0 as f64) as f32);
        let (a, b) = (at(y0 * self.width + x0), at(y0 * self.width + x1));
        let (c, d) = (at(y1 * self.width + x0), at(y1 * self.width + x1));
        std::array::from_fn(|k| {
            (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
        })
    }

    /// The observation of world point `p` with truncation `trunc`: the
    /// clamped sdf and the sampled colour (0–1), or `None` when the view
    /// does not integrate it.
    fn observe(&self, p: DVec3, trunc: f64, colour: bool) -> Option<(f32, [f32; 3])> {
        let c = (self.w2c * p.extend(1.0)).truncate();
        if c.z <= 0.0 || c.z.is_nan() {
            return None;
        }
        let (nx, ny) = self.ndc(c);
        if !(nx > -1.0 && nx < 1.0 && ny > -1.0 && ny < 1.0) {
            return None;
        }
        let d = self.sample::<1>(nx, ny, |i| [self.depth[i]])[0] as f64;
        let sdf = d - c.z;
        // NaN fails too
        if sdf.partial_cmp(&-trunc) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let rgb = match (colour, self.rgb) {
            (true, Some(img)) => self.sample::<3>(nx, ny, |i| img[i].map(|v| v as f32 / 255.0)),
            _ => [0.0; 3],
        };
        Some(((sdf / trunc).clamp(-1.0, 1.0) as f32, rgb))
    }
}

/// What one view does to every sample of a tile.
#[derive(Clone, Copy, PartialEq, Eq)]
enum TileView {
    Skip,
    Free,
    Exact,
}

/// The grid geometry.
struct Grid {
    m: usize,
    step: f64,
    bound: f64,
    voxel: f64,
    center: DVec3,
    radius: f64,
}

impl Grid {
    fn coord(&self, i: usize) -> f64 {
        -self.bound + i as f64 * self.step
    }

    fn contracted(&self, i: [usize; 3]) -> DVec3 {
        DVec3::new(self.coord(i[0]), self.coord(i[1]), self.coord(i[2]))
    }

    fn world(&self, y: DVec3) -> DVec3 {
        uncontract(y) * self.radius + self.center
    }

    fn trunc(&self, y: DVec3) -> f64 {
        let n = y.length();
        let t = 5.0 * self.voxel;
        if n > 1.0 { t / (2.0 - n.min(1.9)) } else { t }
    }
}

/// One tile's share of the mesh: edge keys, contracted positions, triangles
/// in tile-local vertex indices.
type TileMesh = (Vec<[usize; 4]>, Vec<[f64; 3]>, Vec<[u32; 3]>);

/// A tile's values: one for all samples, or one per sample (x-major 16³).
enum Tile {
    Uniform(f32),
    Dense(Vec<f32>),
}

/// The sample index range of tile `t` along an axis.
fn tile_range(t: usize, m: usize) -> std::ops::Range<usize> {
    t * T..((t + 1) * T).min(m)
}

/// Bound of the world points of a contracted box: (AABB min, AABB max), or
/// `None` when the box reaches the sphere ‖y‖ = 2 (no finite bound).
fn world_aabb(g: &Grid, lo: DVec3, hi: DVec3) -> Option<(DVec3, DVec3)> {
    // the box point nearest to the origin, and the farthest corner
    let closest = DVec3::new(
        0.0f64.clamp(lo.x, hi.x),
        0.0f64.clamp(lo.y, hi.y),
        0.0f64.clamp(lo.z, hi.z),
    );
    let rmin = closest.length();
    let rmax = lo.abs().max(hi.abs()).length();
    if rmin <= 2.0 + 1e-9 && rmax >= 2.0 - 1e-9 {
        return None;
    }
    let scale = |r: f64| if r < 1.0 { 1.0 } else { 1.0 / (r * (2.0 - r)) };
    let (s0, s1) = (scale(rmin.max(0.0)), scale(rmax));
    let mut a = DVec3::splat(f64::INFINITY);
    let mut b = DVec3::splat(f64::NEG_INFINITY);
    for k in 0..8 {
        let c = DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        for s in [s0, s1] {
            let w = c * s * g.radius + g.center;
            a = a.min(w);
            b = b.max(w);
        }
    }
    Some((a, b))
}

/// What view `v` does to a tile whose world points lie in `aabb` and whose
/// truncations are at most `tmax`.
fn classify(v: &PreparedView, aabb: Option<(DVec3, DVec3)>, tmax: f64) -> TileView {
    let Some((a, b)) = aabb else {
        return TileView::Exact;
    };
    let mut cs = [DVec3::ZERO; 8];
    for (k, c) in cs.iter_mut().enumerate() {
        let p = DVec3::new(
            if k & 1 == 0 { a.x } else { b.x },
            if k & 2 == 0 { a.y } else { b.y },
            if k & 4 == 0 { a.z } else { b.z },
        );
        *c = (v.w2c * DVec4::new(p.x, p.y, p.z, 1.0)).truncate();
    }
    let behind = cs.iter().filter(|c| c.z <= 0.0).count();
    if behind == 8 {
        return TileView::Skip;
    }
    if behind > 0 {
        return TileView::Exact;
    }
    let (mut nx0, mut nx1, mut ny0, mut ny1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    let (mut z0, mut z1) = (f64::INFINITY, f64::NEG_INFINITY);
    for c in &cs {
        let (nx, ny) = v.ndc(*c);
        nx0 = nx0.min(nx);
        nx1 = nx1.max(nx);
        ny0 = ny0.min(ny);
        ny1 = ny1.max(ny);
        z0 = z0.min(c.z);
        z1 = z1.max(c.z);
    }
    let eps = 1e-6;
    if nx1 <= -1.0 - eps || nx0 >= 1.0 + eps || ny1 <= -1.0 - eps || ny0 >= 1.0 + eps {
        return TileView::Skip;
    }
    let px = |n: f64, s: usize| ((n + 1.0) * 0.5 * (s - 1) as f64).clamp(0.0, (s - 1) as f64);
    let (ux0, ux1) = (
        px(nx0, v.width).floor() as usize,
        (px(nx1, v.width).ceil() as usize).min(v.width - 1),
    );
    let (uy0, uy1) = (
        px(ny0, v.height).floor() as usize,
        (px(ny1, v.height).ceil() as usize).min(v.height - 1),
    );
    let (dmin, dmax) = v.range(ux0, ux1, uy0, uy1);
    let margin = 1e-4 * tmax + 1e-9;
    if dmax as f64 - z0 <= -tmax - margin {
        return TileView::Skip;
    }
    let inside = nx0 > -1.0 + eps && nx1 < 1.0 - eps && ny0 > -1.0 + eps && ny1 < 1.0 - eps;
    if inside && dmin as f64 - z1 >= tmax + margin {
        return TileView::Free;
    }
    TileView::Exact
}

/// Fills one tile: its per-view classification, then (when some view needs
/// it) each sample's mean over its observations, starting from −1.
fn fill_tile(g: &Grid, views: &[PreparedView], t: [usize; 3]) -> Tile {
    let rx = tile_range(t[0], g.m);
    let ry = tile_range(t[1], g.m);
    let rz = tile_range(t[2], g.m);
    let lo = g.contracted([rx.start, ry.start, rz.start]);
    let hi = g.contracted([rx.end - 1, ry.end - 1, rz.end - 1]);
    let aabb = world_aabb(g, lo, hi);
    // truncation range over the tile (monotone in ‖y‖)
    let rmax = lo.abs().max(hi.abs()).length();
    let tmax = g.trunc(DVec3::new(rmax, 0.0, 0.0));
    let kinds: Vec<TileView> = views.iter().map(|v| classify(v, aabb, tmax)).collect();
    let free = kinds.iter().filter(|k| **k == TileView::Free).count() as f64;
    let exact: Vec<&PreparedView> = views
        .iter()
        .zip(&kinds)
        .filter(|(_, k)| **k == TileView::Exact)
        .map(|(v, _)| v)
        .collect();
    if exact.is_empty() {
        return Tile::Uniform(((-1.0 + free) / (1.0 + free)) as f32);
    }
    let mut out = vec![0.0f32; T * T * T];
    for x in rx.clone() {
        for y in ry.clone() {
            for z in rz.clone() {
                let yv = g.contracted([x, y, z]);
                let w = g.world(yv);
                let tr = g.trunc(yv);
                let (mut sum, mut n) = (-1.0 + free, 1.0 + free);
                for v in &exact {
                    if let Some((s, _)) = v.observe(w, tr, false) {
                        sum += s as f64;
                        n += 1.0;
                    }
                }
                out[((x - rx.start) * T + (y - ry.start)) * T + (z - rz.start)] = (sum / n) as f32;
            }
        }
    }
    Tile::Dense(out)
}

/// Fuses `views` on the contracted grid and meshes it (see the module
/// documentation). Errors: no view, a depth map or colour image whose size
/// is not its camera's, a non-positive radius or bound, a resolution below 2.
pub fn fuse_unbounded(views: &[UnboundedView], p: &UnboundedParams) -> Result<Mesh> {
    if views.is_empty() {
        return Err(Error::invalid("no views to fuse"));
    }
    if !(p.radius.is_finite() && p.radius > 0.0 && p.bound.is_finite() && p.bound > 0.0) {
        return Err(Error::invalid(format!(
            "unbounded TSDF needs a positive radius and bound, got {} and {}",
            p.radius, p.bound
        )));
    }
    if p.resolution < 2 {
        return Err(Error::invalid(
            "unbounded TSDF resolution must be at least 2",
        ));
    }
    for v in views {
        let n = v.camera.width as usize * v.camera.height as usize;
        if v.depth.len() != n || v.rgb.is_some_and(|c| c.len() != n) || n == 0 {
            return Err(Error::invalid(format!(
                "camera {:?}: depth or colour map size is not {}x{}",
                v.camera.name, v.camera.width, v.camera.height
            )));
        }
    }
    let m = samples_per_axis(p.resolution);
    let g = Grid {
        m,
        step: 2.0 * p.bound / (m - 1) as f64,
        bound: p.bound,
        voxel: 2.0 * p.radius / p.resolution as f64,
        center: p.center,
        radius: p.radius,
    };
    let prepared: Vec<PreparedView> = views.par_iter().map(PreparedView::new).collect();
    let nt = m.div_ceil(T);
    let keys: Vec<[usize; 3]> = (0..nt * nt * nt)
        .map(|i| [i / (nt * nt), (i / nt) % nt, i % nt])
        .collect();
    let tiles: Vec<Tile> = keys
        .par_iter()
        .map(|&t| fill_tile(&g, &prepared, t))
        .collect();
    let at = |t: [usize; 3]| &tiles[(t[0] * nt + t[1]) * nt + t[2]];
    let value = |s: [usize; 3]| -> f32 {
        let t = [s[0] / T, s[1] / T, s[2] / T];
        match at(t) {
            Tile::Uniform(v) => *v,
            Tile::Dense(d) => d[((s[0] % T) * T + s[1] % T) * T + s[2] % T],
        }
    };
    // marching cubes per tile, cubes whose lower corner is in the tile
    let tab = table();
    let parts: Vec<TileMesh> = keys
        .par_iter()
        .map(|&t| {
            let mut keys_out: Vec<[usize; 4]> = Vec::new();
            let mut pos: Vec<[f64; 3]> = Vec::new();
            let mut tris = Vec::new();
            // a uniform tile whose + neighbours are uniform with the same
            // sign has no crossing
            let neighbours_uniform_same = (0..8).all(|k| {
                let n = [t[0] + (k & 1), t[1] + ((k >> 1) & 1), t[2] + (k >> 2)];
                n.iter().any(|&c| c >= nt)
                    || matches!((at(t), at(n)), (Tile::Uniform(a), Tile::Uniform(b)) if (*a < 0.0) == (*b < 0.0))
            });
            if neighbours_uniform_same {
                return (keys_out, pos, tris);
            }
            let mut local: FxHashMap<[usize; 4], u32> = FxHashMap::default();
            let r = [tile_range(t[0], m), tile_range(t[1], m), tile_range(t[2], m)];
            for x in r[0].clone() {
                for y in r[1].clone() {
                    for z in r[2].clone() {
                        if x + 1 >= m || y + 1 >= m || z + 1 >= m {
                            continue;
                        }
                        let mut f = [0.0f32; 8];
                        let mut case = 0usize;
                        for (k, fk) in f.iter_mut().enumerate() {
                            *fk = value([x + (k & 1), y + ((k >> 1) & 1), z + (k >> 2)]);
                            if *fk < 0.0 {
                                case |= 1 << k;
                            }
                        }
                        if case == 0 || case == 255 {
                            continue;
                        }
                        for lp in &tab[case] {
                            let mut poly = Vec::with_capacity(lp.len());
                            for &e in lp {
                                let (ca, cb) = edge_corners(e as usize);
                                let axis = e as usize / 4;
                                let a = [x + (ca & 1), y + ((ca >> 1) & 1), z + (ca >> 2)];
                                let key = [a[0], a[1], a[2], axis];
                                let id = *local.entry(key).or_insert_with(|| {
                                    let (fa, fb) = (f[ca] as f64, f[cb] as f64);
                                    let tpar = if fb != fa { (0.0 - fa) / (fb - fa) } else { 0.5 };
                                    let mut c = g.contracted(a);
                                    c[axis] += tpar * g.step;
                                    pos.push(c.to_array());
                                    keys_out.push(key);
                                    (pos.len() - 1) as u32
                                });
                                poly.push(id);
                            }
                            triangulate(&poly, &pos, &mut tris);
                        }
                    }
                }
            }
            (keys_out, pos, tris)
        })
        .collect();
    let mut all: Vec<([usize; 4], [f64; 3])> = parts
        .iter()
        .flat_map(|(k, p, _)| k.iter().copied().zip(p.iter().copied()))
        .collect();
    all.par_sort_unstable_by_key(|v| v.0);
    all.dedup_by_key(|v| v.0);
    let id: FxHashMap<[usize; 4], u32> = all
        .iter()
        .enumerate()
        .map(|(i, v)| (v.0, i as u32))
        .collect();
    let mut faces = Vec::new();
    for (k, _, tris) in &parts {
        let map: Vec<u32> = k.iter().map(|q| id[q]).collect();
        faces.extend(
            tris.iter()
                .map(|t| [map[t[0] as usize], map[t[1] as usize], map[t[2] as usize]]),
        );
    }
    let world: Vec<DVec3> = all
        .par_iter()
        .map(|(_, c)| {
            let w = g.world(DVec3::from_array(*c));
            w.clamp(DVec3::splat(-p.max_range), DVec3::splat(p.max_range))
        })
        .collect();
    let mut mesh = Mesh::new(
        world
            .iter()
            .map(|w| [w.x as f32, w.y as f32, w.z as f32])
            .collect(),
        faces,
    );
    if views.iter().all(|v| v.rgb.is_some()) {
        let t = 5.0 * g.voxel;
        let colours: Vec<[u8; 4]> = world
            .par_iter()
            .map(|w| {
                let (mut sum, mut n) = ([0.0f64; 3], 1.0f64);
                for v in &prepared {
                    if let Some((_, c)) = v.observe(*w, t, true) {
                        for k in 0..3 {
                            sum[k] += c[k] as f64;
                        }
                        n += 1.0;
                    }
                }
                let c = sum.map(|s| ((s / n).clamp(0.0, 1.0) * 255.0).round() as u8);
                [c[0], c[1], c[2], 255]
            })
            .collect();
        mesh.vertex_colors = Some(colours);
    }
    Ok(mesh)
}
