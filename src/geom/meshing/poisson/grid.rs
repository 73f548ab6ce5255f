//! Sparse grids of one octree level, stored as 8×8×8 bricks.
//!
//! A level with `res = 2^ℓ` cells per axis has cells `0..res` and nodes
//! (cell corners) `0..=res` per axis; both are addressed by integer
//! coordinates, and a cell shares its coordinates with its lowest corner.
//! [`BitGrid`] is a set of such coordinates (dilation, parents, clipping are
//! word operations on 512-bit masks); [`Bricks`] is an ordered brick list
//! with an index, behind flat per-brick data arrays of `BRICK_LEN` entries.

use rustc_hash::FxHashMap;

/// Brick side in grid points.
pub const BS: i32 = 8;
/// Entries per brick.
pub const BRICK_LEN: usize = 512;

/// A brick's 512 bits: word `z`, bit `x + 8 y`.
pub type Mask = [u64; 8];

const X0: u64 = 0x0101_0101_0101_0101;
const X7: u64 = 0x8080_8080_8080_8080;

/// Packs brick coordinates (each in `-1..2^20`) into a hash key.
#[inline]
pub fn brick_key(b: [i32; 3]) -> u64 {
    let m = 0x1F_FFFF_u64;
    (b[0] as u64 & m) | ((b[1] as u64 & m) << 21) | ((b[2] as u64 & m) << 42)
}

/// Local index of a point inside its brick.
#[inline]
pub fn local_index(p: [i32; 3]) -> usize {
    ((p[0] & 7) | ((p[1] & 7) << 3) | ((p[2] & 7) << 6)) as usize
}

/// The brick holding a point.
#[inline]
pub fn brick_of(p: [i32; 3]) -> [i32; 3] {
    [p[0] >> 3, p[1] >> 3, p[2] >> 3]
}

/// Interleaves the low 21 bits of three coordinates (z most significant).
#[inline]
pub fn morton(p: [i32; 3]) -> u64 {
    fn spread(v: u64) -> u64 {
        let mut x = v & 0x1F_FFFF;
        x = (x | (x << 32)) & 0x001F_0000_0000_FFFF;
        x = (x | (x << 16)) & 0x001F_0000_FF00_00FF;
        x = (x | (x << 8)) & 0x100F_00F0_0F00_F00F;
        x = (x | (x << 4)) & 0x10C3_0C30_C30C_30C3;
        x = (x | (x << 2)) & 0x1249_2492_4924_9249;
        x
    }
    spread(p[0] as u64) | (spread(p[1] as u64) << 1) | (spread(p[2] as u64) << 2)
}

/// A sparse set of grid points.
#[derive(Clone, Debug, Default)]
pub struct BitGrid {
    map: FxHashMap<u64, ([i32; 3], Mask)>,
}

impl BitGrid {
    /// The empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Every point of the box `lo..=hi`.
    pub fn full(lo: [i32; 3], hi: [i32; 3]) -> Self {
        let mut g = BitGrid::new();
        for bz in (lo[2] >> 3)..=(hi[2] >> 3) {
            for by in (lo[1] >> 3)..=(hi[1] >> 3) {
                for bx in (lo[0] >> 3)..=(hi[0] >> 3) {
                    g.map
                        .insert(brick_key([bx, by, bz]), ([bx, by, bz], [!0u64; 8]));
                }
            }
        }
        g.clip(lo, hi);
        g
    }

    /// Adds a point.
    #[inline]
    pub fn insert(&mut self, p: [i32; 3]) {
        let b = brick_of(p);
        let e = self.map.entry(brick_key(b)).or_insert((b, [0; 8]));
        let l = local_index(p);
        e.1[l >> 6] |= 1 << (l & 63);
    }

    /// Membership.
    #[inline]
    pub fn contains(&self, p: [i32; 3]) -> bool {
        match self.map.get(&brick_key(brick_of(p))) {
            Some((b, m)) if *b == brick_of(p) => {
                let l = local_index(p);
                m[l >> 6] >> (l & 63) & 1 == 1
            }
            _ => false,
        }
    }

