//! Screen tiles: which primitives touch which 16×16 tile, front to back.
//!
//! Every rasteriser bins its projected primitives here. The lists hold
//! indices into the caller's projected array, sorted by (depth, index) — a
//! deterministic order — via one global sort; filling the lists in that order
//! keeps each sorted. For the backward passes, each primitive also records
//! where it sits in each list of its tile rectangle, so per-tile gradient
//! buffers can be gathered per primitive in parallel and in a fixed order.

use rayon::prelude::*;

/// Tile side in pixels.
pub const TILE: usize = 16;

/// The binned primitives of one view.
#[derive(Clone, Debug, Default)]
pub struct TileLists {
    /// Per tile (row-major), its range in `entries` (CSR offsets, tiles + 1).
    offsets: Vec<usize>,
    /// Indices of the primitives touching each tile, front to back.
    entries: Vec<u32>,
    pub tiles_x: usize,
    pub tiles_y: usize,
    /// Per primitive: inclusive tile rectangle (x0, y0, x1, y1) or `None`.
    rects: Vec<Option<[u32; 4]>>,
    /// Per primitive: start of its positions in `pos`.
    start: Vec<u32>,
    /// Positions in the tile lists, per primitive, tiles in row-major order.
    pos: Vec<u32>,
}

/// The tiles (x0, y0, x1, y1, inclusive) that a screen box (x0, y0, x1, y1)
/// in pixels touches on a `w × h` image, or `None` when it touches no pixel:
/// a box starting at x = w (or y = h), an inverted box, NaN corners.
#[inline]
pub fn tile_rect(b: [f32; 4], w: usize, h: usize) -> Option<[u32; 4]> {
    let [bx0, by0, bx1, by1] = b;
    let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
    if tw == 0 || th == 0 {
        return None;
    }
    // NaN fails every comparison and is skipped too
    if !(bx1 >= 0.0 && by1 >= 0.0 && bx0 < w as f32 && by0 < h as f32) {
        return None;
    }
    let x0 = (bx0.floor().max(0.0) as usize) / TILE;
    let y0 = (by0.floor().max(0.0) as usize) / TILE;
    let x1 = ((bx1.ceil() as usize) / TILE).min(tw - 1);
    let y1 = ((by1.ceil() as usize) / TILE).min(th - 1);
    (x0 <= x1 && y0 <= y1).then_some([x0 as u32, y0 as u32, x1 as u32, y1 as u32])
}

/// The tiles (x0, y0, x1, y1, inclusive) that the official CUDA kernels
/// (3DGS `getRect`, Triangle Splatting's tightened box) assign to a screen
/// box (x0, y0, x1, y1) given in OpenCV pixel coordinates (pixel centres at
/// integer + 0.5), or `None` for an empty range, which those kernels cull.
///
/// The kernels work in coordinates whose pixel centres are integers (ours
/// − 0.5) and take tile columns `(uint)(x0/16)` up to, but excluding,
/// `(uint)((x1 + 15)/16)`, each clamped to `[0, tiles]` (negative values
/// saturate to 0). Unlike [`tile_rect`], this is not the exact cover of the
/// box: a right edge in [16k, 16k + 1) leaves out column k although the
/// pixel at 16k lies inside, and a box whose right edge is below 1 gets no
/// tile at all. Primitives fitted under this rule must be drawn with it.
/// NaN corners give `None`.
#[inline]
pub fn tile_rect_cuda(b: [f32; 4], w: usize, h: usize) -> Option<[u32; 4]> {
    let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
    if b.iter().any(|v| v.is_nan()) {
        return None;
    }
    // f32 → usize saturates: negatives (and −∞) to 0, +∞ to usize::MAX
    let lo = |v: f32, n: usize| (((v - 0.5) / TILE as f32) as usize).min(n);
    let hi = |v: f32, n: usize| ((((v - 0.5) + (TILE - 1) as f32) / TILE as f32) as usize).min(n);
    let (x0, x1) = (lo(b[0], tw), hi(b[2], tw));
    let (y0, y1) = (lo(b[1], th), hi(b[3], th));
    (x0 < x1 && y0 < y1).then(|| [x0 as u32, y0 as u32, x1 as u32 - 1, y1 as u32 - 1])
}

