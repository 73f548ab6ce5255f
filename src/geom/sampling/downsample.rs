//! Greedy radius downsampling (Poisson-disk thinning) of point sets, and the
//! seeded permutation that drives it.
//!
//! [`greedy_radius_downsample`] reproduces step 4 of DTUeval-python `eval.py`
//! (the MATLAB `reducePts_haa`): walk the points in a (shuffled) order and
//! keep a point iff no already-kept point lies within distance `<= r`. The
//! reference materialises every radius-neighbour list with sklearn; here an
//! incremental hash grid of the kept points is used, so memory is O(kept).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hash, Hasher};

use rand::RngExt;

use crate::model::rng;
use crate::{Error, Result};

/// Integer block coordinates, hashed by a multiplicative mix.
#[derive(Clone, Copy, PartialEq, Eq)]
struct Cell([i64; 3]);

impl Hash for Cell {
    fn hash<H: Hasher>(&self, state: &mut H) {
        let [x, y, z] = self.0.map(|c| c as u64);
        let mut h = x.wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ y.wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ z.wrapping_mul(0x1656_67B1_9E37_79F9);
        h ^= h >> 29;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 32;
        state.write_u64(h);
    }
}

/// Passes the already-mixed `u64` of [`Cell`] through.
#[derive(Default)]
struct PassHasher(u64);

impl Hasher for PassHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ u64::from(b)).wrapping_mul(0x100_0000_01B3);
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = v;
    }
}

/// Squared distance with the terms summed x, y, z in order, as sklearn's
/// Euclidean reduced distance.
#[inline]
fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let (dx, dy, dz) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    dx * dx + dy * dy + dz * dz
}

/// Side of a grid block, in units of `r`. Each query box (side `2r`)
/// overlaps about `(1 + 2/BLOCK_FACTOR)³ ≈ 3.4` blocks, and the kept points of
/// a block sit together in memory, so a query costs a few hash probes and a
/// contiguous scan instead of 27 scattered probes.
const BLOCK_FACTOR: f64 = 4.0;

/// Greedy radius downsampling: walks `points[order[0]], points[order[1]], …`
/// and keeps a point iff no point kept before it lies within Euclidean
/// distance `<= r` (boundary included, the test being `dx²+dy²+dz² <= r²` in
/// f64, as sklearn's `radius_neighbors`). Returns the kept indices (into
/// `points`) in walk order.
///
/// This is DTU step 4 (`reducePts_haa`, `r = 0.2` mm): the reference's "kill
/// all neighbours of each surviving point" walk keeps exactly the same
/// points. Indices repeated in `order` are visited again and dropped (a point
/// is within 0 of itself). `r = 0` drops exact duplicates only.
///
/// Kept points are stored in an incremental hash grid of blocks of side `4r`
/// (each block holding its kept points contiguously); a query scans the
/// blocks covering `p ± r` on every axis — the 3×3×3 neighbourhood of cells
/// of side `r` is always inside them — widened by a floating-point margin so
/// no kept neighbour is ever missed, whatever the coordinate magnitude.
/// Memory is O(kept); nothing is stored for dropped points and no neighbour
/// list is built.
///
/// Errors: `r` negative or not finite; an `order` entry out of range; a point
/// with a NaN or infinite coordinate (named by index) reached by the walk.
pub fn greedy_radius_downsample(
    points: &[[f64; 3]],
    order: &[usize],
    r: f64,
) -> Result<Vec<usize>> {
    if r > 0.0
        && r.is_finite()
        && order.len() == points.len()
        && order.len() >= ROUNDS_MIN_POINTS
        && let Some(kept) = rounds::downsample(points, order, r)?
    {
        return Ok(kept);
    }
    sequential_walk(points, order, r)
}

/// Inputs smaller than this use the sequential walk directly.
const ROUNDS_MIN_POINTS: usize = 50_000;

/// The walk of [`greedy_radius_downsample`], one point after the other.
fn sequential_walk(points: &[[f64; 3]], order: &[usize], r: f64) -> Result<Vec<usize>> {
    if !(r >= 0.0 && r.is_finite()) {
        return Err(Error::invalid(format!(
            "downsampling radius must be finite and >= 0, got {r}"
        )));
    }
    let mut grid = KeptGrid::new(r);
    let mut kept: Vec<usize> = Vec::new();
    for (walk, &idx) in order.iter().enumerate() {
        let Some(p) = points.get(idx) else {
            return Err(Error::invalid(format!(
                "order entry {walk} is {idx}, but there are {} points",
                points.len()
            )));
        };
        if p.iter().any(|c| !c.is_finite()) {
            return Err(Error::invalid(format!(
                "point {idx} has a non-finite coordinate: {p:?}"
            )));
        }
        if !grid.near(p) {
            grid.insert(p);
            kept.push(idx);
        }
    }
    Ok(kept)
}

