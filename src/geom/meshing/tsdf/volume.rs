//! The sparse TSDF volume and its integration of one depth frame, with the
//! rules of Open3D's `ScalableTSDFVolume` (0.10–0.18, `ScalableTSDFVolume.cpp`
//! and `UniformTSDFVolume.cpp`), which 2DGS and Triangle Splatting mesh with.
//!
//! Storage: blocks ("volume units") of 16³ voxels in a hash map keyed by the
//! block index b; block b covers [b·16·voxel, (b+1)·16·voxel) per axis and
//! its voxel (x, y, z) has its centre at `(b·16 + (x, y, z) + 0.5)·voxel`.
//!
//! Integration of a frame (z-depth in scene units, 0 = missing):
//! 1. depths at or beyond `depth_trunc` (and NaN, ±∞ and negatives, which
//!    Open3D would pass through) are missing;
//! 2. allocation: every `stride`-th pixel (rows and columns 0, s, 2s, … with
//!    pixel centres at integer coordinates, Open3D's convention) with a depth
//!    is back-projected to world space in f64; every block whose index lies in
//!    `floor((p ± sdf_trunc) / (16·voxel))` per axis is touched (and created);
//!    so a surface seen only between sampled pixels, or farther than
//!    `sdf_trunc` from every sampled point, gets no block;
//! 3. every touched block integrates the whole frame (several frames are
//!    fused block by block, in frame order per voxel, with the same result:
//!    [`TsdfVolume::integrate_batch`]): per voxel, in f32 as
//!    Open3D does (the camera point of a column's first voxel, then the z
//!    column of the extrinsic times the voxel size added per step), skipped
//!    when the camera z ≤ 0; pixel u = (int)(x·fx/z + cx + 0.5), v alike,
//!    only when 0.0001 ≤ x·fx/z + cx + 0.5 < W − 0.0001 (and for v); skipped
//!    when that pixel has no depth d; sdf = (d − z)·√(1 + ((u − cx)/fx)² +
//!    ((v − cy)/fy)²) (the z difference turned into a distance along the
//!    pixel's ray); when sdf > −sdf_trunc (strict): tsdf ← (tsdf·w +
//!    min(1, sdf·(1/sdf_trunc)))/(w + 1), colour likewise with the pixel's
//!    RGB8, w ← w + 1. There is no maximum weight; voxels in front of the
//!    surface are updated too (free space), but only inside touched blocks.
//!
//! Intrinsics here are Open3D's: cx, cy with pixel centres at integers, that
//! is splatkit's (centres at + 0.5) minus 0.5. For a camera whose principal
//! point is the image centre this gives 2DGS's `cx = (W − 1)/2`.
//!
//! Departure: colours are kept in f32 (Open3D: f64) and updated with the
//! reciprocal of w + 1 (one division per voxel instead of three); they are
//! means of 8-bit values, so the written 8-bit vertex colours agree except
//! where a value lies within 1e-5 of a rounding boundary.

use glam::{DMat4, DVec3, DVec4};
use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};

use crate::model::Camera;
use crate::{Error, Result};

/// Voxels per block side (Open3D `volume_unit_resolution`).
pub const UNIT: usize = 16;
/// Voxels per block.
pub const UNIT3: usize = UNIT * UNIT * UNIT;
/// Frames per [`TsdfVolume::integrate_batch`] call in `tsdf-fuse` and the
/// benchmark: 4 views of 800×600 hold about 23 MB of prepared pixels, and
/// each block is read from memory once per 4 frames (1, 2, 8 and 16 were
/// measured 4–15 % slower on the DTU benchmark).
pub const BATCH: usize = 4;

/// Fusion settings, scene units.
#[derive(Clone, Copy, Debug)]
pub struct TsdfParams {
    /// Voxel edge length.
    pub voxel: f64,
    /// Truncation distance of the signed distance.
    pub sdf_trunc: f64,
    /// Depths at or beyond this are missing (Open3D's `depth_trunc`).
    pub depth_trunc: f64,
    /// Pixel stride of the allocation pass (Open3D: 4).
    pub stride: usize,
    /// Most blocks the volume may hold (80 KiB each with colour, 32 KiB
    /// without): integration fails with an error beyond it, before
    /// allocating.
    pub max_blocks: usize,
}

