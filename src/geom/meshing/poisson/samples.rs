//! Input points → normalised, merged samples.
//!
//! The bounding box of the valid points is mapped into the unit cube: the cube
//! has side `scale · (largest box extent)` and shares the box centre. Points
//! are then merged per finest-level cell (depth D): one sample per occupied
//! cell with total weight W (one per point), the weighted centroid, the sum of
//! the unit normals and the mean colour. Everything downstream works on these
//! samples, so cost follows the occupied cells rather than the point count.

use rayon::prelude::*;

use super::grid::morton;

/// Maps world coordinates to the unit cube and back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalization {
    /// World coordinates of the cube centre.
    pub center: [f64; 3],
    /// World length of the cube side.
    pub side: f64,
}

impl Normalization {
    /// World → unit cube.
    #[inline]
    pub fn to_unit(&self, p: [f64; 3]) -> [f64; 3] {
        [
            (p[0] - self.center[0]) / self.side + 0.5,
            (p[1] - self.center[1]) / self.side + 0.5,
            (p[2] - self.center[2]) / self.side + 0.5,
        ]
    }

    /// Unit cube → world.
    #[inline]
    pub fn to_world(&self, u: [f64; 3]) -> [f64; 3] {
        [
            (u[0] - 0.5) * self.side + self.center[0],
            (u[1] - 0.5) * self.side + self.center[1],
            (u[2] - 0.5) * self.side + self.center[2],
        ]
    }
}

/// Merged samples, sorted by the Morton key of their depth-D cell.
#[derive(Clone, Debug, Default)]
pub struct Samples {
    /// Depth of the merge cells.
    pub depth: u32,
    /// Morton key of each sample's depth-D cell (ascending, unique).
    pub keys: Vec<u64>,
    /// Weighted centroid, unit-cube coordinates.
    pub pos: Vec<[f64; 3]>,
    /// Sum of the unit normals of the merged points (length ≤ weight).
    pub normal: Vec<[f64; 3]>,
    /// Number of merged points.
    pub weight: Vec<f64>,
    /// Mean colour (0..255 per channel) when the input had colours.
    pub color: Option<Vec<[f32; 3]>>,
}

impl Samples {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Aggregates the samples per cell of a coarser depth (`shift` = 3 × the
    /// depth difference, on the Morton keys), calling `f(total weight,
    /// weighted centroid)` once per occupied cell, in key order.
    pub fn for_each_cell(&self, shift: u32, mut f: impl FnMut(f64, [f64; 3])) {
        let n = self.len();
        let mut i = 0;
        while i < n {
            let key = self.keys[i] >> shift;
            let mut w = 0.0;
            let mut c = [0.0; 3];
            while i < n && self.keys[i] >> shift == key {
                let wi = self.weight[i];
                w += wi;
                for (ca, pa) in c.iter_mut().zip(self.pos[i]) {
                    *ca += wi * pa;
                }
                i += 1;
            }
            f(w, [c[0] / w, c[1] / w, c[2] / w]);
        }
    }

    /// Total weight (number of merged points).
    pub fn total_weight(&self) -> f64 {
        self.weight.iter().sum()
    }
}

/// The normalisation for a set of (finite) positions: `None` when there are
/// none or they all coincide.
pub fn normalization(points: &[[f64; 3]], scale: f64) -> Option<Normalization> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if points.is_empty() || extent.is_nan() || extent <= 0.0 {
        return None;
    }
    Some(Normalization {
        center: [
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ],
        side: extent * scale,
    })
}

/// Merges points (unit-cube positions, unit normals, optional colours) into
/// one sample per depth-`depth` cell. Positions outside the cube are clamped
/// into its border cells.
pub fn merge(pos: &[[f64; 3]], nrm: &[[f64; 3]], col: Option<&[[u8; 3]]>, depth: u32) -> Samples {
    let res = 1i64 << depth;
    let cell = |u: f64| ((u * res as f64).floor() as i64).clamp(0, res - 1) as i32;
    let mut order: Vec<(u64, u32)> = pos
        .par_iter()
        .enumerate()
        .map(|(i, p)| (morton([cell(p[0]), cell(p[1]), cell(p[2])]), i as u32))
        .collect();
    order.par_sort_unstable();
    let mut s = Samples {
        depth,
        color: col.map(|_| Vec::new()),
        ..Default::default()
    };
    let mut i = 0;
    while i < order.len() {
        let key = order[i].0;
        let mut j = i;
        let mut w = 0.0;
        let mut p = [0.0; 3];
        let mut n = [0.0; 3];
        let mut c = [0.0f64; 3];
        while j < order.len() && order[j].0 == key {
            let k = order[j].1 as usize;
            w += 1.0;
            for a in 0..3 {
                p[a] += pos[k][a];
                n[a] += nrm[k][a];
            }
            if let Some(col) = col {
                for a in 0..3 {
                    c[a] += col[k][a] as f64;
                }
            }
            j += 1;
        }
        s.keys.push(key);
        s.pos.push([p[0] / w, p[1] / w, p[2] / w]);
        s.normal.push(n);
        s.weight.push(w);
        if let Some(cs) = &mut s.color {
            cs.push([(c[0] / w) as f32, (c[1] / w) as f32, (c[2] / w) as f32]);
        }
        i = j;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merge_sums_per_cell() {
        // Two points share a depth-2 cell, one is alone: two samples.
        let pos = [[0.1, 0.1, 0.1], [0.2, 0.15, 0.1], [0.9, 0.9, 0.9]];
        let nrm = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let s = merge(&pos, &nrm, None, 2);
        assert_eq!(s.len(), 2);
        assert_eq!(s.weight, vec![2.0, 1.0]);
        assert!((s.pos[0][0] - 0.15).abs() < 1e-12);
        assert_eq!(s.normal[0], [1.0, 1.0, 0.0]);
        let n = normalization(&[[0.0, 0.0, 0.0], [2.0, 1.0, 0.0]], 1.1).unwrap();
        assert!((n.side - 2.2).abs() < 1e-12);
        let u = n.to_unit([2.0, 1.0, 0.0]);
        assert!((n.to_world(u)[0] - 2.0).abs() < 1e-12);
        assert!(normalization(&[[1.0; 3], [1.0; 3]], 1.1).is_none());
    }
}