/// The kept points, bucketed in blocks of side `BLOCK_FACTOR·r`.
struct KeptGrid {
    r: f64,
    r2: f64,
    block_size: f64,
    blocks: HashMap<Cell, Vec<[f64; 3]>, BuildHasherDefault<PassHasher>>,
}

impl KeptGrid {
    fn new(r: f64) -> Self {
        KeptGrid {
            r,
            r2: r * r,
            block_size: if r > 0.0 { r * BLOCK_FACTOR } else { 1.0 },
            blocks: HashMap::default(),
        }
    }

    /// Block index along one axis. `as i64` saturates, which keeps the map
    /// monotone in x, so the covering-range argument of [`Self::near`] holds
    /// for huge coordinates too.
    #[inline]
    fn block_of(&self, x: f64) -> i64 {
        (x / self.block_size).floor() as i64
    }

    #[inline]
    fn home(&self, p: &[f64; 3]) -> Cell {
        Cell(p.map(|x| self.block_of(x)))
    }

    /// True when a stored point q has `dist2(p, q) <= r²`.
    fn near(&self, p: &[f64; 3]) -> bool {
        let near_in = |cell: &Cell| {
            self.blocks
                .get(cell)
                .is_some_and(|pts| pts.iter().any(|q| dist2(p, q) <= self.r2))
        };
        // The home block first: it holds the nearest kept points most often.
        let home = self.home(p);
        if near_in(&home) {
            return true;
        }
        // Any q with computed dist2 <= r² has |q_a − p_a| <= r(1 + 4ε) per
        // axis; the margin covers that and the rounding of p ± reach, so
        // q's block lies in [block(p − reach), block(p + reach)] (floor and
        // division are monotone).
        let range = |a: usize| {
            let reach = self.r + (self.r + p[a].abs()) * 1e-9;
            self.block_of(p[a] - reach)..=self.block_of(p[a] + reach)
        };
        for bx in range(0) {
            for by in range(1) {
                for bz in range(2) {
                    let cell = Cell([bx, by, bz]);
                    if cell != home && near_in(&cell) {
                        return true;
                    }
                }
            }
        }
        false
    }

    fn insert(&mut self, p: &[f64; 3]) {
        let home = self.home(p);
        self.blocks.entry(home).or_default().push(*p);
    }
}

/// A uniformly random permutation of `0..n`, reproducible from `seed`:
/// Fisher–Yates from the back (`for i in (1..n).rev()`, swap `i` with a
/// uniform `j` in `0..=i`) driven by [`rng::seeded`]`(seed)`.
/// This replaces the reference's unseeded `np.random.default_rng().shuffle`
/// (DTU step 3), so downsampling results are repeatable.
pub fn seeded_permutation(n: usize, seed: u64) -> Vec<usize> {
    let mut perm: Vec<usize> = (0..n).collect();
    let mut rng = rng::seeded(seed);
    for i in (1..n).rev() {
        let j = rng.random_range(0..=i);
        perm.swap(i, j);
    }
    perm
}

/// The same result as the sequential walk, computed in spatial order.
///
/// The walk keeps a point iff every point of lower rank (earlier in the walk)
/// within r was dropped: the lexicographically-first maximal independent set
/// of the "within r" graph. It is computed in rounds over the points sorted
/// by 4r-block along a Morton curve (so neighbours are close in memory): in a
/// round, an undecided point is dropped when the first non-dropped
/// lower-rank neighbour it meets is kept, waits when that neighbour is still
/// undecided, and is kept when it has none. Each
/// round reads only the state at its start, so it runs in parallel and
/// deterministically. For a random walk order the rounds shrink fast; after
/// [`MAX_ROUNDS`] whatever is left is finished one point at a time in walk
/// order (every lower-rank point is decided by then), so adversarial orders
/// stay correct and never quadratic in rounds.
mod rounds {
    use std::collections::HashMap;
    use std::hash::BuildHasherDefault;

    use rayon::prelude::*;

    use super::{Cell, PassHasher, dist2};
    use crate::{Error, Result};

    const UNDECIDED: u8 = 0;
    const KEPT: u8 = 1;
    const DROPPED: u8 = 2;
    pub(super) const MAX_ROUNDS: usize = 48;

    /// 21-bit interleave.
    fn spread(mut x: u64) -> u64 {
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    }

