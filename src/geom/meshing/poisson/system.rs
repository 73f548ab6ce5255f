//! The screened Poisson system on a sparse multilevel grid, and its cascadic
//! solve (Kazhdan & Hoppe 2013; PoissonRecon `FEMTree::solveSystem`,
//! `Src/FEMTree.System.inl`).
//!
//! Unknowns are coefficients of degree-1 (trilinear hat) functions on the
//! nodes of levels 0..=D. Levels up to `full_depth` are complete; a finer
//! level ℓ holds the cells `C_ℓ` whose corners touch the support of the
//! normal field splatted at ℓ, closed so that every level-ℓ cell next to
//! `C_ℓ` has its parent in `C_{ℓ-1}`. Its *active* nodes (the corners of
//! `C_ℓ`) are solved at ℓ; its *valid* nodes (corners of `C_ℓ` grown by one
//! cell) hold the accumulated solution χ_{≤ℓ} at the node. Because every
//! coarser hat is exactly a combination of finer hats, the accumulated
//! solution of level ℓ-1 prolongs exactly into level ℓ's valid nodes, and the
//! level-ℓ Gauss–Seidel sweeps act on the total solution with the coarse
//! part frozen outside the active set. Coarse levels are never revisited
//! (one cascadic pass, as PoissonRecon and Open3D do).
//!
//! The normal field V is a sum of degree-2 B-splines splatted at each
//! sample's estimated depth (split between ⌈d⌉ and ⌈d⌉-1 with weights
//! dx, 1-dx), negated so that χ ≈ 1 inside and 0 outside. The right-hand side
//! b_i = ⟨∇B_i, V⟩ over the whole of V is assembled exactly: contributions of
//! finer V by restriction (a coarse hat is a combination of finer hats),
//! contributions of coarser V by prolonging the accumulated coarse field into
//! the finer degree-2 basis. Screening adds, per level, one virtual sample per
//! occupied cell (weighted centroid, weight ω = α·ā·W·2^ℓ) pulling χ to ½.

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::bspline::{NodeSide, Tables, b2_weights};
use super::grid::{
    BRICK_LEN, BS, BitGrid, Bricks, Mask, brick_key, brick_of, local_index, mask_has,
};
use super::samples::Samples;

/// Solver settings (the names users know from PoissonRecon / Open3D).
#[derive(Clone, Debug)]
pub struct SolverParams {
    /// Finest depth D.
    pub depth: u32,
    /// Levels up to this depth are complete.
    pub full_depth: u32,
    /// Screening weight α (0 = unscreened Poisson).
    pub point_weight: f64,
    /// Gauss–Seidel sweeps per level.
    pub iters: usize,
}

/// One virtual screening sample of a cell: weight and position inside the cell.
#[derive(Clone, Copy, Debug)]
struct ScreenCell {
    local: u16,
    w: f32,
    f: [f32; 3],
}

/// One level of the grid with its solution.
#[derive(Debug)]
pub struct Level {
    /// Depth ℓ.
    pub depth: u32,
    /// Cells per axis, 2^ℓ.
    pub res: i32,
    /// Bricks holding this level's nodes and cells.
    pub bricks: Bricks,
    /// Per brick: nodes where `y` is the accumulated solution.
    pub valid: Vec<Mask>,
    /// Per brick: nodes solved at this level.
    pub active: Vec<Mask>,
    /// χ_{≤ℓ} at valid nodes (NaN elsewhere).
    pub y: Vec<f32>,
    /// Cells of PoissonRecon's tree at this level (see `extraction_tree`);
    /// empty for the complete levels. The extraction uses their parents (the
    /// refined cells of the level above), so the sibling groups that
    /// PoissonRecon completes around the added neighbours are not stored.
    pub tree: BitGrid,
    /// True for the complete levels.
    pub complete: bool,
    b: Vec<f32>,
    screen: Vec<Vec<ScreenCell>>,
}

impl Level {
    /// True when node `p` holds a value.
    #[inline]
    pub fn is_valid(&self, p: [i32; 3]) -> bool {
        match self.bricks.get(brick_of(p)) {
            Some(bi) => mask_has(&self.valid[bi], local_index(p)),
            None => false,
        }
    }

    /// The solution at node `p` when valid.
    #[inline]
    pub fn value(&self, p: [i32; 3]) -> Option<f32> {
        let bi = self.bricks.get(brick_of(p))?;
        let l = local_index(p);
        mask_has(&self.valid[bi], l).then(|| self.y[bi * BRICK_LEN + l])
    }

    /// Number of active (solved) nodes.
    pub fn active_count(&self) -> usize {
        self.active
            .iter()
            .map(|m| m.iter().map(|w| w.count_ones() as usize).sum::<usize>())
            .sum()
    }
}

/// Statistics of a solve.
#[derive(Clone, Debug, Default)]
pub struct SolveStats {
    /// Active nodes per level.
    pub active_per_level: Vec<usize>,
    /// Bricks per level.
    pub bricks_per_level: Vec<usize>,
    /// Mean sample area ā (unit-cube units).
    pub mean_area: f64,
}

type VBrick = Box<[[f32; 3]; BRICK_LEN]>;