impl TsdfParams {
    /// Open3D's defaults around the three distances: stride 4, and room for
    /// 2^20 blocks.
    pub fn new(voxel: f64, sdf_trunc: f64, depth_trunc: f64) -> Self {
        TsdfParams {
            voxel,
            sdf_trunc,
            depth_trunc,
            stride: 4,
            max_blocks: 1 << 20,
        }
    }

    /// Checks that every distance is finite and positive and the stride is
    /// at least 1.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("voxel", self.voxel),
            ("sdf_trunc", self.sdf_trunc),
            ("depth_trunc", self.depth_trunc),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(format!(
                    "TSDF {name} must be finite and positive, got {v}"
                )));
            }
        }
        if self.stride == 0 {
            return Err(Error::invalid("TSDF allocation stride must be at least 1"));
        }
        Ok(())
    }

    /// Edge length of a block.
    pub fn unit_length(&self) -> f64 {
        self.voxel * UNIT as f64
    }

    /// Blocks one usable depth sample touches (allocation step 2 of the
    /// module docs), (at least, at most): with n = ⌊2·sdf_trunc / u⌋ (u the
    /// block edge), the sample's cube [p − sdf_trunc, p + sdf_trunc] spans
    /// n + 1 or n + 2 blocks per axis, so (n + 1)³ and (n + 2)³. Saturating
    /// (u64::MAX for a truncation billions of blocks wide).
    pub fn sample_blocks(&self) -> (u64, u64) {
        let n = (2.0 * self.sdf_trunc / self.unit_length()).floor();
        let cube = |k: f64| {
            let k = k.min(1e7); // (1e7)³ is still below u64::MAX
            if k.is_finite() {
                (k as u64).pow(3)
            } else {
                u64::MAX
            }
        };
        if n.is_finite() && n < 1e7 {
            (cube(n + 1.0), cube(n + 2.0))
        } else {
            (u64::MAX, u64::MAX)
        }
    }

    /// Bounds of the blocks fusing `cams` can create, before any depth is
    /// seen (see [`BlockBounds`]). Depth samples of a view lie in its
    /// viewing pyramid: apex at the camera centre, base the image rectangle
    /// (pixel coordinates 0..W, 0..H) back-projected at z = depth_trunc; a
    /// block touched by a sample lies in that pyramid dilated by the cube of
    /// half-side r = sdf_trunc + u, whose volume is at most the Steiner
    /// formula with the ball of radius ρ = √3·r: V + S·ρ + (π/2)·L·ρ² +
    /// (4π/3)·ρ³ (V volume, S surface, L total edge length of the pyramid).
    pub fn block_bounds(&self, cams: &[Camera]) -> BlockBounds {
        let (per_min, per_max) = self.sample_blocks();
        let u = self.unit_length();
        let d = self.depth_trunc;
        let r = self.sdf_trunc + u;
        let rho = 3f64.sqrt() * r;
        let st = self.stride.max(1) as u64;
        let mut sum = 0f64;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        // each pyramid as half-spaces n·x ≤ b (unit n)
        let mut planes: Vec<Vec<(DVec3, f64)>> = Vec::with_capacity(cams.len());
        for c in cams {
            let o = c.center();
            let rot = c.c2w_rotation();
            let (w, h) = (c.width as f64, c.height as f64);
            let base: Vec<DVec3> = [(0.0, 0.0), (w, 0.0), (w, h), (0.0, h)]
                .iter()
                .map(|&(x, y)| {
                    o + rot * DVec3::new((x - c.cx) / c.fx * d, (y - c.cy) / c.fy * d, d)
                })
                .collect();
            for q in base.iter().chain(std::iter::once(&o)) {
                lo = lo.min(*q);
                hi = hi.max(*q);
            }
            let vol = (w / c.fx * d).abs() * (h / c.fy * d).abs() * d / 3.0;
            let tri = |a: DVec3, b: DVec3, e: DVec3| 0.5 * (b - a).cross(e - a).length();
            let mut area = tri(base[0], base[1], base[2]) + tri(base[0], base[2], base[3]);
            let mut edges = 0.0;
            for k in 0..4 {
                let (a, b) = (base[k], base[(k + 1) % 4]);
                area += tri(o, a, b);
                edges += (b - a).length() + (a - o).length();
            }
            let dilated = vol
                + area * rho
                + std::f64::consts::FRAC_PI_2 * edges * rho * rho
                + 4.0 / 3.0 * std::f64::consts::PI * rho.powi(3);
            let inside = base.iter().fold(DVec3::ZERO, |a, q| a + *q) / 4.0;
            let mut pl = Vec::with_capacity(6);
            for k in 0..4 {
                let n = (base[k] - o)
                    .cross(base[(k + 1) % 4] - o)
                    .normalize_or_zero();
                let n = if n.dot(inside - o) > 0.0 { -n } else { n };
                pl.push((n, n.dot(o)));
            }
            let axis = rot * DVec3::Z;
            pl.push((axis, axis.dot(o) + d));
            pl.push((-axis, -axis.dot(o)));
            planes.push(pl);
            let frustum = (dilated / u.powi(3)).ceil();
            let samples =
                (c.width as u64).div_ceil(st) as f64 * (c.height as u64).div_ceil(st) as f64;
            sum += frustum.min(samples * per_max as f64);
        }
        let aabb = if cams.is_empty() {
            0.0
        } else {
            (0..3)
                .map(|k| {
                    ((hi[k] + self.sdf_trunc) / u).floor() - ((lo[k] - self.sdf_trunc) / u).floor()
                        + 1.0
                })
                .product::<f64>()
        };
        let union = union_blocks(&planes, lo, hi, u, self.sdf_trunc);
        let upper = sum.min(aabb).min(union);
        BlockBounds {
            per_sample_min: per_min,
            per_sample_max: per_max,
            // `as` saturates; NaN (no finite bound) counts as unbounded
            upper: if upper.is_nan() {
                u64::MAX
            } else {
                upper as u64
            },
        }
    }
}