    /// `None` when `order` is not a permutation or the cloud spans more
    /// blocks than a Morton key holds (the caller then walks sequentially).
    pub(super) fn downsample(
        points: &[[f64; 3]],
        order: &[usize],
        r: f64,
    ) -> Result<Option<Vec<usize>>> {
        let n = points.len();
        let mut rank = vec![u32::MAX; n];
        for (k, &i) in order.iter().enumerate() {
            if i >= n || rank[i] != u32::MAX {
                return Ok(None);
            }
            rank[i] = k as u32;
        }
        if let Some(i) = points.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(Error::invalid(format!(
                "point {i} has a non-finite coordinate: {:?}",
                points[i]
            )));
        }
        let size = r * super::BLOCK_FACTOR;
        let block = |p: &[f64; 3]| p.map(|x| (x / size).floor() as i64);
        let mut lo = [i64::MAX; 3];
        let mut hi = [i64::MIN; 3];
        for p in points {
            let b = block(p);
            for a in 0..3 {
                lo[a] = lo[a].min(b[a]);
                hi[a] = hi[a].max(b[a]);
            }
        }
        if (0..3).any(|a| hi[a] - lo[a] >= 1 << 21) {
            return Ok(None);
        }
        let morton = |b: [i64; 3]| {
            spread((b[0] - lo[0]) as u64)
                | spread((b[1] - lo[1]) as u64) << 1
                | spread((b[2] - lo[2]) as u64) << 2
        };
        let mut sorted: Vec<(u64, u32)> = points
            .par_iter()
            .enumerate()
            .map(|(i, p)| (morton(block(p)), i as u32))
            .collect();
        sorted.par_sort_unstable();
        let pts: Vec<[f64; 3]> = sorted
            .par_iter()
            .map(|&(_, i)| points[i as usize])
            .collect();
        let rk: Vec<u32> = sorted.par_iter().map(|&(_, i)| rank[i as usize]).collect();
        let mut blocks: HashMap<Cell, (u32, u32), BuildHasherDefault<PassHasher>> =
            HashMap::default();
        let mut start = 0usize;
        while start < n {
            let key = sorted[start].0;
            let mut end = start + 1;
            while end < n && sorted[end].0 == key {
                end += 1;
            }
            blocks.insert(Cell(block(&pts[start])), (start as u32, end as u32));
            start = end;
        }
        let r2 = r * r;
        let mut state = vec![UNDECIDED; n];
        // Decision for sorted position i given `state`.
        let decide = |i: usize, state: &[u8]| -> u8 {
            let p = &pts[i];
            let rp = rk[i];
            let range = |a: usize| {
                let reach = r + (r + p[a].abs()) * 1e-9;
                ((p[a] - reach) / size).floor() as i64..=((p[a] + reach) / size).floor() as i64
            };
            for bx in range(0) {
                for by in range(1) {
                    for bz in range(2) {
                        let Some(&(s, e)) = blocks.get(&Cell([bx, by, bz])) else {
                            continue;
                        };
                        for j in s as usize..e as usize {
                            let st = state[j];
                            if st == DROPPED || rk[j] >= rp || dist2(p, &pts[j]) > r2 {
                                continue;
                            }
                            // A kept lower-rank neighbour drops p; an undecided
                            // one makes p wait a round (stopping here may only
                            // postpone p's decision, never change it).
                            return if st == KEPT { DROPPED } else { UNDECIDED };
                        }
                    }
                }
            }
            KEPT
        };
        let mut undecided: Vec<u32> = (0..n as u32).collect();
        for _ in 0..MAX_ROUNDS {
            if undecided.is_empty() {
                break;
            }
            let snapshot = &state;
            let decisions: Vec<u8> = undecided
                .par_iter()
                .with_min_len(4096)
                .map(|&i| decide(i as usize, snapshot))
                .collect();
            for (&i, &d) in undecided.iter().zip(&decisions) {
                state[i as usize] = d;
            }
            undecided.retain(|&i| state[i as usize] == UNDECIDED);
        }
        // Whatever is left, in walk order: every lower-rank point is decided
        // when its turn comes.
        undecided.sort_unstable_by_key(|&i| rk[i as usize]);
        for &i in &undecided {
            let d = decide(i as usize, &state);
            state[i as usize] = if d == UNDECIDED { KEPT } else { d };
        }
        let mut kept: Vec<(u32, usize)> = (0..n)
            .filter(|&i| state[i] == KEPT)
            .map(|i| (rk[i], sorted[i].1 as usize))
            .collect();
        kept.par_sort_unstable();
        Ok(Some(kept.into_iter().map(|(_, i)| i).collect()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_pcg::Pcg64Mcg;

    /// The same walk by brute force: compare with every kept point.
    fn brute(points: &[[f64; 3]], order: &[usize], r: f64) -> Vec<usize> {
        let mut kept: Vec<usize> = Vec::new();
        for &i in order {
            if kept.iter().all(|&k| dist2(&points[i], &points[k]) > r * r) {
                kept.push(i);
            }
        }
        kept
    }

    /// The greedy invariants, checked by brute force: kept points are pairwise
    /// farther than r, and each dropped point is within r of a kept one.
    fn check_invariants(points: &[[f64; 3]], kept: &[usize], r: f64) {
        for (a, &i) in kept.iter().enumerate() {
            for &j in &kept[a + 1..] {
                assert!(
                    dist2(&points[i], &points[j]) > r * r,
                    "kept {i} and {j} within r"
                );
            }
        }
        let mut is_kept = vec![false; points.len()];
        kept.iter().for_each(|&k| is_kept[k] = true);
        for (i, p) in points.iter().enumerate().filter(|&(i, _)| !is_kept[i]) {
            assert!(
                kept.iter().any(|&k| dist2(p, &points[k]) <= r * r),
                "dropped {i} has no kept neighbour"
            );
        }
    }

    fn uniform_cloud(rng: &mut Pcg64Mcg, n: usize, lo: f64, hi: f64) -> Vec<[f64; 3]> {
        (0..n)
            .map(|_| {
                [
                    rng.random_range(lo..hi),
                    rng.random_range(lo..hi),
                    rng.random_range(lo..hi),
                ]
            })
            .collect()
    }

    #[test]
    fn equals_brute_force_on_random_clouds() {
        let mut rng = Pcg64Mcg::seed_from_u64(1);
        for (trial, &(n, lo, hi, r)) in [
            (3000, 0.0, 5.0, 0.2),
            (3000, -1.0, 1.0, 0.2),
            (2000, 0.0, 1.0, 0.05),
            (1500, 0.0, 10.0, 1.3),
            // Far from the origin: cell indices ~5e6, margins matter.
            (2000, 1.0e6, 1.0e6 + 4.0, 0.2),
            (500, 0.0, 1.0, 10.0),
        ]
        .iter()
        .enumerate()
        {
            let pts = uniform_cloud(&mut rng, n, lo, hi);
            let order = seeded_permutation(n, trial as u64);
            let kept = greedy_radius_downsample(&pts, &order, r).unwrap();
            assert_eq!(kept, brute(&pts, &order, r), "trial {trial}");
            assert!(
                !kept.is_empty() && kept.len() < n || r == 0.05,
                "trial {trial}: no thinning"
            );
            check_invariants(&pts, &kept, r);
        }
    }

    #[test]
    fn clustered_and_duplicated_points() {
        let mut rng = Pcg64Mcg::seed_from_u64(2);
        let mut pts = Vec::new();
        // Tight clusters (spread 0.1 < r), each centre also repeated 5 times.
        for _ in 0..40 {
            let c = [
                rng.random_range(0.0..3.0),
                rng.random_range(0.0..3.0),
                rng.random_range(0.0..3.0),
            ];
            for _ in 0..5 {
                pts.push(c);
            }
            for _ in 0..50 {
                pts.push([
                    c[0] + rng.random_range(-0.05..0.05),
                    c[1] + rng.random_range(-0.05..0.05),
                    c[2] + rng.random_range(-0.05..0.05),
                ]);
            }
        }
        let order = seeded_permutation(pts.len(), 77);
        for r in [0.2, 0.0, 0.01] {
            let kept = greedy_radius_downsample(&pts, &order, r).unwrap();
            assert_eq!(kept, brute(&pts, &order, r), "r = {r}");
            check_invariants(&pts, &kept, r);
        }
        // r = 0 keeps all distinct points: only the 4 extra copies of each
        // centre go (random offsets never coincide exactly).
        let kept = greedy_radius_downsample(&pts, &order, 0.0).unwrap();
        assert_eq!(kept.len(), pts.len() - 40 * 4);
    }

    #[test]
    fn distance_exactly_r_is_dropped() {
        // Points on a line at spacing 0.25 (exact in binary), r = 0.25: in
        // index order every odd point is at distance exactly r from the kept
        // even one before it (boundary included → dropped); the even points
        // are 2r from each other. Also points sitting exactly on cell
        // boundaries (multiples of the cell size r).
        let pts: Vec<[f64; 3]> = (0..20).map(|i| [i as f64 * 0.25, 1.0, -0.5]).collect();
        let order: Vec<usize> = (0..20).collect();
        let kept = greedy_radius_downsample(&pts, &order, 0.25).unwrap();
        assert_eq!(kept, (0..20).step_by(2).collect::<Vec<_>>());
        // Just below the spacing every point survives.
        let kept = greedy_radius_downsample(&pts, &order, 0.249_999_999).unwrap();
        assert_eq!(kept, order);
        // 3-4-5 triangle: distance exactly 5·0.125 along a diagonal.
        let pts = [[0.0, 0.0, 0.0], [0.375, 0.5, 0.0], [0.0, 0.0, 0.625]];
        let kept = greedy_radius_downsample(&pts, &[0, 1, 2], 0.625).unwrap();
        assert_eq!(kept, vec![0], "both at distance exactly 0.625 from point 0");
    }

    #[test]
    fn order_controls_the_walk_and_repeats_are_dropped() {
        let pts = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.5, 0.0, 0.0]];
        assert_eq!(
            greedy_radius_downsample(&pts, &[1, 0, 2], 0.2).unwrap(),
            vec![1, 2]
        );
        assert_eq!(
            greedy_radius_downsample(&pts, &[0, 1, 2], 0.2).unwrap(),
            vec![0, 2]
        );
        assert_eq!(
            greedy_radius_downsample(&pts, &[2, 2, 0], 0.2).unwrap(),
            vec![2, 0]
        );
        // A partial order walks only the listed points.
        assert_eq!(greedy_radius_downsample(&pts, &[1], 0.2).unwrap(), vec![1]);
        assert!(greedy_radius_downsample(&pts, &[], 0.2).unwrap().is_empty());
    }