/// The tiles two inclusive tile rectangles share, `None` when disjoint.
#[inline]
pub fn intersect_rects(a: [u32; 4], b: [u32; 4]) -> Option<[u32; 4]> {
    let r = [
        a[0].max(b[0]),
        a[1].max(b[1]),
        a[2].min(b[2]),
        a[3].min(b[3]),
    ];
    (r[0] <= r[2] && r[1] <= r[3]).then_some(r)
}

/// Order-preserving map of f32 bits to u32 (a total order: −NaN < −∞ < … <
/// −0 < +0 < … < +∞ < NaN), the depth part of the tile lists' sort key.
#[inline]
pub fn depth_key(d: f32) -> u32 {
    let b = d.to_bits();
    if b >> 31 == 1 { !b } else { b | 0x8000_0000 }
}

impl TileLists {
    /// Bins `items` of a `w × h` image: `rect` gives an item's inclusive
    /// tile rectangle (x0, y0, x1, y1), from [`tile_rect`] or
    /// [`tile_rect_cuda`], or `None` to skip it; `depth` its sort key.
    pub fn build<P: Sync>(
        items: &[P],
        rect: impl Fn(&P) -> Option<[u32; 4]> + Sync,
        depth: impl Fn(&P) -> f32 + Sync,
        w: usize,
        h: usize,
    ) -> TileLists {
        let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
        let n = items.len();
        if tw == 0 || th == 0 {
            return TileLists {
                rects: vec![None; n],
                start: vec![0; n],
                ..Default::default()
            };
        }
        let rects: Vec<Option<[u32; 4]>> = items
            .par_iter()
            .map(|p| {
                let r = rect(p)?;
                // a rectangle off the grid is a caller's bug; skip, not panic
                ((r[2] as usize) < tw && (r[3] as usize) < th).then_some(r)
            })
            .collect();
        let key = depth_key;
        let mut order: Vec<u64> = items
            .par_iter()
            .enumerate()
            .filter(|(i, _)| rects[*i].is_some())
            .map(|(i, p)| ((key(depth(p)) as u64) << 32) | i as u64)
            .collect();
        order.par_sort_unstable();
        // the rectangles in sorted order: one gather, then the passes below
        // read them in sequence instead of at random
        let sorted_rects: Vec<[u32; 4]> = order
            .par_iter()
            .map(|k| rects[(k & 0xffff_ffff) as usize].expect("filtered"))
            .collect();
        // counts per tile, in parallel over chunks of the sorted order
        let chunk = order
            .len()
            .div_ceil(rayon::current_num_threads() * 4)
            .max(1);
        let counts: Vec<Vec<u32>> = sorted_rects
            .par_chunks(chunk)
            .map(|c| {
                let mut cnt = vec![0u32; tw * th];
                for &[x0, y0, x1, y1] in c {
                    for ty in y0 as usize..=y1 as usize {
                        for tx in x0 as usize..=x1 as usize {
                            cnt[ty * tw + tx] += 1;
                        }
                    }
                }
                cnt
            })
            .collect();
        let nt = tw * th;
        let mut offsets = vec![0usize; nt + 1];
        for t in 0..nt {
            offsets[t + 1] = offsets[t] + counts.iter().map(|c| c[t] as usize).sum::<usize>();
        }
        // where each chunk starts writing in each tile's range
        let mut chunk_at: Vec<Vec<usize>> = Vec::with_capacity(counts.len());
        let mut run = offsets[..nt].to_vec();
        for c in &counts {
            chunk_at.push(run.clone());
            for t in 0..nt {
                run[t] += c[t] as usize;
            }
        }
        // where each primitive's positions start, in sorted order
        let mut start = vec![0u32; n];
        let mut total = 0usize;
        for (k, &[x0, y0, x1, y1]) in order.iter().zip(&sorted_rects) {
            start[(k & 0xffff_ffff) as usize] = total as u32;
            total += (x1 - x0 + 1) as usize * (y1 - y0 + 1) as usize;
        }
        let mut entries = vec![0u32; offsets[nt]];
        let mut pos = vec![0u32; total];
        let (ep, pp) = (SharedSlice::new(&mut entries), SharedSlice::new(&mut pos));
        order
            .par_chunks(chunk)
            .zip(sorted_rects.par_chunks(chunk))
            .zip(chunk_at.into_par_iter())
            .for_each(|((c, cr), mut at)| {
                for (k, &[x0, y0, x1, y1]) in c.iter().zip(cr) {
                    let pi = (k & 0xffff_ffff) as usize;
                    let mut q = start[pi] as usize;
                    for ty in y0 as usize..=y1 as usize {
                        for tx in x0 as usize..=x1 as usize {
                            let t = ty * tw + tx;
                            // SAFETY: chunk c owns entries[at[t]..] up to its
                            // count for tile t, and pos[start[pi]..] belongs
                            // to pi alone: every index is written once.
                            unsafe {
                                ep.write(at[t], pi as u32);
                                pp.write(q, (at[t] - offsets[t]) as u32);
                            }
                            at[t] += 1;
                            q += 1;
                        }
                    }
                }
            });
        TileLists {
            offsets,
            entries,
            tiles_x: tw,
            tiles_y: th,
            rects,
            start,
            pos,
        }
    }