/// Most cells [`union_blocks`] tests (each against every view).
const UNION_CELLS: f64 = (1u64 << 18) as f64;

/// An upper bound of the blocks that meet the union of the dilated viewing
/// pyramids `planes` (half-spaces n·x ≤ b, unit n, one list per view) whose
/// vertices span the box `lo`..`hi`: the block grid over that box widened
/// by `tr` is cut into cubic cells of s³ blocks (s ≥ 1, at most
/// [`UNION_CELLS`] cells); a cell is kept when, for some view, its centre c
/// satisfies n·c − b ≤ (tr + u + g/2)·‖n‖₁ for every plane (g = s·u; a
/// cell meeting the pyramid dilated by the cube of half-side tr + u passes,
/// since that dilation moves each plane by at most (tr + u)·‖n‖₁); the
/// blocks of the kept cells are counted. `f64::INFINITY` when the box is
/// not finite.
fn union_blocks(planes: &[Vec<(DVec3, f64)>], lo: DVec3, hi: DVec3, u: f64, tr: f64) -> f64 {
    if planes.is_empty() {
        return 0.0;
    }
    let blo = ((lo - DVec3::splat(tr)) / u).floor();
    let bhi = ((hi + DVec3::splat(tr)) / u).floor();
    let nb = bhi - blo + DVec3::ONE;
    let total = nb.x * nb.y * nb.z;
    if !total.is_finite() || total <= 0.0 {
        return f64::INFINITY;
    }
    let s = (total / UNION_CELLS).cbrt().ceil().max(1.0);
    let nc = (nb / s).ceil();
    let cells = nc.x * nc.y * nc.z;
    if cells.is_nan() || cells > 2.0 * UNION_CELLS {
        return f64::INFINITY;
    }
    let (cx, cy, cz) = (nc.x as usize, nc.y as usize, nc.z as usize);
    let g = s * u;
    let reach = tr + u + g / 2.0;
    (0..cx * cy * cz)
        .into_par_iter()
        .map(|i| {
            let idx = DVec3::new(
                (i / (cy * cz)) as f64,
                ((i / cz) % cy) as f64,
                (i % cz) as f64,
            );
            let first = blo + idx * s;
            let c = first * u + DVec3::splat(g / 2.0);
            let hit = planes.iter().any(|pl| {
                pl.iter()
                    .all(|(n, b)| n.dot(c) - b <= reach * (n.x.abs() + n.y.abs() + n.z.abs()))
            });
            if !hit {
                return 0.0;
            }
            // blocks of this cell inside the grid
            let left = (bhi - first + DVec3::ONE).min(DVec3::splat(s));
            left.x * left.y * left.z
        })
        .sum()
}

