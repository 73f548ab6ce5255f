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
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
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

#[cfg(test)]
mod tests {
    use super::*;

    /// v_i = ((i·7919) mod 10007)·s + o for i < 10007: one rounding per value,
    /// identical in numpy and here, so numpy's results apply bit for bit.
    fn numpy_series(s: f64, o: f64) -> Vec<f64> {
        (0..10007u64)
            .map(|i| ((i * 7919) % 10007) as f64 * s + o)
            .collect()
    }

    #[test]
    fn pairwise_sum_matches_numpy_bits() {
        // Expected values printed by numpy 2.4 (`repr` round-trips exactly):
        // np.sum(v), v.mean(), v[v < 5].mean() and (v < 5).sum().
        let v = numpy_series(0.001, 0.1);
        assert_eq!(pairwise_sum(&v), 51065.721000000005);
        // A plain left-to-right sum lands one ulp higher, so this test
        // distinguishes the summation orders.
        assert_eq!(v.iter().fold(0.0, |s, x| s + x), 51065.72100000001);
        assert_eq!(DistanceStats::from_distances(&v).mean, 5.103000000000001);
        assert_eq!(mean_below(&v, 5.0), (2.5494999999999997, 4900));
        // Short inputs and the block boundaries (7/8, 128/129) agree with an
        // exact rational sum of small integers.
        for n in [0usize, 1, 7, 8, 9, 127, 128, 129, 1000] {
            let ints: Vec<f64> = (0..n).map(|i| (i % 13) as f64).collect();
            let exact: u64 = (0..n as u64).map(|i| i % 13).sum();
            assert_eq!(pairwise_sum(&ints), exact as f64, "n = {n}");
        }
    }

    #[test]
    fn hand_computed_odd_and_even_counts() {
        // Odd: sorted [1, 2, 3]; median is the middle value; p90: h = 2·0.9 =
        // 1.8 → 2 + 0.8·(3 − 2) = 2.8 (t >= ½ branch: 3 − 1·0.2).
        let s = DistanceStats::from_distances(&[3.0, 1.0, 2.0]);
        assert_eq!(
            (s.count, s.mean, s.median, s.min, s.max),
            (3, 2.0, 2.0, 1.0, 3.0)
        );
        assert_eq!(s.rms, (14.0f64 / 3.0).sqrt());
        // Values within 1 ulp of the decimal; numpy prints exactly these.
        assert_eq!((s.p90, s.p95, s.p99), (2.8, 2.9, 2.98));

        // Even: sorted [0.5, 1, 2.25, 3.5, 7, 10]; median (2.25 + 3.5)/2;
        // p90: h = 4.5 → 7 + 0.5·3 = 8.5; p95: h = 4.75 → 10 − 0.25·3 = 9.25;
        // p99: h = 4.95 → 10 − 0.05·3 = 9.85, which rounds to
        // 9.850000000000001 (numpy's value); rms = sqrt(167.5625/6).
        let s = DistanceStats::from_distances(&[0.5, 10.0, 2.25, 7.0, 1.0, 3.5]);
        assert_eq!(s.count, 6);
        assert_eq!(s.mean, 24.25 / 6.0);
        assert_eq!(s.median, 2.875);
        assert_eq!(s.rms, (167.5625f64 / 6.0).sqrt());
        assert_eq!((s.p90, s.p95, s.p99), (8.5, 9.25, 9.850000000000001));
        assert_eq!((s.min, s.max), (0.5, 10.0));

        // numpy on [4, 1, 3, 2]: p95 = 3.8499999999999996, p99 = 3.9699999999999998.
        let s = DistanceStats::from_distances(&[4.0, 1.0, 3.0, 2.0]);
        assert_eq!(
            (s.median, s.p90, s.p95, s.p99),
            (2.5, 3.7, 3.8499999999999996, 3.9699999999999998)
        );
    }

    #[test]
    fn percentiles_match_numpy_on_a_large_series() {
        // numpy 2.4: np.percentile(v, [90, 95, 99]), np.median(v),
        // np.sqrt(np.mean(v**2)) for this series (n = 10007, odd).
        let v = numpy_series(0.37, 0.01);
        let s = DistanceStats::from_distances(&v);
        assert_eq!(
            (s.p90, s.p95, s.p99),
            (3332.008, 3517.1189999999997, 3665.2078)
        );
        assert_eq!(s.median, 1851.12);
        assert_eq!(s.rms, 2137.53977787549);
        assert_eq!(percentile_sorted(&[1.0, 2.0], 0.0), 1.0);
        assert_eq!(percentile_sorted(&[1.0, 2.0], 100.0), 2.0);
        assert_eq!(percentile_sorted(&[7.0], 50.0), 7.0);
        assert!(percentile_sorted(&[], 50.0).is_nan());
    }

    #[test]
    fn empty_input_gives_nan() {
        let s = DistanceStats::from_distances(&[]);
        assert_eq!(s.count, 0);
        for x in [s.mean, s.median, s.rms, s.p90, s.p95, s.p99, s.max, s.min] {
            assert!(x.is_nan());
        }
        let (m, n) = mean_below(&[], 20.0);
        assert!(m.is_nan() && n == 0);
        assert!(fraction_below(&[], 1.0).is_nan());
    }

    #[test]
    fn mean_below_discards_values_at_or_above_the_cap() {
        // 20 (equal to the cap), 25 and NaN are discarded, not clamped:
        // mean of [1, 2, 19.5] = 22.5/3 = 7.5.
        let d = [1.0, 20.0, 2.0, 25.0, f64::NAN, 19.5];
        assert_eq!(mean_below(&d, 20.0), (7.5, 3));
        // Everything at the cap → nothing left.
        let (m, n) = mean_below(&[20.0, 20.0], 20.0);
        assert!(m.is_nan() && n == 0);
        // Clamping would have given (1 + 20 + 2 + 20 + 19.5)/5 = 12.5.
        assert_ne!(mean_below(&d, 20.0).0, 12.5);
    }

    #[test]
    fn fraction_below_is_strict() {
        let d = [0.1, 0.2, 0.2, 0.3, 0.05];
        // τ = 0.2: only 0.1 and 0.05 are < τ (the two 0.2 equal it).
        assert_eq!(fraction_below(&d, 0.2), 2.0 / 5.0);
        assert_eq!(fraction_below(&d, 0.3), 4.0 / 5.0);
        assert_eq!(fraction_below(&d, 1.0), 1.0);
        assert_eq!(fraction_below(&d, 0.0), 0.0);
        assert_eq!(fraction_below(&[f64::NAN, 0.0], 1.0), 0.5);
    }
}