    /// The brick mask holding `p`'s brick, if any.
    #[inline]
    pub fn mask(&self, b: [i32; 3]) -> Option<&Mask> {
        self.map.get(&brick_key(b)).map(|(_, m)| m)
    }

    /// Number of points.
    pub fn count(&self) -> usize {
        self.map
            .values()
            .map(|(_, m)| m.iter().map(|w| w.count_ones() as usize).sum::<usize>())
            .sum()
    }

    /// Bricks with at least one point, in Morton order.
    pub fn bricks(&self) -> Vec<[i32; 3]> {
        let mut v: Vec<[i32; 3]> = self
            .map
            .values()
            .filter(|(_, m)| m.iter().any(|&w| w != 0))
            .map(|(b, _)| *b)
            .collect();
        v.sort_unstable_by_key(|b| morton(*b));
        v
    }

    /// Calls `f` on every point (unordered).
    pub fn for_each(&self, mut f: impl FnMut([i32; 3])) {
        for (b, m) in self.map.values() {
            for (z, &w) in m.iter().enumerate() {
                let mut w = w;
                while w != 0 {
                    let bit = w.trailing_zeros() as i32;
                    w &= w - 1;
                    f([
                        b[0] * BS + (bit & 7),
                        b[1] * BS + (bit >> 3),
                        b[2] * BS + z as i32,
                    ]);
                }
            }
        }
    }

    /// Union with another set.
    pub fn union_with(&mut self, o: &BitGrid) {
        for (k, (b, m)) in &o.map {
            let e = self.map.entry(*k).or_insert((*b, [0; 8]));
            for (dst, src) in e.1.iter_mut().zip(m) {
                *dst |= src;
            }
        }
    }

    fn or_into(map: &mut FxHashMap<u64, ([i32; 3], Mask)>, b: [i32; 3], m: &Mask) {
        if m.iter().all(|&w| w == 0) {
            return;
        }
        let e = map.entry(brick_key(b)).or_insert((b, [0; 8]));
        for (dst, src) in e.1.iter_mut().zip(m) {
            *dst |= src;
        }
    }

    /// The set shifted by `dir` (±1) along `axis`, united with itself.
    fn grow(&self, axis: usize, dir: i32) -> BitGrid {
        let mut out = self.map.clone();
        for (b, m) in self.map.values() {
            let mut inner = [0u64; 8];
            let mut spill = [0u64; 8];
            match (axis, dir) {
                (0, 1) => {
                    for z in 0..8 {
                        inner[z] = (m[z] << 1) & !X0;
                        spill[z] = (m[z] & X7) >> 7;
                    }
                }
                (0, _) => {
                    for z in 0..8 {
                        inner[z] = (m[z] >> 1) & !X7;
                        spill[z] = (m[z] & X0) << 7;
                    }
                }
                (1, 1) => {
                    for z in 0..8 {
                        inner[z] = m[z] << 8;
                        spill[z] = m[z] >> 56;
                    }
                }
                (1, _) => {
                    for z in 0..8 {
                        inner[z] = m[z] >> 8;
                        spill[z] = m[z] << 56;
                    }
                }
                (_, 1) => {
                    inner[1..8].copy_from_slice(&m[0..7]);
                    spill[0] = m[7];
                }
                _ => {
                    inner[0..7].copy_from_slice(&m[1..8]);
                    spill[7] = m[0];
                }
            }
            Self::or_into(&mut out, *b, &inner);
            let mut nb = *b;
            nb[axis] += dir;
            Self::or_into(&mut out, nb, &spill);
        }
        BitGrid { map: out }
    }

    /// Minkowski sum with the box `-neg..=pos` on every axis.
    pub fn dilate(&self, neg: i32, pos: i32) -> BitGrid {
        let mut g = self.clone();
        for axis in 0..3 {
            for _ in 0..neg {
                g = g.grow(axis, -1);
            }
            for _ in 0..pos {
                g = g.grow(axis, 1);
            }
        }
        g
    }