/// How many blocks a fusion can create, known before any depth is seen
/// ([`TsdfParams::block_bounds`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockBounds {
    /// Blocks a single usable depth sample creates at least (see
    /// [`TsdfParams::sample_blocks`]): a fusion that sees anything needs
    /// this many.
    pub per_sample_min: u64,
    /// Blocks a single sample touches at most.
    pub per_sample_max: u64,
    /// Blocks all the views can create at most: the smaller of (a) the sum
    /// over views of min(the stride's samples × `per_sample_max`, the
    /// blocks in the view's dilated viewing pyramid), (b) the blocks of
    /// the box bounding every pyramid, widened by sdf_trunc, and (c) the
    /// blocks of the cells of that box that meet some dilated pyramid
    /// ([`union_blocks`]).
    pub upper: u64,
}

/// One frame to fuse: a camera, its z-depth map (row-major, `width·height`,
/// camera z in scene units, 0 = missing) and optionally its RGB8 colours.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    pub camera: &'a Camera,
    pub depth: &'a [f32],
    pub color: Option<&'a [[u8; 3]]>,
}

/// A block of 16³ voxels, index x·256 + y·16 + z.
#[derive(Clone, Debug)]
pub struct Block {
    /// Truncated signed distance / sdf_trunc, in [−1, 1]; 0 until observed.
    pub tsdf: Vec<f32>,
    /// Number of observations.
    pub weight: Vec<f32>,
    /// Mean RGB (0–255), when the volume keeps colour.
    pub color: Option<Vec<[f32; 3]>>,
}

impl Block {
    fn new(with_color: bool) -> Self {
        Block {
            tsdf: vec![0.0; UNIT3],
            weight: vec![0.0; UNIT3],
            color: with_color.then(|| vec![[0.0; 3]; UNIT3]),
        }
    }
}

/// What one [`TsdfVolume::integrate`] call did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntegrateStats {
    /// Blocks the frame touched (and integrated).
    pub touched: usize,
    /// Of those, blocks created by this frame.
    pub created: usize,
    /// Pixels with a usable depth (before the stride).
    pub valid_pixels: usize,
}

/// The sparse volume.
#[derive(Clone, Debug)]
pub struct TsdfVolume {
    params: TsdfParams,
    with_color: bool,
    keys: Vec<[i32; 3]>,
    blocks: Vec<Block>,
    index: FxHashMap<[i32; 3], usize>,
}

/// Open3D's depth preprocessing: a usable depth is finite, positive and
/// below `depth_trunc`; anything else is 0 (missing).
#[inline]
fn usable(d: f32, depth_trunc: f32) -> f32 {
    if d > 0.0 && d < depth_trunc && d.is_finite() {
        d
    } else {
        0.0
    }
}

/// The camera as Open3D gets it: f64 world-to-camera 4×4 and intrinsics with
/// integer pixel centres.
struct O3dCamera {
    w2c: DMat4,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    width: usize,
    height: usize,
}

impl O3dCamera {
    fn new(cam: &Camera) -> Self {
        let r = cam.rotation;
        let t = cam.translation;
        let w2c = DMat4::from_cols(
            r.x_axis.extend(0.0),
            r.y_axis.extend(0.0),
            r.z_axis.extend(0.0),
            t.extend(1.0),
        );
        O3dCamera {
            w2c,
            fx: cam.fx,
            fy: cam.fy,
            cx: cam.cx - 0.5,
            cy: cam.cy - 0.5,
            width: cam.width as usize,
            height: cam.height as usize,
        }
    }
}

impl TsdfVolume {
    /// An empty volume; `with_color` keeps a mean colour per voxel.
    pub fn new(params: TsdfParams, with_color: bool) -> Result<Self> {
        params.validate()?;
        Ok(TsdfVolume {
            params,
            with_color,
            keys: Vec::new(),
            blocks: Vec::new(),
            index: FxHashMap::default(),
        })
    }

    /// The settings.
    pub fn params(&self) -> &TsdfParams {
        &self.params
    }

