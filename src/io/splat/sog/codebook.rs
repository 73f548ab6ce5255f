//! Codebooks of the SOG writer: splat-transform's 1-D quantiser (a
//! 256-entry codebook for pooled columns) and a deterministic k-means palette
//! for the SH rest vectors.

use rayon::prelude::*;

/// A 1-D codebook (ascending values) and one label per input value per column.
#[derive(Debug, Clone)]
pub struct Quantized {
    pub centroids: Vec<f32>,
    /// `labels[c][i]`: codebook index of column `c`, row `i`.
    pub labels: Vec<Vec<u8>>,
}

/// Optimal 1-D quantisation of pooled columns into `k` values, by the rule of
/// splat-transform's `quantize1dColumns` (k = 256, alpha = 0.5): the finite
/// values are sorted and binned into min(1024, N) bins at positions blending
/// rank (quantile) and value (uniform) by β = clamp(1 − IQR/range, 0.5,
/// 0.999); each bin is weighted by count^alpha; dynamic programming finds the
/// `k` contiguous bin ranges of least weighted squared error, whose weighted
/// means are the centroids (padded with the last when fewer bins are
/// non-empty). ±∞ get end slots 20 outside the finite range. Every value is
/// labelled with its nearest centroid (NaN: an arbitrary one).
pub fn quantize_1d(columns: &[&[f32]], k: usize, alpha: f64) -> Quantized {
    let rows = columns.first().map_or(0, |c| c.len());
    let n = rows * columns.len();
    if n == 0 {
        return Quantized {
            centroids: vec![0.0; k],
            labels: columns.iter().map(|_| vec![0; rows]).collect(),
        };
    }
    let mut finite: Vec<f32> = Vec::with_capacity(n);
    let (mut neg_inf, mut pos_inf) = (false, false);
    for c in columns {
        for &v in c.iter() {
            if v.is_finite() {
                finite.push(v);
            } else if v == f32::NEG_INFINITY {
                neg_inf = true;
            } else if v == f32::INFINITY {
                pos_inf = true;
            }
        }
    }
    finite.par_sort_unstable_by(f32::total_cmp);
    let lo_slots = neg_inf as usize;
    let hi_slots = pos_inf as usize;
    let (vmin, vmax) = match (finite.first(), finite.last()) {
        (Some(&a), Some(&b)) => (a, b),
        _ => (0.0, 0.0),
    };
    let mut centroids = vec![0f32; k];
    if lo_slots == 0 && hi_slots == 0 && (vmax as f64 - vmin as f64) < 1e-20 {
        centroids.fill(vmin);
        return Quantized {
            centroids,
            labels: columns.iter().map(|_| vec![0; rows]).collect(),
        };
    }
    let k_finite = k.saturating_sub(lo_slots + hi_slots);
    let values: Vec<f32> = if finite.is_empty() || k_finite == 0 {
        Vec::new()
    } else if (vmax as f64 - vmin as f64) < 1e-20 {
        vec![vmin]
    } else {
        quantize_finite(&finite, k_finite, alpha)
    };
    let neg_c = vmin - 20.0;
    let pos_c = vmax + 20.0;
    let pad = values
        .last()
        .copied()
        .unwrap_or(if neg_inf { neg_c } else { pos_c });
    for (i, c) in centroids.iter_mut().enumerate() {
        *c = if i >= lo_slots && i - lo_slots < values.len() {
            values[i - lo_slots]
        } else {
            pad
        };
    }
    if neg_inf {
        centroids[0] = neg_c;
    }
    if pos_inf {
        centroids[k - 1] = pos_c;
    }
    let labels = columns
        .iter()
        .map(|c| c.par_iter().map(|&v| nearest(&centroids, v)).collect())
        .collect();
    Quantized { centroids, labels }
}