    /// Removes every point outside the box `lo..=hi`.
    pub fn clip(&mut self, lo: [i32; 3], hi: [i32; 3]) {
        self.map.retain(|_, (b, m)| {
            for axis in 0..3 {
                let b0 = b[axis] * BS;
                if b0 + BS - 1 < lo[axis] || b0 > hi[axis] {
                    return false;
                }
            }
            if (0..3).all(|a| b[a] * BS >= lo[a] && b[a] * BS + BS - 1 <= hi[a]) {
                return true;
            }
            for (z, word) in m.iter_mut().enumerate() {
                let gz = b[2] * BS + z as i32;
                if gz < lo[2] || gz > hi[2] {
                    *word = 0;
                    continue;
                }
                let mut keep = 0u64;
                for y in 0..8 {
                    let gy = b[1] * BS + y;
                    if gy < lo[1] || gy > hi[1] {
                        continue;
                    }
                    for x in 0..8 {
                        let gx = b[0] * BS + x;
                        if gx >= lo[0] && gx <= hi[0] {
                            keep |= 1 << (x + 8 * y);
                        }
                    }
                }
                *word &= keep;
            }
            m.iter().any(|&w| w != 0)
        });
    }

    /// The 8 children of every cell, one level down.
    pub fn children(&self) -> BitGrid {
        let mut g = BitGrid::new();
        self.for_each(|p| {
            for k in 0..8 {
                g.insert([
                    2 * p[0] + (k & 1),
                    2 * p[1] + ((k >> 1) & 1),
                    2 * p[2] + (k >> 2),
                ]);
            }
        });
        g
    }

    /// The set of parents (coordinates halved, rounding down) one level up.
    pub fn parents(&self) -> BitGrid {
        let mut g = BitGrid::new();
        self.for_each(|p| g.insert([p[0] >> 1, p[1] >> 1, p[2] >> 1]));
        g
    }
}

/// An ordered list of bricks with a coordinate index; per-brick data lives in
/// flat arrays of `len() * BRICK_LEN` entries owned by the caller.
#[derive(Clone, Debug, Default)]
pub struct Bricks {
    /// Brick coordinates, in Morton order.
    pub coords: Vec<[i32; 3]>,
    map: FxHashMap<u64, u32>,
}

impl Bricks {
    /// Indexes the given bricks (sorted into Morton order, duplicates removed).
    pub fn new(mut coords: Vec<[i32; 3]>) -> Self {
        coords.sort_unstable_by_key(|b| morton(*b));
        coords.dedup();
        let map = coords
            .iter()
            .enumerate()
            .map(|(i, b)| (brick_key(*b), i as u32))
            .collect();
        Bricks { coords, map }
    }

    /// Number of bricks.
    pub fn len(&self) -> usize {
        self.coords.len()
    }

    /// True when there are no bricks.
    pub fn is_empty(&self) -> bool {
        self.coords.is_empty()
    }

    /// Index of a brick.
    #[inline]
    pub fn get(&self, b: [i32; 3]) -> Option<usize> {
        if b.iter().any(|&c| c < 0) {
            return None;
        }
        self.map.get(&brick_key(b)).map(|&i| i as usize)
    }

    /// Flat index of a point in per-brick data, if its brick exists.
    #[inline]
    pub fn locate(&self, p: [i32; 3]) -> Option<usize> {
        self.get(brick_of(p))
            .map(|i| i * BRICK_LEN + local_index(p))
    }