    /// Whether voxels carry colour.
    pub fn has_color(&self) -> bool {
        self.with_color
    }

    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.blocks.len()
    }

    /// True before any block exists.
    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// Bytes held by the voxel arrays.
    pub fn memory_bytes(&self) -> usize {
        self.blocks.len() * Self::block_bytes(self.with_color)
    }

    /// Bytes of one block.
    pub fn block_bytes(with_color: bool) -> usize {
        UNIT3 * (8 + if with_color { 12 } else { 0 })
    }

    /// Block keys in creation order.
    pub fn keys(&self) -> &[[i32; 3]] {
        &self.keys
    }

    /// The block with key `k`.
    pub fn block(&self, k: [i32; 3]) -> Option<&Block> {
        self.index.get(&k).map(|&i| &self.blocks[i])
    }

    /// A volume with the given blocks whose voxel values come from `f`
    /// (global voxel index → tsdf and colour, `None` for weight 0), for
    /// hand-made test cases.
    #[cfg(test)]
    pub(crate) fn from_fn(
        params: TsdfParams,
        keys: &[[i32; 3]],
        f: impl Fn([i32; 3]) -> Option<(f32, [f32; 3])>,
    ) -> Self {
        let mut v = TsdfVolume::new(params, true).expect("valid parameters");
        for &k in keys {
            let mut b = Block::new(true);
            for x in 0..UNIT {
                for y in 0..UNIT {
                    for z in 0..UNIT {
                        let g = [
                            k[0] * UNIT as i32 + x as i32,
                            k[1] * UNIT as i32 + y as i32,
                            k[2] * UNIT as i32 + z as i32,
                        ];
                        if let Some((t, c)) = f(g) {
                            let i = (x * UNIT + y) * UNIT + z;
                            b.tsdf[i] = t;
                            b.weight[i] = 1.0;
                            b.color.as_mut().expect("colour")[i] = c;
                        }
                    }
                }
            }
            v.index.insert(k, v.blocks.len());
            v.keys.push(k);
            v.blocks.push(b);
        }
        v
    }

    /// True when world point `p` lies within the block indices the volume
    /// can address: voxel indices are block index × 16 + offset in `i32`,
    /// so a block index must stay below 2^31 / 16 in size (a point 10^29
    /// voxels away, from `--voxel 1e-30`, would overflow them).
    fn addressable(&self, p: DVec3) -> bool {
        let u = self.params.unit_length();
        let limit = (i32::MAX / UNIT as i32 / 2) as f64;
        (p / u).abs().max_element() < limit
    }

    /// The block index holding world point `p` (Open3D `LocateVolumeUnit`).
    fn locate(&self, p: DVec3) -> [i32; 3] {
        let u = self.params.unit_length();
        [
            (p.x / u).floor() as i32,
            (p.y / u).floor() as i32,
            (p.z / u).floor() as i32,
        ]
    }

    /// Fuses one frame. Errors: a depth (or colour) map whose size is not
    /// the camera's, a colour map on a volume without colour or none on one
    /// with colour, a camera that is not pinhole, or more blocks than
    /// `max_blocks`; the volume is unchanged after an error.
    pub fn integrate(&mut self, frame: &Frame) -> Result<IntegrateStats> {
        Ok(self.integrate_batch(std::slice::from_ref(frame))?[0])
    }

    /// Fuses frames in their order, with exactly the result of calling
    /// [`Self::integrate`] on each in turn, but faster: frame k allocates
    /// its blocks after frames 0..k, and each block then integrates, one
    /// after the other, the frames of the batch that touched it, while its
    /// 80 KB stay in cache (one frame at a time streams every touched block
    /// through memory once per frame, which bounds the speed). Per voxel the
    /// updates come in frame order, so the running means are the same
    /// numbers. Errors as [`Self::integrate`], checked for every frame
    /// before any is fused: the volume is unchanged after an error.
    pub fn integrate_batch(&mut self, frames: &[Frame]) -> Result<Vec<IntegrateStats>> {
        let prepared: Vec<Prepared> = frames
            .iter()
            .map(|f| self.prepare(f))
            .collect::<Result<_>>()?;

        // 1. allocation, frame by frame, without touching the volume yet
        let mut touched_per_frame: Vec<Vec<[i32; 3]>> = Vec::with_capacity(frames.len());
        let mut new_keys: Vec<[i32; 3]> = Vec::new();
        let mut new_set: FxHashSet<[i32; 3]> = FxHashSet::default();
        let mut created = Vec::with_capacity(frames.len());
        for p in &prepared {
            let touched = self.touched_blocks(p, self.params.max_blocks)?;
            let mut c = 0;
            for k in &touched {
                if !self.index.contains_key(k) && new_set.insert(*k) {
                    new_keys.push(*k);
                    c += 1;
                }
            }
            created.push(c);
            touched_per_frame.push(touched);
        }
        if self.blocks.len() + new_keys.len() > self.params.max_blocks {
            let n = self.blocks.len() + new_keys.len();
            return Err(Error::invalid(format!(
                "TSDF volume would need {n} blocks of 16³ voxels ({:.1} GiB), over the limit of {}: \
                 raise the voxel size or lower depth_trunc",
                (n * Self::block_bytes(self.with_color)) as f64 / (1u64 << 30) as f64,
                self.params.max_blocks
            )));
        }
        for k in &new_keys {
            self.index.insert(*k, self.blocks.len());
            self.keys.push(*k);
            self.blocks.push(Block::new(self.with_color));
        }
        // 2. per block, the frames that touched it, in order
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); self.blocks.len()];
        for (fi, touched) in touched_per_frame.iter().enumerate() {
            for k in touched {
                lists[self.index[k]].push(fi as u32);
            }
        }
        let prm = self.params;
        let keys = &self.keys;
        self.blocks
            .par_iter_mut()
            .zip(lists.par_iter())
            .enumerate()
            .filter(|(_, (_, l))| !l.is_empty())
            .for_each(|(i, (b, l))| {
                for &fi in l {
                    let p = &prepared[fi as usize];
                    if p.has_color {
                        integrate_block::<true>(b, keys[i], &prm, &p.oc, &p.pixels);
                    } else {
                        integrate_block::<false>(b, keys[i], &prm, &p.oc, &p.pixels);
                    }
                }
            });
        Ok(touched_per_frame
            .iter()
            .zip(&prepared)
            .zip(created)
            .map(|((t, p), created)| IntegrateStats {
                touched: t.len(),
                created,
                valid_pixels: p.valid_pixels,
            })
            .collect())
    }

    /// Checks a frame against the volume and computes what integration
    /// needs: Open3D's camera, the usable depth and the ray multipliers.
    fn prepare(&self, frame: &Frame) -> Result<Prepared> {
        let cam = frame.camera;
        cam.require_pinhole()
            .map_err(|e| Error::invalid(format!("camera {:?}: {e}", cam.name)))?;
        let (w, h) = (cam.width as usize, cam.height as usize);
        if frame.depth.len() != w * h {
            return Err(Error::invalid(format!(
                "depth map of camera {:?} has {} values, the camera is {w}×{h}",
                cam.name,
                frame.depth.len()
            )));
        }
        match (frame.color, self.with_color) {
            (Some(c), true) if c.len() != w * h => {
                return Err(Error::invalid(format!(
                    "colour image of camera {:?} has {} pixels, the camera is {w}×{h}",
                    cam.name,
                    c.len()
                )));
            }
            (None, true) => {
                return Err(Error::invalid(format!(
                    "camera {:?} has no colour image and the volume keeps colour",
                    cam.name
                )));
            }
            _ => {}
        }
        let oc = O3dCamera::new(cam);
        let trunc = self.params.depth_trunc as f32;
        let mult = distance_multiplier(&oc);
        let color = if self.with_color { frame.color } else { None };
        let pixels: Vec<Pixel> = frame
            .depth
            .iter()
            .zip(mult)
            .enumerate()
            .map(|(i, (&d, mult))| Pixel {
                depth: usable(d, trunc),
                mult,
                rgb: color.map_or([0; 3], |c| c[i]),
            })
            .collect();
        let valid_pixels = pixels.iter().filter(|p| p.depth > 0.0).count();
        Ok(Prepared {
            oc,
            pixels,
            has_color: color.is_some(),
            valid_pixels,
        })
    }

    /// The blocks a frame touches (allocation rule 2 of the module docs),
    /// sorted.
    fn touched_blocks(&self, p: &Prepared, limit: usize) -> Result<Vec<[i32; 3]>> {
        let oc = &p.oc;
        let (w, h) = (oc.width, oc.height);
        let px = &p.pixels;
        let c2w = oc.w2c.inverse();
        let st = self.params.stride;
        let tr = self.params.sdf_trunc;
        let too_many = |n: u64| {
            Error::invalid(format!(
                "TSDF volume would need more than {n} blocks of 16³ voxels ({:.1} GiB), over the \
                 limit of {limit}: raise the voxel size or lower sdf_trunc or depth_trunc",
                n as f64 * Self::block_bytes(self.with_color) as f64 / (1u64 << 30) as f64,
            ))
        };
        let rows: Vec<usize> = (0..h).step_by(st).collect();
        // rows a pass at a time, so the row sets held at once stay bounded
        // by the limit (each row stops once it alone is over it)
        let mut touched: Vec<[i32; 3]> = Vec::new();
        for pass in rows.chunks(ROWS_PER_PASS) {
            let touched_sets: Vec<std::result::Result<FxHashSet<[i32; 3]>, Option<DVec3>>> = pass
                .par_iter()
                .map(|&i| {
                    let mut set = FxHashSet::default();
                    for j in (0..w).step_by(st) {
                        let z = px[i * w + j].depth as f64;
                        if z <= 0.0 {
                            continue;
                        }
                        let x = (j as f64 - oc.cx) * z / oc.fx;
                        let y = (i as f64 - oc.cy) * z / oc.fy;
                        let p = (c2w * DVec4::new(x, y, z, 1.0)).truncate();
                        let lo = self.locate(p - DVec3::splat(tr));
                        let hi = self.locate(p + DVec3::splat(tr));
                        // one sample's block range is checked before it is
                        // walked: with a huge sdf_trunc it holds billions
                        let span = (0..3)
                            .map(|k| (i64::from(hi[k]) - i64::from(lo[k]) + 1) as u64)
                            .fold(1u64, u64::saturating_mul);
                        if span > limit as u64 {
                            return Err(None);
                        }
                        // (after the span: a huge sdf_trunc is a block
                        // count error; indices out of range otherwise)
                        if !self.addressable(p - DVec3::splat(tr))
                            || !self.addressable(p + DVec3::splat(tr))
                        {
                            return Err(Some(p));
                        }
                        for bx in lo[0]..=hi[0] {
                            for by in lo[1]..=hi[1] {
                                for bz in lo[2]..=hi[2] {
                                    set.insert([bx, by, bz]);
                                }
                            }
                        }
                        if set.len() > limit {
                            return Err(None);
                        }
                    }
                    Ok(set)
                })
                .collect();
            for set in touched_sets {
                match set {
                    Ok(set) => touched.extend(set),
                    Err(None) => return Err(too_many(limit as u64 + 1)),
                    Err(Some(p)) => {
                        return Err(Error::invalid(format!(
                            "a depth sample at ({:.3e}, {:.3e}, {:.3e}) lies beyond the \
                             block indices the volume can address at voxel size {:e}: raise \
                             the voxel size (or check the depth units and depth_trunc)",
                            p.x, p.y, p.z, self.params.voxel
                        )));
                    }
                }
            }
            touched.par_sort_unstable();
            touched.dedup();
            if touched.len() > limit {
                return Err(too_many(touched.len() as u64));
            }
        }
        Ok(touched)
    }
}

