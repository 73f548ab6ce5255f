//! The insertion order: a biased randomised insertion order (BRIO, Amenta,
//! Choi and Rote 2003) whose rounds are each sorted along a Hilbert curve,
//! so that consecutive points are close (short location walks) while the
//! rounds keep the randomisation that bounds the expected work.

use rand::seq::SliceRandom;

/// Bits per axis of the Hilbert grid (3 × 21 = 63-bit keys).
const BITS: u32 = 21;
/// Smallest round: the first `FIRST_ROUND` points (or fewer) form round 0.
const FIRST_ROUND: usize = 1000;
/// Each round has `ROUND_RATIO - 1` times the points of all earlier rounds.
const ROUND_RATIO: usize = 4;
/// Seed of the shuffle (fixed: the output depends only on the input).
const SEED: u64 = 0x6465_6c61_756e_6179;

/// Reorders `ids` (indices into `points`) in place into the insertion order:
/// a seeded shuffle, cut into rounds of geometrically growing size
/// (`FIRST_ROUND`, then ×`ROUND_RATIO`), each sorted by the Hilbert index of
/// its points on a 2^21-cell grid over the bounding cube of all points. Ties
/// in the key keep the shuffled order, so the result is deterministic.
pub(super) fn brio_hilbert(points: &[[f64; 3]], ids: &mut [u32]) {
    if ids.is_empty() {
        return;
    }
    let mut rng = crate::model::rng::seeded(SEED);
    ids.shuffle(&mut rng);

    let (lo, scale) = grid(points, ids);
    let key = |i: u32| -> u64 {
        let p = points[i as usize];
        let q = |k: usize| -> u32 {
            let v = ((p[k] - lo[k]) * scale).floor();
            v.clamp(0.0, ((1u32 << BITS) - 1) as f64) as u32
        };
        hilbert_key([q(0), q(1), q(2)])
    };

    // Round boundaries from the end: n, n/4, n/16, … down to FIRST_ROUND.
    let mut ends = vec![ids.len()];
    while *ends.last().unwrap_or(&0) > FIRST_ROUND {
        let last = ends[ends.len() - 1];
        ends.push(last / ROUND_RATIO);
    }
    ends.push(0);
    ends.reverse();
    let mut keyed: Vec<(u64, u32)> = Vec::new();
    for w in ends.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a {
            continue;
        }
        keyed.clear();
        keyed.extend(ids[a..b].iter().map(|&i| (key(i), i)));
        // Stable sort by key only: equal keys keep their shuffled order.
        keyed.sort_by_key(|&(k, _)| k);
        for (dst, &(_, i)) in ids[a..b].iter_mut().zip(keyed.iter()) {
            *dst = i;
        }
    }
}

/// Lower corner and cells-per-unit of the grid over the bounding cube of
/// `ids`' points.
fn grid(points: &[[f64; 3]], ids: &[u32]) -> ([f64; 3], f64) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in ids {
        let p = points[i as usize];
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f64, f64::max);
    let cells = (1u64 << BITS) as f64;
    let scale = if extent > 0.0 && (cells / extent).is_finite() {
        cells / extent
    } else {
        0.0
    };
    (lo, scale)
}

/// The index of grid cell `x` (each coordinate < 2^21) along the 3-D Hilbert
/// curve, by Skilling's transposition ("Programming the Hilbert curve",
/// AIP Conf. Proc. 707, 2004): the coordinates are turned into the curve's
/// transposed index, then its bits are interleaved, most significant first.
pub(super) fn hilbert_key(mut x: [u32; 3]) -> u64 {
    let top = 1u32 << (BITS - 1);
    // Undo the excess work of the recursive construction.
    let mut q = top;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    // Gray encode.
    x[1] ^= x[0];
    x[2] ^= x[1];
    let mut t = 0;
    let mut q = top;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for v in &mut x {
        *v ^= t;
    }
    // Interleave: bit b of x[0], x[1], x[2], from the top bit down.
    let mut key = 0u64;
    for b in (0..BITS).rev() {
        for v in &x {
            key = (key << 1) | ((v >> b) & 1) as u64;
        }
    }
    key
}
