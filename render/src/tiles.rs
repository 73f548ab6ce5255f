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
    /// Per tile (row-major), indices of the primitives touching it, front to back.
    pub lists: Vec<Vec<u32>>,
    pub tiles_x: usize,
    pub tiles_y: usize,
    /// Per primitive: inclusive tile rectangle (x0, y0, x1, y1) or `None`.
    rects: Vec<Option<[u32; 4]>>,
    /// Per primitive: start of its positions in `pos`.
    start: Vec<u32>,
    /// Positions in the tile lists, per primitive, tiles in row-major order.
    pos: Vec<u32>,
}

impl TileLists {
    /// Bins `items` of a `w × h` image: `bbox` gives an item's screen box in
    /// pixels (x0, y0, x1, y1) or `None` to skip it, `depth` its sort key.
    pub fn build<P: Sync>(
        items: &[P],
        bbox: impl Fn(&P) -> Option<[f32; 4]> + Sync,
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
                let [bx0, by0, bx1, by1] = bbox(p)?;
                if !(bx1 >= 0.0 && by1 >= 0.0 && bx0 <= w as f32 && by0 <= h as f32) {
                    return None;
                }
                let x0 = (bx0.floor().max(0.0) as usize) / TILE;
                let y0 = (by0.floor().max(0.0) as usize) / TILE;
                let x1 = ((bx1.ceil() as usize) / TILE).min(tw - 1);
                let y1 = ((by1.ceil() as usize) / TILE).min(th - 1);
                Some([x0 as u32, y0 as u32, x1 as u32, y1 as u32])
            })
            .collect();
        // order-preserving map of f32 bits to u32 (a total order)
        let key = |d: f32| {
            let b = d.to_bits();
            if b >> 31 == 1 { !b } else { b | 0x8000_0000 }
        };
        let mut order: Vec<u64> = items
            .par_iter()
            .enumerate()
            .filter(|(i, _)| rects[*i].is_some())
            .map(|(i, p)| ((key(depth(p)) as u64) << 32) | i as u64)
            .collect();
        order.par_sort_unstable();
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); tw * th];
        let mut start = vec![0u32; n];
        let mut pos = Vec::new();
        for k in order {
            let pi = (k & 0xffff_ffff) as usize;
            let [x0, y0, x1, y1] = rects[pi].expect("filtered");
            start[pi] = pos.len() as u32;
            for ty in y0 as usize..=y1 as usize {
                for tx in x0 as usize..=x1 as usize {
                    let l = &mut lists[ty * tw + tx];
                    pos.push(l.len() as u32);
                    l.push(pi as u32);
                }
            }
        }
        TileLists {
            lists,
            tiles_x: tw,
            tiles_y: th,
            rects,
            start,
            pos,
        }
    }

    /// Sums, per primitive, the per-tile values aligned with the lists
    /// (`per_tile[t][k]` belongs to `lists[t][k]`), in f64, tiles in
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