    /// Copies the box `lo .. lo+dims` of `data` into `out` (x fastest), with
    /// `fill` where no brick holds a point.
    pub fn gather<T: Copy>(
        &self,
        data: &[T],
        lo: [i32; 3],
        dims: [usize; 3],
        out: &mut [T],
        fill: T,
    ) {
        let hi = [
            lo[0] + dims[0] as i32 - 1,
            lo[1] + dims[1] as i32 - 1,
            lo[2] + dims[2] as i32 - 1,
        ];
        for bz in (lo[2] >> 3)..=(hi[2] >> 3) {
            let z0 = (bz * BS).max(lo[2]);
            let z1 = (bz * BS + BS - 1).min(hi[2]);
            for by in (lo[1] >> 3)..=(hi[1] >> 3) {
                let y0 = (by * BS).max(lo[1]);
                let y1 = (by * BS + BS - 1).min(hi[1]);
                for bx in (lo[0] >> 3)..=(hi[0] >> 3) {
                    let x0 = (bx * BS).max(lo[0]);
                    let x1 = (bx * BS + BS - 1).min(hi[0]);
                    let n = (x1 - x0 + 1) as usize;
                    let src = self.get([bx, by, bz]);
                    for z in z0..=z1 {
                        for y in y0..=y1 {
                            let o = (x0 - lo[0]) as usize
                                + dims[0] * ((y - lo[1]) as usize + dims[1] * (z - lo[2]) as usize);
                            match src {
                                Some(bi) => {
                                    let s = bi * BRICK_LEN + local_index([x0, y, z]);
                                    out[o..o + n].copy_from_slice(&data[s..s + n]);
                                }
                                None => out[o..o + n].fill(fill),
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Tests a bit of a brick mask.
#[inline]
pub fn mask_has(m: &Mask, local: usize) -> bool {
    m[local >> 6] >> (local & 63) & 1 == 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive_dilate(pts: &[[i32; 3]], neg: i32, pos: i32) -> Vec<[i32; 3]> {
        let mut v = Vec::new();
        for p in pts {
            for dz in -neg..=pos {
                for dy in -neg..=pos {
                    for dx in -neg..=pos {
                        v.push([p[0] + dx, p[1] + dy, p[2] + dz]);
                    }
                }
            }
        }
        v.sort_unstable();
        v.dedup();
        v
    }

    fn points(g: &BitGrid) -> Vec<[i32; 3]> {
        let mut v = Vec::new();
        g.for_each(|p| v.push(p));
        v.sort_unstable();
        v
    }

    #[test]
    fn dilate_matches_naive_across_brick_borders() {
        // Points on brick faces, edges and corners exercise every spill path.
        let pts = [[7, 7, 7], [8, 0, 15], [0, 8, 8], [23, 4, 9], [16, 16, 16]];
        let mut g = BitGrid::new();
        for p in pts {
            g.insert(p);
        }
        for (neg, pos) in [(1, 1), (0, 1), (2, 2)] {
            let mut d = g.dilate(neg, pos);
            d.clip([0; 3], [40; 3]);
            let want: Vec<_> = naive_dilate(&pts, neg, pos)
                .into_iter()
                .filter(|p| p.iter().all(|&c| (0..=40).contains(&c)))
                .collect();
            assert_eq!(points(&d), want, "dilate({neg},{pos})");
        }
    }

    #[test]
    fn parents_and_gather() {
        let mut g = BitGrid::new();
        g.insert([9, 3, 17]);
        g.insert([8, 2, 16]);
        assert_eq!(points(&g.parents()), vec![[4, 1, 8]]);
        assert!(g.contains([9, 3, 17]) && !g.contains([9, 3, 18]));
        let bricks = Bricks::new(vec![[1, 0, 2], [0, 0, 0]]);
        let mut data = vec![0.0f32; bricks.len() * BRICK_LEN];
        let i = bricks.locate([9, 3, 17]).unwrap();
        data[i] = 5.0;
        let mut out = vec![0.0f32; 27];
        bricks.gather(&data, [8, 2, 16], [3, 3, 3], &mut out, -1.0);
        assert_eq!(out[1 + 3 + 9], 5.0);
        assert_eq!(out[0], 0.0);
        bricks.gather(&data, [30, 30, 30], [3, 3, 3], &mut out, -1.0);
        assert!(out.iter().all(|&v| v == -1.0));
    }
}
