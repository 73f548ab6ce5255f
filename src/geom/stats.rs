//! Summary statistics of distance sets (Chamfer accuracy / completeness,
//! F-score precision / recall).
//!
//! Sums use numpy's pairwise summation (the algorithm of `np.add.reduce` on a
//! contiguous float64 array: 8 interleaved accumulators on blocks of at most
//! 128 values, halving at multiples of 8 above that), so [`mean_below`] and
//! [`DistanceStats::mean`] equal numpy's `d[d < cap].mean()` / `d.mean()` bit
//! for bit on the same values, and are deterministic (fixed order, no
//! threads). Percentiles follow `np.percentile(..., method="linear")` and the
//! median `np.median`.

/// numpy's pairwise sum of a contiguous float64 array, `0.0 + pairwise(a)`.
pub fn pairwise_sum(a: &[f64]) -> f64 {
    0.0 + pairwise_rec(a)
}

fn pairwise_rec(a: &[f64]) -> f64 {
    let n = a.len();
    if n < 8 {
        a.iter().fold(0.0, |s, &x| s + x)
    } else if n <= 128 {
        let mut r = [a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]];
        let full = n - n % 8;
        for block in a[8..full].chunks_exact(8) {
            for (acc, &x) in r.iter_mut().zip(block) {
                *acc += x;
            }
        }
        let head = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        a[full..].iter().fold(head, |s, &x| s + x)
    } else {
        let half = n / 2;
        let half = half - half % 8;
        pairwise_rec(&a[..half]) + pairwise_rec(&a[half..])
    }
}

/// Summary of a set of distances (same unit as the input).
///
/// For an empty input `count` is 0 and every other field is NaN. NaN inputs
/// propagate into `mean` and `rms` and sort after every number (so they
/// become `max` and may enter the upper percentiles); callers pass finite
/// distances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceStats {
    /// Number of distances.
    pub count: usize,
    /// Arithmetic mean (numpy pairwise sum / count).
    pub mean: f64,
    /// Median as `np.median`: the middle value, or the mean `(a + b) / 2` of
    /// the two middle values for an even count.
    pub median: f64,
    /// Root mean square, `sqrt(mean(d²))`.
    pub rms: f64,
    /// 90th percentile (`np.percentile`, linear method).
    pub p90: f64,
    /// 95th percentile (linear method).
    pub p95: f64,
    /// 99th percentile (linear method).
    pub p99: f64,
    /// Largest distance.
    pub max: f64,
    /// Smallest distance.
    pub min: f64,
}

/// The `q`-th percentile (0..=100) of ascending `sorted` by numpy's default
/// linear method: virtual index `h = (n−1)·(q/100)`, `lo = floor(h)`,
/// `t = h − lo`, and numpy's `_lerp`: `a + (b−a)·t` for `t < 0.5`,
/// `b − (b−a)·(1−t)` otherwise, with `a = sorted[lo]`, `b = sorted[min(lo+1, n−1)]`.
/// NaN for an empty slice.
pub fn percentile_sorted(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    let h = (n - 1) as f64 * (q / 100.0);
    let lo_f = h.floor().clamp(0.0, (n - 1) as f64);
    let t = h - lo_f;
    let lo = lo_f as usize;
    let hi = (lo + 1).min(n - 1);
    let (a, b) = (sorted[lo], sorted[hi]);
    let diff = b - a;
    if t >= 0.5 {
        b - diff * (1.0 - t)
    } else {
        a + diff * t
    }
}

impl DistanceStats {
    /// Computes the statistics of `d` (copied and sorted internally with
    /// `f64::total_cmp`; the input order does not matter except for the last
    /// bits of `mean` and `rms`, which are summed in input order).
    pub fn from_distances(d: &[f64]) -> DistanceStats {
        let n = d.len();
        if n == 0 {
            return DistanceStats {
                count: 0,
                mean: f64::NAN,
                median: f64::NAN,
                rms: f64::NAN,
                p90: f64::NAN,
                p95: f64::NAN,
                p99: f64::NAN,
                max: f64::NAN,
                min: f64::NAN,
            };
        }
        let mean = pairwise_sum(d) / n as f64;
        let squares: Vec<f64> = d.iter().map(|x| x * x).collect();
        let rms = (pairwise_sum(&squares) / n as f64).sqrt();
        let mut sorted = squares;
        sorted.copy_from_slice(d);
        sorted.sort_unstable_by(f64::total_cmp);
        let median = if n % 2 == 1 {
            sorted[n / 2]
        } else {
            (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
        };
        DistanceStats {
            count: n,
            mean,
            median,
            rms,
            p90: percentile_sorted(&sorted, 90.0),
            p95: percentile_sorted(&sorted, 95.0),
            p99: percentile_sorted(&sorted, 99.0),
            max: sorted[n - 1],
            min: sorted[0],
        }
    }
}

/// Mean of the values strictly below `cap`, and how many there are: DTU
/// step 7–8, `mean(d[d < max_dist])` with `max_dist = 20` mm. Values `>= cap`
/// (and NaN) are discarded, not clamped. Summed as numpy does, so the result
/// equals numpy's on the same values. An empty selection gives `(NaN, 0)`
/// (numpy's mean of an empty array).
pub fn mean_below(d: &[f64], cap: f64) -> (f64, usize) {
    let kept: Vec<f64> = d.iter().copied().filter(|&x| x < cap).collect();
    if kept.is_empty() {
        return (f64::NAN, 0);
    }
    (pairwise_sum(&kept) / kept.len() as f64, kept.len())
}

/// Fraction of the values strictly below `tau`, as Tanks-and-Temples
/// precision / recall (`sum(d < τ) / len(d)`). NaN counts as not below.
/// An empty slice gives NaN (the reference divides by zero).
pub fn fraction_below(d: &[f64], tau: f64) -> f64 {
    if d.is_empty() {
        return f64::NAN;
    }
    d.iter().filter(|&&x| x < tau).count() as f64 / d.len() as f64
}