    /// Number of tiles.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True when the image has no tiles.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The primitives touching tile `t`, front to back.
    pub fn list(&self, t: usize) -> &[u32] {
        &self.entries[self.offsets[t]..self.offsets[t + 1]]
    }

    /// Sums, per primitive, the per-tile values aligned with the lists
    /// (`per_tile[t][k]` belongs to `list(t)[k]`), in f64, tiles in
    /// row-major order: deterministic and parallel over primitives.
    pub fn gather<const K: usize>(&self, per_tile: &[Vec<[f32; K]>]) -> Vec<[f64; K]> {
        (0..self.rects.len())
            .into_par_iter()
            .map(|pi| {
                let mut acc = [0.0f64; K];
                let Some([x0, y0, x1, y1]) = self.rects[pi] else {
                    return acc;
                };
                let mut k = self.start[pi] as usize;
                for ty in y0 as usize..=y1 as usize {
                    for tx in x0 as usize..=x1 as usize {
                        let v = &per_tile[ty * self.tiles_x + tx][self.pos[k] as usize];
                        for (a, b) in acc.iter_mut().zip(v) {
                            *a += *b as f64;
                        }
                        k += 1;
                    }
                }
                acc
            })
            .collect()
    }
}

/// The pixels (x, y) of tile `t` of a `w × h` image, row-major.
pub fn tile_pixels(
    t: usize,
    tiles_x: usize,
    w: usize,
    h: usize,
) -> impl Iterator<Item = (usize, usize)> {
    let (tx, ty) = (t % tiles_x, t / tiles_x);
    let (x0, x1) = (tx * TILE, ((tx + 1) * TILE).min(w));
    (ty * TILE..((ty + 1) * TILE).min(h)).flat_map(move |y| (x0..x1).map(move |x| (x, y)))
}

/// Runs `per_tile(t)` for every tile in parallel (one value per pixel, in
/// [`tile_pixels`] order) and hands each value to `land(y·w + x, value)` in
/// tile order, so the result does not depend on the thread count.
pub fn render_tiles<T: Send>(
    tiles_x: usize,
    tiles_y: usize,
    w: usize,
    h: usize,
    per_tile: impl Fn(usize) -> Vec<T> + Sync + Send,
    mut land: impl FnMut(usize, T),
) {
    let done: Vec<Vec<T>> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(per_tile)
        .collect();
    for (t, values) in done.into_iter().enumerate() {
        let mut it = values.into_iter();
        for (x, y) in tile_pixels(t, tiles_x, w, h) {
            land(y * w + x, it.next().expect("one value per pixel"));
        }
    }
}