/// Index of the centroid nearest `v` in ascending `c` (binary search on the
/// midpoints, as splat-transform).
pub fn nearest(c: &[f32], v: f32) -> u8 {
    let (mut lo, mut hi) = (0usize, c.len() - 1);
    let v = v as f64;
    while lo < hi {
        let mid = (lo + hi) / 2;
        if v < (c[mid] as f64 + c[mid + 1] as f64) * 0.5 {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo as u8
}

// The DP reads like its recurrence with explicit indices.
#[allow(clippy::needless_range_loop)]
fn quantize_finite(sorted: &[f32], k_target: usize, alpha: f64) -> Vec<f32> {
    let n = sorted.len();
    let vmin = sorted[0] as f64;
    let vmax = sorted[n - 1] as f64;
    let h = n.min(1024);
    let range = vmax - vmin;
    let iqr = sorted[n * 3 / 4] as f64 - sorted[n / 4] as f64;
    let beta = (1.0 - iqr / range).clamp(0.5, 0.999);
    let mut counts = vec![0f64; h];
    let mut sums = vec![0f64; h];
    for (i, &v) in sorted.iter().enumerate() {
        let uniform = (v as f64 - vmin) / range;
        let quantile = i as f64 / n as f64;
        let bin =
            ((h as f64 * (beta * quantile + (1.0 - beta) * uniform)).floor() as usize).min(h - 1);
        counts[bin] += 1.0;
        sums[bin] += v as f64;
    }
    let centers: Vec<f64> = (0..h)
        .map(|i| {
            if counts[i] > 0.0 {
                sums[i] / counts[i]
            } else {
                vmin + (i as f64 + 0.5) / h as f64 * range
            }
        })
        .collect();
    let weights: Vec<f64> = counts
        .iter()
        .map(|&c| if c > 0.0 { c.powf(alpha) } else { 0.0 })
        .collect();
    let mut pw = vec![0f64; h + 1];
    let mut pwx = vec![0f64; h + 1];
    let mut pwxx = vec![0f64; h + 1];
    for i in 0..h {
        pw[i + 1] = pw[i] + weights[i];
        pwx[i + 1] = pwx[i] + weights[i] * centers[i];
        pwxx[i + 1] = pwxx[i] + weights[i] * centers[i] * centers[i];
    }
    let cost = |a: usize, b: usize| {
        let w = pw[b + 1] - pw[a];
        if w <= 0.0 {
            return 0.0;
        }
        let wx = pwx[b + 1] - pwx[a];
        pwxx[b + 1] - pwxx[a] - wx * wx / w
    };
    let mean = |a: usize, b: usize| {
        let w = pw[b + 1] - pw[a];
        if w <= 0.0 {
            (centers[a] + centers[b]) * 0.5
        } else {
            (pwx[b + 1] - pwx[a]) / w
        }
    };
    let non_empty = counts.iter().filter(|&&c| c > 0.0).count();
    let k = k_target.min(non_empty);
    const INF: f64 = 1e30;
    let mut prev: Vec<f64> = (0..h).map(|j| cost(0, j)).collect();
    // split[m][j]: last bin of the first m−1 ranges in the best m-range split of 0..=j
    let mut split: Vec<Vec<i32>> = vec![Vec::new(); k + 1];
    split[1] = vec![-1; h];
    for m in 2..=k {
        let row: Vec<(f64, i32)> = (0..h)
            .into_par_iter()
            .map(|j| {
                if j < m - 1 {
                    return (INF, 0);
                }
                let mut best = INF;
                let mut best_s = m as i32 - 2;
                for s in (m - 2)..j {
                    let c = prev[s] + cost(s + 1, j);
                    if c < best {
                        best = c;
                        best_s = s as i32;
                    }
                }
                (best, best_s)
            })
            .collect();
        prev = row.iter().map(|r| r.0).collect();
        split[m] = row.iter().map(|r| r.1).collect();
    }
    let mut out = vec![0f32; k];
    let mut j = h as i32 - 1;
    for m in (1..=k).rev() {
        let s = if m > 1 { split[m][j as usize] } else { -1 };
        out[m - 1] = mean((s + 1) as usize, j as usize) as f32;
        j = s;
    }
    out.sort_by(f32::total_cmp);
    out
}

/// Squared distance between two vectors.
fn dist2(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Index of the row of `centroids` (rows of `dim`) nearest `p`.
fn assign_one(p: &[f32], centroids: &[f32], dim: usize) -> u32 {
    let mut best = f32::INFINITY;
    let mut bi = 0;
    for (c, row) in centroids.chunks_exact(dim).enumerate() {
        let d = dist2(p, row);
        if d < best {
            best = d;
            bi = c;
        }
    }
    bi as u32
}

/// Lloyd's k-means on the rows of `points` (`dim` columns) from `init`
/// centroids, `iters` rounds; an empty cluster keeps its centroid.
fn lloyd(points: &[f32], dim: usize, mut centroids: Vec<f32>, iters: usize) -> Vec<f32> {
    let k = centroids.len() / dim;
    for _ in 0..iters {
        let labels: Vec<u32> = points
            .par_chunks_exact(dim)
            .map(|p| assign_one(p, &centroids, dim))
            .collect();
        let mut sums = vec![0f64; k * dim];
        let mut counts = vec![0u32; k];
        for (p, &l) in points.chunks_exact(dim).zip(&labels) {
            counts[l as usize] += 1;
            for (s, &v) in sums[l as usize * dim..][..dim].iter_mut().zip(p) {
                *s += v as f64;
            }
        }
        for c in 0..k {
            if counts[c] > 0 {
                for j in 0..dim {
                    centroids[c * dim + j] = (sums[c * dim + j] / counts[c] as f64) as f32;
                }
            }
        }
    }
    centroids
}

/// `k` rows of `points` evenly spaced in their order.
fn strided_rows(points: &[f32], dim: usize, k: usize) -> Vec<f32> {
    let n = points.len() / dim;
    (0..k)
        .flat_map(|i| {
            let r = (i * n) / k;
            points[r * dim..(r + 1) * dim].iter().copied()
        })
        .collect()
}

/// k-means++ seeds: the first row drawn uniformly, each next one with
/// probability proportional to its squared distance from the nearest seed
/// so far; from the fixed random stream `stream` (deterministic).
fn seeds_pp(points: &[f32], dim: usize, k: usize, stream: u64) -> Vec<f32> {
    use rand::RngExt;
    let n = points.len() / dim;
    let mut rng = crate::model::rng::stream(0x50_47, stream);
    let first = rng.random_range(0..n);
    let mut seeds = points[first * dim..(first + 1) * dim].to_vec();
    let mut d2: Vec<f32> = points
        .par_chunks_exact(dim)
        .map(|p| dist2(p, &seeds))
        .collect();
    while seeds.len() < k * dim {
        let total: f64 = d2.iter().map(|&d| d as f64).sum();
        let pick = if total > 0.0 {
            let mut r = rng.random::<f64>() * total;
            let mut pick = n - 1;
            for (i, &d) in d2.iter().enumerate() {
                r -= d as f64;
                if r < 0.0 {
                    pick = i;
                    break;
                }
            }
            pick
        } else {
            // every row sits on a seed: further seeds are duplicates
            (seeds.len() / dim) % n
        };
        let c = points[pick * dim..(pick + 1) * dim].to_vec();
        d2.par_iter_mut()
            .zip(points.par_chunks_exact(dim))
            .for_each(|(d, p)| *d = d.min(dist2(p, &c)));
        seeds.extend(c);
    }
    seeds
}

/// Rows used to train a level of the palette: at most `cap`, evenly spaced.
fn sample(points: &[f32], dim: usize, cap: usize) -> Vec<f32> {
    let n = points.len() / dim;
    if n <= cap {
        points.to_vec()
    } else {
        strided_rows(points, dim, cap)
    }
}

/// Lloyd rounds of the palette (splat-transform's default is 10).
pub const ITERATIONS: usize = 10;

/// A palette of at most `k` centroids for the rows of `points` (`dim`
/// columns) and one label per row.
///
/// Departure from splat-transform (random seeds, plain Lloyd over a k-d tree
/// or GPU): deterministic. With fewer rows than `k` each row is its own
/// centroid (as splat-transform). When rows × k is small, Lloyd's k-means
/// ([`ITERATIONS`] rounds) from k-means++ seeds drawn from a fixed random
/// stream. Otherwise two
/// levels: √k coarse clusters trained on ≤ 64·√k evenly sampled rows, then
/// each coarse cluster gets centroids in proportion to its rows, trained on
/// ≤ 8 sampled members per centroid; each row is labelled with the nearest
/// centroid of its coarse cluster.
pub fn palette(points: &[f32], dim: usize, k: usize) -> (Vec<f32>, Vec<u32>) {
    let n = points.len() / dim;
    if n <= k {
        return (points.to_vec(), (0..n as u32).collect());
    }
    if (n as u64) * (k as u64) <= 1 << 26 {
        let c = lloyd(points, dim, seeds_pp(points, dim, k, 0), ITERATIONS);
        let labels = points
            .par_chunks_exact(dim)
            .map(|p| assign_one(p, &c, dim))
            .collect();
        return (c, labels);
    }
    let k1 = (k as f64).sqrt().ceil() as usize;
    let train = sample(points, dim, 64 * k1);
    let coarse = lloyd(&train, dim, seeds_pp(&train, dim, k1, 1), ITERATIONS);
    let coarse_labels: Vec<u32> = points
        .par_chunks_exact(dim)
        .map(|p| assign_one(p, &coarse, dim))
        .collect();
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); k1];
    for (i, &l) in coarse_labels.iter().enumerate() {
        members[l as usize].push(i as u32);
    }
    // centroids per coarse cluster, in proportion to its rows (≥ 1 if non-empty)
    let mut quota: Vec<usize> = members
        .iter()
        .map(|m| {
            if m.is_empty() {
                0
            } else {
                ((m.len() as f64 * k as f64 / n as f64).floor() as usize).clamp(1, m.len())
            }
        })
        .collect();
    let mut total: usize = quota.iter().sum();
    // hand out what rounding left, largest clusters first, never above k
    let mut order: Vec<usize> = (0..k1).collect();
    order.sort_by_key(|&c| std::cmp::Reverse(members[c].len()));
    'fill: while total < k {
        let before = total;
        for &c in &order {
            if total >= k {
                break 'fill;
            }
            if quota[c] < members[c].len() {
                quota[c] += 1;
                total += 1;
            }
        }
        if total == before {
            break;
        }
    }
    while total > k {
        let c = *order
            .iter()
            .find(|&&c| quota[c] > 1)
            .expect("k ≥ number of clusters");
        quota[c] -= 1;
        total -= 1;
    }
    let parts: Vec<(Vec<f32>, Vec<u32>)> = (0..k1)
        .into_par_iter()
        .map(|c| {
            if quota[c] == 0 {
                return (Vec::new(), Vec::new());
            }
            let rows: Vec<f32> = members[c]
                .iter()
                .flat_map(|&i| {
                    points[i as usize * dim..(i as usize + 1) * dim]
                        .iter()
                        .copied()
                })
                .collect();
            let train = sample(&rows, dim, 8 * quota[c]);
            let cent = lloyd(
                &train,
                dim,
                seeds_pp(&train, dim, quota[c], 2 + c as u64),
                ITERATIONS,
            );
            let labels = rows
                .chunks_exact(dim)
                .map(|p| assign_one(p, &cent, dim))
                .collect();
            (cent, labels)
        })
        .collect();
    let mut centroids = Vec::with_capacity(k * dim);
    let mut labels = vec![0u32; n];
    for (c, (cent, lab)) in parts.into_iter().enumerate() {
        let base = (centroids.len() / dim) as u32;
        for (&i, &l) in members[c].iter().zip(&lab) {
            labels[i as usize] = base + l;
        }
        centroids.extend(cent);
    }
    (centroids, labels)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fewer distinct values than codebook entries are reproduced exactly.
    #[test]
    fn few_values_are_exact() {
        let a = [1.0f32, 2.0, 3.0, 2.0];
        let b = [3.0f32, 1.0, -4.0, 7.5];
        let q = quantize_1d(&[&a, &b], 256, 0.5);
        for (col, data) in [&a[..], &b[..]].iter().enumerate() {
            for (i, &v) in data.iter().enumerate() {
                assert_eq!(q.centroids[q.labels[col][i] as usize], v);
            }
        }
        assert!(q.centroids.windows(2).all(|w| w[0] <= w[1]));
    }

    /// 256 entries for a smooth distribution: the worst error is well below the
    /// uniform step of the range and the codebook is sorted.
    #[test]
    fn codebook_error_is_small() {
        let v: Vec<f32> = (0..20_000)
            .map(|i| ((i as f32) * 0.618).sin() * 3.0)
            .collect();
        let q = quantize_1d(&[&v], 256, 0.5);
        let worst = v
            .iter()
            .zip(&q.labels[0])
            .map(|(x, &l)| (x - q.centroids[l as usize]).abs())
            .fold(0f32, f32::max);
        // uniform 256 levels over [-3, 3] would give 6/255/2 = 0.0118
        assert!(worst < 0.03, "worst {worst}");
        assert!(q.centroids.windows(2).all(|w| w[0] <= w[1]));
        let inf = quantize_1d(&[&[f32::NEG_INFINITY, 0.0, 1.0]], 256, 0.5);
        let decoded: Vec<f32> = inf.labels[0]
            .iter()
            .map(|&l| inf.centroids[l as usize])
            .collect();
        assert_eq!(decoded, vec![-20.0, 0.0, 1.0]);
    }

    /// The palette labels every row with a centroid of its own size class and
    /// gives each row its own centroid when there are few rows.
    #[test]
    fn palette_clusters() {
        let dim = 3;
        let pts: Vec<f32> = (0..3000)
            .flat_map(|i| {
                let c = (i % 5) as f32;
                [c, c * 2.0, -c + (i as f32) * 1e-5]
            })
            .collect();
        let (c, l) = palette(&pts, dim, 5);
        for (i, &lab) in l.iter().enumerate() {
            let p = &pts[i * dim..(i + 1) * dim];
            assert!(dist2(p, &c[lab as usize * dim..][..dim]) < 1e-3);
        }
        let (c, l) = palette(&pts[..12], dim, 5);
        assert_eq!(c, pts[..12].to_vec());
        assert_eq!(l, vec![0, 1, 2, 3]);
        // the two-level path keeps the palette size
        let big: Vec<f32> = (0..70_000)
            .map(|i| ((i * 7919) % 1000) as f32 * 1e-3)
            .collect();
        let (c, l) = palette(&big, 1, 1024);
        assert!(c.len() <= 1024 && c.len() > 900);
        let worst = big
            .iter()
            .zip(&l)
            .map(|(v, &lab)| (v - c[lab as usize]).abs())
            .fold(0f32, f32::max);
        assert!(worst < 0.02, "worst {worst}");
    }
}