/// Splatted normal field of one level, keyed by brick.
#[derive(Default)]
struct VLevel {
    bricks: FxHashMap<u64, ([i32; 3], VBrick)>,
}

impl VLevel {
    fn add(&mut self, c: [i32; 3], v: [f64; 3], res: i32) {
        if c.iter().any(|&x| x < 0 || x >= res) {
            return;
        }
        let b = brick_of(c);
        let e = self
            .bricks
            .entry(brick_key(b))
            .or_insert_with(|| (b, Box::new([[0.0; 3]; BRICK_LEN])));
        let t = &mut e.1[local_index(c)];
        for k in 0..3 {
            t[k] += v[k] as f32;
        }
    }

    /// Copies the cell box `lo .. lo+dims` into `out` (zeros where absent).
    fn gather(&self, lo: [i32; 3], dims: [usize; 3], out: &mut [[f32; 3]]) {
        out.fill([0.0; 3]);
        let hi = [
            lo[0] + dims[0] as i32 - 1,
            lo[1] + dims[1] as i32 - 1,
            lo[2] + dims[2] as i32 - 1,
        ];
        for bz in (lo[2] >> 3)..=(hi[2] >> 3) {
            for by in (lo[1] >> 3)..=(hi[1] >> 3) {
                for bx in (lo[0] >> 3)..=(hi[0] >> 3) {
                    let b = [bx, by, bz];
                    let Some((bb, data)) = self.bricks.get(&brick_key(b)) else {
                        continue;
                    };
                    if *bb != b {
                        continue;
                    }
                    for z in (bz * BS).max(lo[2])..=(bz * BS + BS - 1).min(hi[2]) {
                        for y in (by * BS).max(lo[1])..=(by * BS + BS - 1).min(hi[1]) {
                            for x in (bx * BS).max(lo[0])..=(bx * BS + BS - 1).min(hi[0]) {
                                let o = (x - lo[0]) as usize
                                    + dims[0]
                                        * ((y - lo[1]) as usize + dims[1] * (z - lo[2]) as usize);
                                out[o] = data[local_index([x, y, z])];
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Per-sample depth estimate and area, from the density field.
pub struct SampleDepths {
    /// d(p) per sample.
    pub depth: Vec<f64>,
    /// a(p) per sample (unit-cube area per unit weight).
    pub area: Vec<f64>,
}

/// Builds and solves the system; returns the levels 0..=D with their solution.
pub fn solve(samples: &Samples, sd: &SampleDepths, p: &SolverParams) -> (Vec<Level>, SolveStats) {
    let d = p.depth;
    let full = p.full_depth.min(d);
    let tables = Tables::new();

    // Mean area per unit weight, ā.
    // Samples whose merged normals cancel carry no normal and no area
    // (PoissonRecon's conversion rejects them).
    let (wsum, wa) = (0..samples.len())
        .filter(|&i| has_normal(samples, i))
        .fold((0.0f64, 0.0f64), |(w, wa), i| {
            (w + samples.weight[i], wa + samples.weight[i] * sd.area[i])
        });
    let mean_area = if wsum > 0.0 { wa / wsum } else { 0.0 };

    // 1. Splat plan: which samples splat at which level, with which factor.
    let plan = splat_plan(samples, sd, d);
    // 2. Cell sets C_ℓ, finest first.
    let mut cells: Vec<BitGrid> = (0..=d).map(|_| BitGrid::new()).collect();
    let mut data: Vec<BitGrid> = (0..=d).map(|_| BitGrid::new()).collect();
    for lv in (full + 1..=d).rev() {
        let res = 1i32 << lv;
        data[lv as usize] = splat_cells(samples, &plan[lv as usize], lv);
        // Cells whose corner hats overlap the level's normal splats.
        let mut c = data[lv as usize].dilate(1, 1);
        if lv < d {
            c.union_with(&cells[lv as usize + 1].dilate(1, 1).parents());
        }
        c.clip([0; 3], [res - 1; 3]);
        cells[lv as usize] = c;
    }
    let tree = extraction_tree(data, full, d);

    // 3. Levels with node masks and screening cells.
    let mut levels: Vec<Level> = (0..=d)
        .map(|lv| {
            let res = 1i32 << lv;
            let (active, valid, span) = if lv <= full {
                let all = BitGrid::full([0; 3], [res; 3]);
                (all.clone(), all.clone(), all)
            } else {
                let c = &cells[lv as usize];
                let mut active = c.dilate(0, 1);
                active.clip([0; 3], [res; 3]);
                let mut valid = c.dilate(1, 2);
                valid.clip([0; 3], [res; 3]);
                let mut span = c.dilate(2, 2);
                span.clip([0; 3], [res - 1; 3]);
                (active, valid, span)
            };
            let mut bl = valid.bricks();
            bl.extend(span.bricks());
            let bricks = Bricks::new(bl);
            let nb = bricks.len();
            let masks = |g: &BitGrid| -> Vec<Mask> {
                bricks
                    .coords
                    .iter()
                    .map(|b| g.mask(*b).copied().unwrap_or([0; 8]))
                    .collect()
            };
            Level {
                depth: lv,
                res,
                valid: masks(&valid),
                active: masks(&active),
                y: vec![f32::NAN; nb * BRICK_LEN],
                tree: BitGrid::new(),
                complete: lv <= full,
                b: vec![0.0; nb * BRICK_LEN],
                screen: vec![Vec::new(); nb],
                bricks,
            }
        })
        .collect();
    drop(cells);
    for (lev, t) in levels.iter_mut().zip(tree) {
        if !lev.complete {
            lev.tree = t;
        }
    }

    levels.par_iter_mut().for_each(|lev| {
        add_screening(lev, samples, d, p.point_weight * mean_area);
    });

    // 4. Right-hand side from same and finer levels (bottom-up).
    for lv in (0..=d as usize).rev() {
        let own = splat(samples, &plan[lv], lv as u32);
        let (coarse, fine) = levels.split_at_mut(lv + 1);
        let lev = &mut coarse[lv];
        integrate_level(
            &lev.bricks,
            &lev.active,
            lev.res,
            &tables,
            &mut lev.b,
            |lo, dims, out| own.gather(lo, dims, out),
        );
        if let Some(f) = fine.first() {
            restrict(lev, f);
        }
    }

    levels.par_iter_mut().for_each(add_screening_target);

    // 5. Cascadic solve, coarse to fine, adding the coarser normal field.
    let mut vacc: Vec<[f32; 3]> = Vec::new();
    for lv in 0..=d as usize {
        let stencils = stencils(&tables, levels[lv].res);
        let own = splat(samples, &plan[lv], lv as u32);
        if lv > 0 {
            let (coarse, fine) = levels.split_at_mut(lv);
            let (prev, lev) = (&coarse[lv - 1], &mut fine[0]);
            prolong_solution(prev, lev);
            let keep = lv < d as usize;
            vacc = coarse_field_rhs(prev, &vacc, lev, &tables, &own, keep);
        } else {
            // Level 0 is one brick; start from χ = 0 and keep its own field.
            let lev = &mut levels[0];
            for (i, v) in lev.y.iter_mut().enumerate() {
                if mask_has(&lev.valid[i / BRICK_LEN], i % BRICK_LEN) {
                    *v = 0.0;
                }
            }
            vacc = vec![[0.0f32; 3]; BRICK_LEN];
            own.gather([0; 3], [8, 8, 8], &mut vacc);
        }
        drop(own);
        let sweeps = if lv == 0 { 64 } else { p.iters };
        let lev = &mut levels[lv];
        for _ in 0..sweeps {
            gauss_seidel_sweep(lev, &stencils);
        }
        // The right-hand side and screening samples are spent.
        lev.b = Vec::new();
        lev.screen = Vec::new();
    }
    let stats = SolveStats {
        active_per_level: levels.iter().map(Level::active_count).collect(),
        bricks_per_level: levels.iter().map(|l| l.bricks.len()).collect(),
        mean_area,
    };
    (levels, stats)
}

/// The cells of the octree that PoissonRecon extracts on (its non-ghost
/// nodes after `finalizeForMultigrid`), per level above `full`, from the
/// cells holding normal-field coefficients (`data`, the 3³ around each
/// splatting sample): a level-ℓ cell is in the tree when a cell of its
/// sibling group (same parent) has data at ℓ or below; then, finest first,
/// every level-ℓ cell within two cells of a parent of a level-(ℓ+1) tree cell
/// joins (the neighbourhood PoissonRecon adds for its degree-2 overlap). The
/// solve keeps its own, wider cell sets `C_ℓ`; this tree only decides where
/// the iso-surface is extracted at which depth, so the mesh has Open3D's
/// resolution where the samples are sparse (its vertex count within 0.1 %
/// on the Stanford bunny, docs/poisson.md).
fn extraction_tree(data: Vec<BitGrid>, full: u32, d: u32) -> Vec<BitGrid> {
    let mut tree: Vec<BitGrid> = (0..=d).map(|_| BitGrid::new()).collect();
    let mut has_data = BitGrid::new();
    for (lv, mut h) in data.into_iter().enumerate().rev() {
        if lv as u32 <= full {
            break;
        }
        if (lv as u32) < d {
            h.union_with(&has_data.parents());
        }
        tree[lv] = h.parents().children();
        has_data = h;
    }
    for lv in (full as usize + 1..d as usize).rev() {
        let res = 1i32 << lv;
        let mut t = tree[lv + 1].parents().dilate(2, 2);
        t.union_with(&tree[lv]);
        t.clip([0; 3], [res - 1; 3]);
        tree[lv] = t;
    }
    tree
}

/// For each level, the samples splatting there and their factor
/// −a·part/h³ · W/|n| (negated so that χ ≈ 1 inside; W/|n| rescales the
/// merged normal sum n to the sample's weight W, PoissonRecon's conversion:
/// unit mean normal × weight): a sample at depth estimate d splats the
/// fraction dx = 1 − (⌈d⌉ − d) at ⌈d⌉ and the rest one level up.
fn splat_plan(samples: &Samples, sd: &SampleDepths, d: u32) -> Vec<Vec<(u32, f32)>> {
    let mut plan: Vec<Vec<(u32, f32)>> = (0..=d).map(|_| Vec::new()).collect();
    for i in (0..samples.len()).filter(|&i| has_normal(samples, i)) {
        let dep = sd.depth[i].clamp(0.0, d as f64);
        let top = dep.ceil().max(0.0) as u32;
        let dx = 1.0 - (top as f64 - dep);
        let n = samples.normal[i];
        let a = sd.area[i] * samples.weight[i] / (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let mut put = |lv: u32, part: f64| {
            let h3 = 0.125f64.powi(lv as i32);
            plan[lv as usize].push((i as u32, (-a * part / h3) as f32));
        };
        // PoissonRecon splats the coarser part only when it exceeds 1e-6.
        if top > 0 && 1.0 - dx > 1e-6 {
            put(top, dx);
            put(top - 1, 1.0 - dx);
        } else {
            put(top, 1.0);
        }
    }
    plan
}

/// True when the merged sample's normal sum is not zero.
fn has_normal(samples: &Samples, i: usize) -> bool {
    samples.normal[i] != [0.0; 3]
}

/// The degree-2 normal field of one level from its splat plan.
fn splat(samples: &Samples, plan: &[(u32, f32)], lv: u32) -> VLevel {
    let res = 1i32 << lv;
    let mut v = VLevel::default();
    for &(i, s) in plan {
        let i = i as usize;
        let n = samples.normal[i];
        let pos = samples.pos[i];
        let (ix, wx) = b2_weights(pos[0] * res as f64);
        let (iy, wy) = b2_weights(pos[1] * res as f64);
        let (iz, wz) = b2_weights(pos[2] * res as f64);
        for (dz, wz) in wz.iter().enumerate() {
            for (dy, wy) in wy.iter().enumerate() {
                for (dxi, wx) in wx.iter().enumerate() {
                    let w = wx * wy * wz * s as f64;
                    let c = [ix + dxi as i32 - 1, iy + dy as i32 - 1, iz + dz as i32 - 1];
                    v.add(c, [n[0] * w, n[1] * w, n[2] * w], res);
                }
            }
        }
    }
    v
}

/// The cells a level's splats can touch (3³ around each splatting sample).
fn splat_cells(samples: &Samples, plan: &[(u32, f32)], lv: u32) -> BitGrid {
    let res = 1i32 << lv;
    let mut g = BitGrid::new();
    for &(i, _) in plan {
        let p = samples.pos[i as usize];
        let c = [
            ((p[0] * res as f64).floor() as i32).clamp(0, res - 1),
            ((p[1] * res as f64).floor() as i32).clamp(0, res - 1),
            ((p[2] * res as f64).floor() as i32).clamp(0, res - 1),
        ];
        g.insert(c);
    }
    let mut g = g.dilate(1, 1);
    g.clip([0; 3], [res - 1; 3]);
    g
}

/// Records the level's virtual screening samples (one per occupied cell whose
/// corners are all valid). `alpha_area` is α·ā.
fn add_screening(lev: &mut Level, samples: &Samples, d: u32, alpha_area: f64) {
    if alpha_area <= 0.0 {
        return;
    }
    let shift = 3 * (d - lev.depth);
    let res = lev.res;
    // ω = α·ā·W·2^ℓ as PoissonRecon's `InitializeApproximatePointInterpolationInfo`
    // (adaptive exponent 1), with ā the mean of the samples' areas 4^-d.
    let scale = alpha_area * res as f64;
    samples.for_each_cell(shift, |w, c| {
        let t = [c[0] * res as f64, c[1] * res as f64, c[2] * res as f64];
        let cell = [
            (t[0].floor() as i32).clamp(0, res - 1),
            (t[1].floor() as i32).clamp(0, res - 1),
            (t[2].floor() as i32).clamp(0, res - 1),
        ];
        let corners_valid = (0..8).all(|k| {
            lev.is_valid([
                cell[0] + (k & 1),
                cell[1] + ((k >> 1) & 1),
                cell[2] + (k >> 2),
            ])
        });
        if !corners_valid {
            return;
        }
        let f = [
            (t[0] - cell[0] as f64).clamp(0.0, 1.0),
            (t[1] - cell[1] as f64).clamp(0.0, 1.0),
            (t[2] - cell[2] as f64).clamp(0.0, 1.0),
        ];
        let omega = scale * w;
        let bi = lev
            .bricks
            .get(brick_of(cell))
            .expect("valid corner has a brick");
        lev.screen[bi].push(ScreenCell {
            local: local_index(cell) as u16,
            w: omega as f32,
            f: [f[0] as f32, f[1] as f32, f[2] as f32],
        });
    });
}

/// Adds the screening target (χ = ½ at every virtual sample) to the level's
/// right-hand side at its active nodes.
fn add_screening_target(lev: &mut Level) {
    for bi in 0..lev.screen.len() {
        let b = lev.bricks.coords[bi];
        for sc in &lev.screen[bi] {
            let l = sc.local as i32;
            let cell = [
                b[0] * BS + (l & 7),
                b[1] * BS + ((l >> 3) & 7),
                b[2] * BS + (l >> 6),
            ];
            for k in 0..8i32 {
                let q = [
                    cell[0] + (k & 1),
                    cell[1] + ((k >> 1) & 1),
                    cell[2] + (k >> 2),
                ];
                let qb = lev
                    .bricks
                    .get(brick_of(q))
                    .expect("screened cells have valid corners");
                let ql = local_index(q);
                if mask_has(&lev.active[qb], ql) {
                    lev.b[qb * BRICK_LEN + ql] += 0.5 * sc.w * corner_weight(sc.f, k) as f32;
                }
            }
        }
    }
}

/// Trilinear weight of corner `k` (bit 0 = x, 1 = y, 2 = z) at `f` ∈ [0,1]³.
#[inline]
fn corner_weight<T: Into<f64> + Copy>(f: [T; 3], k: i32) -> f64 {
    let s = |v: T, bit: i32| if bit == 1 { v.into() } else { 1.0 - v.into() };
    s(f[0], k & 1) * s(f[1], (k >> 1) & 1) * s(f[2], k >> 2)
}

/// ⟨∇B_i, W⟩ at the active nodes of `lev` for a degree-2 vector field W on
/// the level's cells, read through `gather` (cell box → values). Separable:
/// each component is filtered along x, y, z with the 1-D value/derivative
/// tables of the node's side.
fn integrate_level(
    bricks: &Bricks,
    active: &[Mask],
    res: i32,
    t: &Tables,
    out: &mut [f32],
    gather: impl Fn([i32; 3], [usize; 3], &mut [[f32; 3]]) + Sync,
) {
    let h2 = (1.0 / res as f64).powi(2) as f32;
    out.par_chunks_mut(BRICK_LEN)
        .enumerate()
        .for_each(|(bi, ob)| {
            if active[bi].iter().all(|&w| w == 0) {
                return;
            }
            let b = bricks.coords[bi];
            let o = [b[0] * BS, b[1] * BS, b[2] * BS];
            const N: usize = 11; // cells o-2 ..= o+8
            let mut v = vec![[0.0f32; 3]; N * N * N];
            gather([o[0] - 2, o[1] - 2, o[2] - 2], [N, N, N], &mut v);
            if v.iter().all(|c| c.iter().all(|&x| x == 0.0)) {
                return;
            }
            let side = |axis: usize, n: usize| NodeSide::of(o[axis] + n as i32, res) as usize;
            let mut acc = [0.0f32; BRICK_LEN];
            for comp in 0..3 {
                let tab = |axis: usize, s: usize| -> [f32; 4] {
                    let r = if axis == comp { &t.der[s] } else { &t.val[s] };
                    [r[0] as f32, r[1] as f32, r[2] as f32, r[3] as f32]
                };
                // x pass: N×N×8
                let mut a = vec![0.0f32; N * N * 8];
                for z in 0..N {
                    for y in 0..N {
                        let row = &v[(z * N + y) * N..(z * N + y) * N + N];
                        for x in 0..8 {
                            let tb = tab(0, side(0, x));
                            let mut s = 0.0;
                            for (k, tk) in tb.iter().enumerate() {
                                s += row[x + k][comp] * tk;
                            }
                            a[(z * N + y) * 8 + x] = s;
                        }
                    }
                }
                // y pass: N×8×8
                let mut bb = vec![0.0f32; N * 64];
                for z in 0..N {
                    for y in 0..8 {
                        let tb = tab(1, side(1, y));
                        for x in 0..8 {
                            let mut s = 0.0;
                            for (k, tk) in tb.iter().enumerate() {
                                s += a[(z * N + y + k) * 8 + x] * tk;
                            }
                            bb[(z * 8 + y) * 8 + x] = s;
                        }
                    }
                }
                // z pass: 8×8×8
                for z in 0..8 {
                    let tb = tab(2, side(2, z));
                    for y in 0..8 {
                        for x in 0..8 {
                            let mut s = 0.0;
                            for (k, tk) in tb.iter().enumerate() {
                                s += bb[((z + k) * 8 + y) * 8 + x] * tk;
                            }
                            acc[(z * 8 + y) * 8 + x] += s;
                        }
                    }
                }
            }
            let m = &active[bi];
            for (l, (dst, src)) in ob.iter_mut().zip(acc.iter()).enumerate() {
                if mask_has(m, l) {
                    *dst += src * h2;
                }
            }
        });
}

/// Restriction of the finer level's right-hand side onto the active nodes of
/// `lev` (added to its `b`): a coarse hat is the fine hats at 2N (weight 1)
/// and 2N±1 (½) per axis.
fn restrict(lev: &mut Level, fine: &Level) {
    let (bricks, active) = (&lev.bricks, &lev.active);
    lev.b
        .par_chunks_mut(BRICK_LEN)
        .enumerate()
        .for_each(|(bi, ob)| {
            if active[bi].iter().all(|&w| w == 0) {
                return;
            }
            let b = bricks.coords[bi];
            let lo = [2 * b[0] * BS - 1, 2 * b[1] * BS - 1, 2 * b[2] * BS - 1];
            const N: usize = 17;
            let mut f = vec![0.0f32; N * N * N];
            fine.bricks.gather(&fine.b, lo, [N, N, N], &mut f, 0.0);
            if f.iter().all(|&x| x == 0.0) {
                return;
            }
            // separable: x, y, z passes with taps (½, 1, ½) at 2n-1, 2n, 2n+1
            let mut a = vec![0.0f32; N * N * 8];
            for zy in 0..N * N {
                for x in 0..8 {
                    let r = &f[zy * N + 2 * x..zy * N + 2 * x + 3];
                    a[zy * 8 + x] = 0.5 * r[0] + r[1] + 0.5 * r[2];
                }
            }
            let mut c = vec![0.0f32; N * 64];
            for z in 0..N {
                for y in 0..8 {
                    for x in 0..8 {
                        let at = |yy: usize| a[(z * N + yy) * 8 + x];
                        c[(z * 8 + y) * 8 + x] =
                            0.5 * at(2 * y) + at(2 * y + 1) + 0.5 * at(2 * y + 2);
                    }
                }
            }
            let m = &active[bi];
            for z in 0..8 {
                for y in 0..8 {
                    for x in 0..8 {
                        let at = |zz: usize| c[(zz * 8 + y) * 8 + x];
                        let l = (z * 8 + y) * 8 + x;
                        if mask_has(m, l) {
                            ob[l] += 0.5 * at(2 * z) + at(2 * z + 1) + 0.5 * at(2 * z + 2);
                        }
                    }
                }
            }
        });
}

/// Sets `lev.y` at its valid nodes to the prolonged accumulated solution of
/// `prev` (exact: trilinear interpolation of the coarse node values).
fn prolong_solution(prev: &Level, lev: &mut Level) {
    let bricks = &lev.bricks;
    let valid = &lev.valid;
    lev.y
        .par_chunks_mut(BRICK_LEN)
        .enumerate()
        .for_each(|(bi, yb)| {
            let b = bricks.coords[bi];
            let lo = [b[0] * 4, b[1] * 4, b[2] * 4];
            let mut c = [0.0f32; 125];
            prev.bricks.gather(&prev.y, lo, [5, 5, 5], &mut c, f32::NAN);
            let m = &valid[bi];
            for z in 0..8usize {
                for y in 0..8usize {
                    for x in 0..8usize {
                        let l = (z * 8 + y) * 8 + x;
                        if !mask_has(m, l) {
                            yb[l] = f32::NAN;
                            continue;
                        }
                        let taps = |n: usize| -> [(usize, f32); 2] {
                            if n.is_multiple_of(2) {
                                [(n / 2, 1.0), (n / 2, 0.0)]
                            } else {
                                [(n / 2, 0.5), (n / 2 + 1, 0.5)]
                            }
                        };
                        let mut s = 0.0f32;
                        for (cz, wz) in taps(z) {
                            if wz == 0.0 {
                                continue;
                            }
                            for (cy, wy) in taps(y) {
                                if wy == 0.0 {
                                    continue;
                                }
                                for (cx, wx) in taps(x) {
                                    if wx == 0.0 {
                                        continue;
                                    }
                                    s += wx * wy * wz * c[(cz * 5 + cy) * 5 + cx];
                                }
                            }
                        }
                        yb[l] = s;
                    }
                }
            }
        });
}

/// The right-hand side contribution of the coarser accumulated normal field
/// `vacc` (degree-2 coefficients on `prev`'s bricks) at `lev`'s active nodes,
/// added to its `b`, and, when `keep`, the accumulated field of `lev` (prolonged + own).
fn coarse_field_rhs(
    prev: &Level,
    vacc: &[[f32; 3]],
    lev: &mut Level,
    t: &Tables,
    own: &VLevel,
    keep: bool,
) -> Vec<[f32; 3]> {
    // Prolong one box of fine cells from the coarse accumulated field.
    let prolong_box = |lo: [i32; 3], dims: [usize; 3], out: &mut [[f32; 3]]| {
        let clo = [(lo[0] >> 1) - 1, (lo[1] >> 1) - 1, (lo[2] >> 1) - 1];
        let cd = [dims[0] / 2 + 3, dims[1] / 2 + 3, dims[2] / 2 + 3];
        let mut c = vec![[0.0f32; 3]; cd[0] * cd[1] * cd[2]];
        prev.bricks.gather(vacc, clo, cd, &mut c, [0.0; 3]);
        // taps of fine cell j: parent J (¾) and J-1 (even j) or J+1 (odd j) (¼)
        let taps = |j: i32, axis: usize| -> [(usize, f32); 2] {
            let jj = j >> 1;
            let other = if j & 1 == 0 { jj - 1 } else { jj + 1 };
            [
                ((jj - clo[axis]) as usize, 0.75),
                ((other - clo[axis]) as usize, 0.25),
            ]
        };
        // separable passes
        let mut ax = vec![[0.0f32; 3]; cd[2] * cd[1] * dims[0]];
        for zy in 0..cd[2] * cd[1] {
            for x in 0..dims[0] {
                let mut s = [0.0f32; 3];
                for (cx, w) in taps(lo[0] + x as i32, 0) {
                    let v = c[zy * cd[0] + cx];
                    for k in 0..3 {
                        s[k] += w * v[k];
                    }
                }
                ax[zy * dims[0] + x] = s;
            }
        }
        let mut ay = vec![[0.0f32; 3]; cd[2] * dims[1] * dims[0]];
        for z in 0..cd[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let mut s = [0.0f32; 3];
                    for (cy, w) in taps(lo[1] + y as i32, 1) {
                        let v = ax[(z * cd[1] + cy) * dims[0] + x];
                        for k in 0..3 {
                            s[k] += w * v[k];
                        }
                    }
                    ay[(z * dims[1] + y) * dims[0] + x] = s;
                }
            }
        }
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let mut s = [0.0f32; 3];
                    for (cz, w) in taps(lo[2] + z as i32, 2) {
                        let v = ay[(cz * dims[1] + y) * dims[0] + x];
                        for k in 0..3 {
                            s[k] += w * v[k];
                        }
                    }
                    out[(z * dims[1] + y) * dims[0] + x] = s;
                }
            }
        }
    };
    integrate_level(
        &lev.bricks,
        &lev.active,
        lev.res,
        t,
        &mut lev.b,
        prolong_box,
    );
    if keep {
        let mut next = vec![[0.0f32; 3]; lev.bricks.len() * BRICK_LEN];
        next.par_chunks_mut(BRICK_LEN)
            .enumerate()
            .for_each(|(bi, nb)| {
                let b = lev.bricks.coords[bi];
                let lo = [b[0] * BS, b[1] * BS, b[2] * BS];
                prolong_box(lo, [8, 8, 8], nb);
                let mut o = vec![[0.0f32; 3]; BRICK_LEN];
                own.gather(lo, [8, 8, 8], &mut o);
                for (a, b) in nb.iter_mut().zip(&o) {
                    for k in 0..3 {
                        a[k] += b[k];
                    }
                }
            });
        next
    } else {
        Vec::new()
    }
}

/// The 27-point Laplacian stencils of a level for each combination of node
/// sides (index sx + 3 sy + 9 sz), entries indexed (ox+1) + 3(oy+1) + 9(oz+1).
fn stencils(t: &Tables, res: i32) -> Vec<[f32; 27]> {
    let h = 1.0 / res as f64;
    let mut out = vec![[0.0f32; 27]; 27];
    for (si, st) in out.iter_mut().enumerate() {
        let s = [si % 3, (si / 3) % 3, si / 9];
        for (oi, e) in st.iter_mut().enumerate() {
            let o = [oi % 3, (oi / 3) % 3, oi / 9];
            let m = |a: usize| t.mass[s[a]][o[a]];
            let k = |a: usize| t.stiff[s[a]][o[a]];
            *e = (h * (k(0) * m(1) * m(2) + m(0) * k(1) * m(2) + m(0) * m(1) * k(2))) as f32;
        }
    }
    out
}

/// One Gauss–Seidel sweep over the active nodes: bricks in 8 colours by brick
/// parity (same-coloured bricks never touch, so they run in parallel), nodes
/// in lexicographic order inside a brick. The order does not depend on the
/// thread count.
fn gauss_seidel_sweep(lev: &mut Level, st: &[[f32; 27]]) {
    let res = lev.res;
    for colour in 0..8 {
        let ids: Vec<usize> = (0..lev.bricks.len())
            .filter(|&bi| {
                let b = lev.bricks.coords[bi];
                ((b[0] & 1) | ((b[1] & 1) << 1) | ((b[2] & 1) << 2)) == colour
                    && lev.active[bi].iter().any(|&w| w != 0)
            })
            .collect();
        let lv = &*lev;
        let updates: Vec<(usize, Box<[f32; BRICK_LEN]>)> = ids
            .par_iter()
            .map(|&bi| (bi, relax_brick(lv, bi, st, res)))
            .collect();
        for (bi, v) in updates {
            let m = lev.active[bi];
            let yb = &mut lev.y[bi * BRICK_LEN..(bi + 1) * BRICK_LEN];
            for (l, (dst, src)) in yb.iter_mut().zip(v.iter()).enumerate() {
                if mask_has(&m, l) {
                    *dst = *src;
                }
            }
        }
    }
}

const P: usize = 10; // padded brick side (nodes o-1 ..= o+8)

fn relax_brick(lev: &Level, bi: usize, st: &[[f32; 27]], res: i32) -> Box<[f32; BRICK_LEN]> {
    let b = lev.bricks.coords[bi];
    let o = [b[0] * BS, b[1] * BS, b[2] * BS];
    let mut y = vec![0.0f32; P * P * P];
    lev.bricks.gather(
        &lev.y,
        [o[0] - 1, o[1] - 1, o[2] - 1],
        [P, P, P],
        &mut y,
        0.0,
    );
    // Invalid nodes (NaN) only sit outside the domain next to boundary
    // nodes, where the stencil weight is zero.
    for v in y.iter_mut() {
        if v.is_nan() {
            *v = 0.0;
        }
    }
    // Screening cells with lower corner in o-1 ..= o+7 (9³), dense.
    const C: usize = 9;
    let mut cw = vec![0.0f32; C * C * C];
    let mut cf = vec![[0.0f32; 3]; C * C * C];
    let mut any_screen = false;
    for dz in -1..=0 {
        for dy in -1..=0 {
            for dx in -1..=0 {
                let Some(nb) = lev.bricks.get([b[0] + dx, b[1] + dy, b[2] + dz]) else {
                    continue;
                };
                for sc in &lev.screen[nb] {
                    let l = sc.local as i32;
                    let g = [
                        (b[0] + dx) * BS + (l & 7),
                        (b[1] + dy) * BS + ((l >> 3) & 7),
                        (b[2] + dz) * BS + (l >> 6),
                    ];
                    let r = [g[0] - o[0] + 1, g[1] - o[1] + 1, g[2] - o[2] + 1];
                    if r.iter().all(|&v| (0..C as i32).contains(&v)) {
                        let ci = (r[0] + C as i32 * (r[1] + C as i32 * r[2])) as usize;
                        cw[ci] = sc.w;
                        cf[ci] = sc.f;
                        any_screen = true;
                    }
                }
            }
        }
    }
    let mask = &lev.active[bi];
    let rhs = &lev.b[bi * BRICK_LEN..(bi + 1) * BRICK_LEN];
    for z in 0..8usize {
        let sz = NodeSide::of(o[2] + z as i32, res) as usize;
        for yy in 0..8usize {
            let sy = NodeSide::of(o[1] + yy as i32, res) as usize;
            for x in 0..8usize {
                let l = (z * 8 + yy) * 8 + x;
                if !mask_has(mask, l) {
                    continue;
                }
                let sx = NodeSide::of(o[0] + x as i32, res) as usize;
                let s = &st[sx + 3 * sy + 9 * sz];
                let pi = (x + 1) + P * ((yy + 1) + P * (z + 1));
                let mut sum = 0.0f32;
                for oz in 0..3 {
                    for oy in 0..3 {
                        let base = x + P * ((yy + oy) + P * (z + oz));
                        let sb = 3 * oy + 9 * oz;
                        sum += s[sb] * y[base] + s[sb + 1] * y[base + 1] + s[sb + 2] * y[base + 2];
                    }
                }
                let mut diag = s[13];
                sum -= diag * y[pi];
                if any_screen {
                    // cells whose corner k is this node: lower corner = node - bits(k)
                    for k in 0..8i32 {
                        let cx = x as i32 + 1 - (k & 1);
                        let cy = yy as i32 + 1 - ((k >> 1) & 1);
                        let cz = z as i32 + 1 - (k >> 2);
                        let ci = (cx + C as i32 * (cy + C as i32 * cz)) as usize;
                        let w = cw[ci];
                        if w == 0.0 {
                            continue;
                        }
                        let f = cf[ci];
                        let cpi = (cx as usize) + P * ((cy as usize) + P * (cz as usize));
                        let mut chi = 0.0f32;
                        let mut bi_self = 0.0f32;
                        for q in 0..8i32 {
                            let beta = corner_weight(f, q) as f32;
                            let qi = cpi
                                + (q & 1) as usize
                                + P * (((q >> 1) & 1) as usize + P * (q >> 2) as usize);
                            if q == k {
                                bi_self = beta;
                            } else {
                                chi += beta * y[qi];
                            }
                        }
                        sum += w * bi_self * chi;
                        diag += w * bi_self * bi_self;
                    }
                }
                y[pi] = (rhs[l] - sum) / diag;
            }
        }
    }
    let mut out = Box::new([0.0f32; BRICK_LEN]);
    for z in 0..8 {
        for yy in 0..8 {
            for x in 0..8 {
                out[(z * 8 + yy) * 8 + x] = y[(x + 1) + P * ((yy + 1) + P * (z + 1))];
            }
        }
    }
    out
}

/// χ at a unit-cube point: trilinear interpolation on the finest level whose
/// cell around the point has all eight corners valid. `None` outside the cube.
pub fn eval(levels: &[Level], p: [f64; 3]) -> Option<f64> {
    if p.iter().any(|&c| !(0.0..=1.0).contains(&c)) {
        return None;
    }
    for lev in levels.iter().rev() {
        let r = lev.res as f64;
        let t = [p[0] * r, p[1] * r, p[2] * r];
        let c = [
            (t[0].floor() as i32).clamp(0, lev.res - 1),
            (t[1].floor() as i32).clamp(0, lev.res - 1),
            (t[2].floor() as i32).clamp(0, lev.res - 1),
        ];
        let f = [t[0] - c[0] as f64, t[1] - c[1] as f64, t[2] - c[2] as f64];
        let mut s = 0.0;
        let mut ok = true;
        for k in 0..8i32 {
            match lev.value([c[0] + (k & 1), c[1] + ((k >> 1) & 1), c[2] + (k >> 2)]) {
                Some(v) => s += corner_weight(f, k) * v as f64,
                None => {
                    ok = false;
                    break;
                }
            }
        }
        if ok {
            return Some(s);
        }
    }
    None
}

/// The finest depth whose cell around unit-cube point `p` has all eight
/// corners active: the depth at which the solver represents the surface
/// there (PoissonRecon's leaf depth, up to the width of the active band).
pub fn support_level(levels: &[Level], p: [f64; 3]) -> u32 {
    for lev in levels.iter().rev() {
        let r = lev.res as f64;
        let c = [
            ((p[0] * r).floor() as i32).clamp(0, lev.res - 1),
            ((p[1] * r).floor() as i32).clamp(0, lev.res - 1),
            ((p[2] * r).floor() as i32).clamp(0, lev.res - 1),
        ];
        let all = (0..8i32).all(|k| {
            let q = [c[0] + (k & 1), c[1] + ((k >> 1) & 1), c[2] + (k >> 2)];
            lev.bricks
                .get(brick_of(q))
                .is_some_and(|bi| mask_has(&lev.active[bi], local_index(q)))
        });
        if all {
            return lev.depth;
        }
    }
    0
}