/// [`render_tiles`] with the landing in parallel too: `bands[ty]` is the
/// caller's mutable view of the image rows of tile row `ty` (`TILE` rows of
/// `w` pixels, the last band shorter), and `land(band, i, value)` gets the
/// pixel's index inside its band, `(y − ty·TILE)·w + x`. The tiles of a row
/// are blended in parallel, the rows too; every pixel receives exactly its
/// own value, so the result does not depend on the thread count.
pub fn render_tile_rows<T: Send, B: Send>(
    tiles_x: usize,
    w: usize,
    h: usize,
    bands: Vec<B>,
    per_tile: impl Fn(usize) -> Vec<T> + Sync + Send,
    land: impl Fn(&mut B, usize, T) + Sync + Send,
) {
    bands
        .into_par_iter()
        .enumerate()
        .for_each(|(ty, mut band)| {
            let done: Vec<Vec<T>> = (0..tiles_x)
                .into_par_iter()
                .map(|tx| per_tile(ty * tiles_x + tx))
                .collect();
            for (tx, values) in done.into_iter().enumerate() {
                let mut it = values.into_iter();
                for (x, y) in tile_pixels(ty * tiles_x + tx, tiles_x, w, h) {
                    let v = it.next().expect("one value per pixel");
                    land(&mut band, (y - ty * TILE) * w + x, v);
                }
            }
        });
}

/// How many list entries ahead [`prefetch_ahead`] asks for.
pub(crate) const PREFETCH_DISTANCE: usize = 8;