/// Rows of a frame whose touched blocks are gathered at once (in parallel)
/// before they are merged and counted.
const ROWS_PER_PASS: usize = 64;

/// A frame checked and prepared for integration.
struct Prepared {
    oc: O3dCamera,
    /// What a voxel reads from its pixel, in one place (one cache line);
    /// depth 0 = missing.
    pixels: Vec<Pixel>,
    has_color: bool,
    valid_pixels: usize,
}

/// One pixel of a prepared frame: usable depth, Open3D's ray multiplier,
/// colour.
#[derive(Clone, Copy)]
struct Pixel {
    depth: f32,
    mult: f32,
    rgb: [u8; 3],
}

/// Open3D's `CreateDepthToCameraDistanceMultiplierFloatImage`: per pixel
/// √(xx² + yy² + 1) with xx = (j − cx)·(1/fx), yy = (i − cy)·(1/fy), f32.
fn distance_multiplier(oc: &O3dCamera) -> Vec<f32> {
    let (ifx, ify) = (1.0f32 / oc.fx as f32, 1.0f32 / oc.fy as f32);
    let (cx, cy) = (oc.cx as f32, oc.cy as f32);
    let xx: Vec<f32> = (0..oc.width).map(|j| (j as f32 - cx) * ifx).collect();
    let mut out = Vec::with_capacity(oc.width * oc.height);
    for i in 0..oc.height {
        let yy = (i as f32 - cy) * ify;
        out.extend(xx.iter().map(|&x| (x * x + yy * yy + 1.0).sqrt()));
    }
    out
}