    #[test]
    fn bad_input_is_an_error() {
        let pts = [[0.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0]];
        let msg = greedy_radius_downsample(&pts, &[0, 1], 0.2)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("point 1"), "{msg}");
        let msg = greedy_radius_downsample(&pts, &[0, 5], 0.2)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("entry 1") && msg.contains('5'), "{msg}");
        for r in [-0.1, f64::NAN, f64::INFINITY] {
            assert!(greedy_radius_downsample(&pts, &[0], r).is_err());
        }
    }

    #[test]
    fn seeded_permutation_is_a_reproducible_uniform_permutation() {
        assert!(seeded_permutation(0, 1).is_empty());
        assert_eq!(seeded_permutation(1, 1), vec![0]);
        let p = seeded_permutation(1000, 5);
        let mut sorted = p.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..1000).collect::<Vec<_>>());
        assert_eq!(p, seeded_permutation(1000, 5));
        assert_ne!(p, seeded_permutation(1000, 6));
        // Uniformity: over 24000 seeds each of the 24 permutations of 4
        // items has count ~ Bin(24000, 1/24), mean 1000, σ ≈ 31; 5σ bound.
        let mut counts = std::collections::HashMap::new();
        for seed in 0..24_000u64 {
            *counts.entry(seeded_permutation(4, seed)).or_insert(0usize) += 1;
        }
        assert_eq!(counts.len(), 24);
        let sigma = (24_000.0f64 * (1.0 / 24.0) * (23.0 / 24.0)).sqrt();
        for (perm, &c) in &counts {
            assert!((c as f64 - 1000.0).abs() <= 5.0 * sigma, "{perm:?}: {c}");
        }
    }

    /// The round-based path gives exactly the sequential walk's result, for a
    /// random order and for an adversarial one (walk along a line of points
    /// closer than r, one decision per round) that exhausts the rounds.
    #[test]
    fn rounds_equal_the_sequential_walk() {
        let mut rng = Pcg64Mcg::seed_from_u64(42);
        let mut pts: Vec<[f64; 3]> = (0..60_000)
            .map(|_| {
                let (u, v): (f64, f64) = (rng.random_range(0.0..6.0), rng.random_range(0.0..6.0));
                [u, v, 0.1 * (u * 1.7).sin()]
            })
            .collect();
        pts.extend((0..2000).map(|i| [i as f64 * 0.15, 7.0, 0.0]));
        let dup: Vec<[f64; 3]> = pts[..500].to_vec();
        pts.extend(dup);
        let order = seeded_permutation(pts.len(), 3);
        let fast = greedy_radius_downsample(&pts, &order, 0.2).unwrap();
        assert_eq!(fast, sequential_walk(&pts, &order, 0.2).unwrap());
        let mut line_first: Vec<usize> = (60_000..62_000).collect();
        line_first.extend((0..60_000).chain(62_000..pts.len()));
        let fast = greedy_radius_downsample(&pts, &line_first, 0.2).unwrap();
        assert_eq!(fast, sequential_walk(&pts, &line_first, 0.2).unwrap());
    }
}