/// Hints the CPU to load `items[list[k]]` (both cache lines of a record up
/// to 128 bytes) into cache; nothing when `k` is past the list. A tile list
/// visits its primitives in depth order, which is random in memory: without
/// the hint every primitive's first read is a cache miss the pixel loop
/// waits for (measured: a tenth of the Gaussian forward pass). A hint never
/// faults and never changes a result.
#[inline(always)]
pub(crate) fn prefetch_ahead<T>(items: &[T], list: &[u32], k: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(&i) = list.get(k) {
        let p = items.as_ptr().wrapping_add(i as usize) as *const i8;
        // SAFETY: prefetching is only a hint; it does not dereference the
        // address and cannot fault, whatever the address.
        unsafe {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            _mm_prefetch::<_MM_HINT_T0>(p);
            if std::mem::size_of::<T>() > 64 {
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (items, list, k);
}

/// A slice that several threads write at disjoint indices.
struct SharedSlice<T> {
    ptr: *mut T,
    len: usize,
}

// SAFETY: used only for writes at indices that no two threads share.
unsafe impl<T: Send> Sync for SharedSlice<T> {}
// SAFETY: as above; the pointer is only written through `write`.
unsafe impl<T: Send> Send for SharedSlice<T> {}

impl<T> SharedSlice<T> {
    fn new(v: &mut [T]) -> Self {
        SharedSlice {
            ptr: v.as_mut_ptr(),
            len: v.len(),
        }
    }

    /// # Safety
    /// No other thread may access index `i` concurrently.
    unsafe fn write(&self, i: usize, v: T) {
        assert!(i < self.len, "index {i} out of {}", self.len);
        // SAFETY: in bounds (checked), exclusive by the caller's contract.
        unsafe { self.ptr.add(i).write(v) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lists are sorted by (depth, index), hold exactly the primitives whose
    /// box touches the tile, and `gather` sums per primitive.
    #[test]
    fn lists_and_gather() {
        // boxes (x0, y0, x1, y1) on a 40×40 image (3×3 tiles), depths
        let items = [
            ([0.0f32, 0.0, 20.0, 5.0], 3.0f32),
            ([17.0, 17.0, 18.0, 18.0], 1.0),
            ([-5.0, -5.0, 100.0, 100.0], 2.0),
            ([50.0, 50.0, 60.0, 60.0], 0.5), // off-image
            ([30.0, 0.0, 39.0, 39.0], 2.0),
        ];
        let tl = TileLists::build(&items, |p| tile_rect(p.0, 40, 40), |p| p.1, 40, 40);
        assert_eq!(tl.len(), 9);
        assert_eq!(tl.list(0), &[2, 0]);
        assert_eq!(tl.list(1), &[2, 4, 0], "x 30 lies in tile column 1");
        assert_eq!(tl.list(4), &[1, 2, 4]);
        assert_eq!(tl.list(2), &[2, 4]);
        assert_eq!(tl.list(8), &[2, 4]);
        assert_eq!(tl.list(6), &[2]);
        let per_tile: Vec<Vec<[f32; 1]>> = (0..9)
            .map(|t| tl.list(t).iter().map(|_| [t as f32 + 1.0]).collect())
            .collect();
        let sums = tl.gather(&per_tile);
        assert_eq!(sums[2][0], 45.0, "item 2 touches all 9 tiles");
        assert_eq!(sums[0][0], 1.0 + 2.0);
        assert_eq!(sums[3][0], 0.0);
        assert_eq!(sums[4][0], 2.0 + 3.0 + 5.0 + 6.0 + 8.0 + 9.0);
    }

    /// Boxes that touch no pixel are skipped, not counted: one starting
    /// exactly at the right or bottom edge of a 32×32 image (whose tile
    /// count divides evenly, the case that once underflowed), an inverted
    /// box, and NaN corners.
    #[test]
    fn edge_inverted_and_nan_boxes() {
        let items = [
            [32.0f32, 0.0, 40.0, 8.0],
            [0.0, 32.0, 8.0, 40.0],
            [20.0, 20.0, 3.0, 25.0],
            [f32::NAN, 0.0, 5.0, 5.0],
            [0.0, 0.0, f32::NAN, 5.0],
            [31.5, 31.5, 32.0, 32.0],
        ];
        let tl = TileLists::build(&items, |p| tile_rect(*p, 32, 32), |_| 1.0, 32, 32);
        assert_eq!(tl.len(), 4);
        for t in 0..3 {
            assert!(tl.list(t).is_empty(), "tile {t}: {:?}", tl.list(t));
        }
        assert_eq!(tl.list(3), &[5], "only the last pixel's box is binned");
    }

    /// The kernels' rule, case by case (boxes in OpenCV pixel coordinates,
    /// so kernel x = ours − 0.5) on a 40×40 image (3×3 tiles):
    /// - right edge 16.5 → kernel 16.0: (16 + 15)/16 = 1.94 → columns [0, 1),
    ///   column 1 is left out although pixel 16 (kernel) lies on the edge;
    /// - right edge 17.5 → kernel 17: (32)/16 = 2 → columns [0, 2);
    /// - left edge 16.4 → kernel 15.9 → column 0 is included;
    /// - right edge 1.2 → kernel 0.7: 15.7/16 = 0.98 → no column: culled,
    ///   where the exact cover ([`tile_rect`]) has column 0;
    /// - negative left edges saturate to 0; far right edges clamp to the grid.
    #[test]
    fn cuda_tile_range() {
        let r = |b: [f32; 4]| tile_rect_cuda(b, 40, 40);
        assert_eq!(r([3.0, 3.0, 16.5, 16.5]), Some([0, 0, 0, 0]));
        assert_eq!(
            tile_rect([3.0, 3.0, 16.5, 16.5], 40, 40),
            Some([0, 0, 1, 1])
        );
        assert_eq!(r([3.0, 3.0, 17.5, 17.5]), Some([0, 0, 1, 1]));
        assert_eq!(r([16.4, 0.0, 20.0, 5.0]), Some([0, 0, 1, 0]));
        assert_eq!(r([16.5, 0.0, 20.0, 5.0]), Some([1, 0, 1, 0]));
        assert_eq!(r([-0.3, -0.3, 1.2, 1.2]), None);
        assert_eq!(
            tile_rect([-0.3, -0.3, 1.2, 1.2], 40, 40),
            Some([0, 0, 0, 0])
        );
        assert_eq!(r([-100.0, -20.0, 1e9, f32::INFINITY]), Some([0, 0, 2, 2]));
        assert_eq!(r([f32::NAN, 0.0, 5.0, 5.0]), None);
        assert_eq!(
            r([50.0, 0.0, 60.0, 5.0]),
            None,
            "left of the box past the grid"
        );
        assert_eq!(
            intersect_rects([0, 0, 2, 2], [1, 2, 5, 5]),
            Some([1, 2, 2, 2])
        );
        assert_eq!(intersect_rects([0, 0, 0, 0], [1, 0, 1, 0]), None);
    }
}