/// Integrates the frame into one block, voxel by voxel, in Open3D's f32
/// operation order.
fn integrate_block<const COLOR: bool>(
    b: &mut Block,
    key: [i32; 3],
    prm: &TsdfParams,
    oc: &O3dCamera,
    pixels: &[Pixel],
) {
    let e = oc.w2c.as_mat4(); // f32 extrinsic
    let vl = prm.voxel as f32;
    let half = vl * 0.5;
    let inv_trunc = 1.0f32 / prm.sdf_trunc as f32;
    let neg_trunc = -(prm.sdf_trunc as f32);
    let ul = prm.unit_length();
    let origin = [
        (key[0] as f64 * ul) as f32,
        (key[1] as f64 * ul) as f32,
        (key[2] as f64 * ul) as f32,
    ];
    // column 2 of extrinsic·voxel: the camera-space step per z voxel
    let step = [e.z_axis.x * vl, e.z_axis.y * vl, e.z_axis.z * vl];
    let (fx, fy, cx, cy) = (oc.fx as f32, oc.fy as f32, oc.cx as f32, oc.cy as f32);
    let w = oc.width;
    let safe_w = oc.width as f32 - 0.0001;
    let safe_h = oc.height as f32 - 0.0001;
    for x in 0..UNIT {
        for y in 0..UNIT {
            let base = x * UNIT * UNIT + y * UNIT;
            let p = [
                half + vl * x as f32 + origin[0],
                half + vl * y as f32 + origin[1],
                half + origin[2],
            ];
            // extrinsic_f · (p, 1), row by row, then Open3D's incremental z
            // step (f32 additions in order, as it does)
            let mut c = [0.0f32; 3];
            for (r, cr) in c.iter_mut().enumerate() {
                *cr = e.x_axis[r] * p[0] + e.y_axis[r] * p[1] + e.z_axis[r] * p[2] + e.w_axis[r];
            }
            let (mut cxs, mut cys, mut czs) = ([0.0f32; UNIT], [0.0f32; UNIT], [0.0f32; UNIT]);
            for z in 0..UNIT {
                if z > 0 {
                    c[0] += step[0];
                    c[1] += step[1];
                    c[2] += step[2];
                }
                cxs[z] = c[0];
                cys[z] = c[1];
                czs[z] = c[2];
            }
            // the projections of the column's 16 voxels, in one vectorisable
            // pass (same operations and order as per voxel)
            let mut ufs = [0.0f32; UNIT];
            let mut vfs = [0.0f32; UNIT];
            for z in 0..UNIT {
                ufs[z] = cxs[z] * fx / czs[z] + cx + 0.5;
                vfs[z] = cys[z] * fy / czs[z] + cy + 0.5;
            }
            for z in 0..UNIT {
                let (uf, vf) = (ufs[z], vfs[z]);
                if czs[z] <= 0.0 {
                    continue;
                }
                if !(uf >= 0.0001 && uf < safe_w && vf >= 0.0001 && vf < safe_h) {
                    continue;
                }
                // in range by the test above
                let px = vf as u32 as usize * w + uf as u32 as usize;
                let pix = &pixels[px];
                let d = pix.depth;
                if d <= 0.0 {
                    continue;
                }
                let sdf = (d - czs[z]) * pix.mult;
                if sdf > neg_trunc {
                    let i = base + z;
                    let tsdf = (sdf * inv_trunc).min(1.0);
                    let wt = b.weight[i];
                    b.tsdf[i] = (b.tsdf[i] * wt + tsdf) / (wt + 1.0);
                    if COLOR && let Some(bc) = b.color.as_mut() {
                        let rgb = pix.rgb;
                        let inv = 1.0 / (wt + 1.0);
                        for k in 0..3 {
                            bc[i][k] = (bc[i][k] * wt + rgb[k] as f32) * inv;
                        }
                    }
                    b.weight[i] = wt + 1.0;
                }
            }
        }
    }
}
