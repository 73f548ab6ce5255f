//! Input preparation: finiteness check, exact power-of-two scaling into the
//! range where the predicates are exact, duplicate removal.

use crate::{Error, Result};

/// Coordinates smaller in magnitude than the largest one times 2^-`TINY_EXP`
/// are taken as 0 (see [`prepare`]).
pub(super) const TINY_EXP: i32 = 80;

/// The index of the first point with a NaN or infinite coordinate, as an
/// error naming it.
pub(super) fn check_finite(points: &[[f64; 3]]) -> Result<()> {
    match points.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
        None => Ok(()),
        Some(i) => {
            let p = points[i];
            Err(Error::invalid(format!(
                "Delaunay: point {i} has a non-finite coordinate ({}, {}, {})",
                p[0], p[1], p[2]
            )))
        }
    }
}

/// `x · 2^k`, exact while the result and the steps stay normal.
fn ldexp(mut x: f64, mut k: i32) -> f64 {
    while k > 1000 {
        x *= 2f64.powi(1000);
        k -= 1000;
    }
    while k < -1000 {
        x *= 2f64.powi(-1000);
        k += 1000;
    }
    x * 2f64.powi(k)
}

/// The points the predicates see: every coordinate multiplied by the power
/// of two that brings the largest magnitude M into [1, 2) (exact, and no
/// orientation or in-sphere sign changes), after coordinates below
/// M·2^-[`TINY_EXP`] are set to 0 (so that no product inside the predicates
/// underflows; such a coordinate moves by less than 1e-24 of the extent).
/// All points must be finite.
pub(super) fn prepare(points: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let m = points
        .iter()
        .flat_map(|p| p.iter())
        .fold(0.0f64, |a, &x| a.max(x.abs()));
    if m == 0.0 {
        return vec![[0.0; 3]; points.len()];
    }
    let mut e = m.log2().floor() as i32;
    while ldexp(m, -e) >= 2.0 {
        e += 1;
    }
    while ldexp(m, -e) < 1.0 {
        e -= 1;
    }
    let tiny = ldexp(1.0, -TINY_EXP);
    points
        .iter()
        .map(|p| {
            p.map(|x| {
                let y = ldexp(x, -e);
                // `+ 0.0` turns -0.0 into 0.0, so equal points compare equal
                // bit for bit.
                if y.abs() < tiny { 0.0 } else { y + 0.0 }
            })
        })
        .collect()
}

/// The indices of the distinct points, each the first (lowest index) of its
/// group of equal points, in increasing order.
pub(super) fn distinct(points: &[[f64; 3]]) -> Vec<u32> {
    let mut ids: Vec<u32> = (0..points.len() as u32).collect();
    let key = |i: u32| points[i as usize];
    ids.sort_unstable_by(|&a, &b| {
        let (p, q) = (key(a), key(b));
        p[0].total_cmp(&q[0])
            .then(p[1].total_cmp(&q[1]))
            .then(p[2].total_cmp(&q[2]))
            .then(a.cmp(&b))
    });
    let mut keep: Vec<u32> = Vec::with_capacity(ids.len());
    let mut last: Option<[f64; 3]> = None;
    for &i in &ids {
        let p = key(i);
        if last != Some(p) {
            keep.push(i);
            last = Some(p);
        }
    }
    keep.sort_unstable();
    keep
}
