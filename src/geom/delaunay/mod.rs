//! 3-D Delaunay tetrahedralisation of a point set, as GOF's tetrahedral
//! mesh extraction needs it (GOF calls CGAL's `Delaunay_triangulation_3`).
//!
//! Randomised incremental construction (Bowyer–Watson) with exact
//! predicates:
//! - [`predicates`]: Shewchuk's adaptive exact `orient3d` / `insphere` (the
//!   `robust` crate) and the symbolic perturbation that settles exactly
//!   co-spherical points (grids, spheres), so the cavity of a new point is
//!   always a ball star-shaped from it;
//! - [`spatial_sort`]: insertion in a biased randomised order whose rounds
//!   are sorted along a Hilbert curve (short point-location walks);
//! - [`triangulation`]: the tets with neighbour links, closed by an
//!   "infinite vertex", stochastic visibility walks and cavity insertion;
//! - [`input`]: finiteness, the exact power-of-two scaling, duplicates.
//!
//! Memory: `geom` may not read the budget (`io::budget`) itself. A caller
//! checks [`estimated_bytes`] against it before calling, or passes its
//! usable bytes to [`tetrahedralize_within`], which also stops with an error
//! if the tets outgrow it (a degenerate input can have far more tets than
//! the usual ≈ 6.7 per point).

mod input;
mod predicates;
mod spatial_sort;
mod triangulation;

#[cfg(test)]
mod tests;

use crate::{Error, Result};
use triangulation::{TET_BYTES, Triangulation};

/// Delaunay tetrahedralisation of `points`: the tets of a Delaunay
/// triangulation of their convex hull, as quadruples of indices into
/// `points`.
///
/// - Orientation: every tet `[a, b, c, d]` is positive in the convention of
///   `robust::orient3d`: `orient3d(p[a], p[b], p[c], p[d]) > 0`, i.e. `p[d]`
///   lies on the side of the plane of `p[a], p[b], p[c]` from which those
///   three appear clockwise; in terms of the usual signed volume
///   `((p[b] − p[a]) × (p[c] − p[a])) · (p[d] − p[a]) < 0`. No tet is flat.
/// - Empty spheres: no input point lies strictly inside any tet's
///   circumsphere (tested exactly). Where five or more points are
///   co-spherical, the tie is settled by a symbolic perturbation in a fixed
///   order of the points (their insertion order, itself determined by the
///   input), so the output is one of the Delaunay triangulations and is
///   fully determined by the input.
/// - Duplicates: of equal points only the first (lowest index) is used; the
///   others are in no tet. Every other point is a vertex of some tet.
/// - Fewer than 4 distinct points, or all points coplanar: `Ok(empty)`.
/// - A NaN or infinite coordinate: `Err` naming the point's index.
/// - Coordinates are scaled by a power of two (exact) into the range where
///   the predicates are exact; a coordinate smaller than 2^-80 times the
///   largest magnitude is taken as 0 (the result is exact for the points so
///   rounded).
/// - Deterministic: the same input gives the same output (order of tets
///   included); no threads are used.
///
/// The work is O(n log n) expected for well-spread points (about 1 M points
/// in a few seconds on one core, docs/BENCHMARKS.md); memory about
/// [`estimated_bytes`]. Use [`tetrahedralize_within`] to bound memory.
pub fn tetrahedralize(points: &[[f64; 3]]) -> Result<Vec<[u32; 4]>> {
    tetrahedralize_within(points, u64::MAX)
}

/// Bytes per point of [`estimated_bytes`]: about 7.5 tet slots of
/// [`TET_BYTES`], the scaled copy of the points (24), the insertion order
/// and its sort keys (20) and the output (≈ 6.7 × 16).
const BYTES_PER_POINT: u64 = 400;

/// The memory [`tetrahedralize`] needs for `n` points in the usual case
/// (≈ 6.7 tets per point): about 400 bytes per point. Degenerate inputs may
/// need more; [`tetrahedralize_within`] enforces a hard limit.
pub fn estimated_bytes(n: usize) -> u64 {
    (n as u64).saturating_mul(BYTES_PER_POINT) + (1 << 20)
}

/// [`tetrahedralize`] within `max_bytes` of memory: refused up front when
/// [`estimated_bytes`] exceeds it, and stopped with an error when the tets
/// outgrow it.
pub fn tetrahedralize_within(points: &[[f64; 3]], max_bytes: u64) -> Result<Vec<[u32; 4]>> {
    tetrahedralize_with_progress(points, max_bytes, &mut |_, _| {})
}

/// Points inserted between two calls of the progress callback.
pub const PROGRESS_STEP: usize = 1 << 16;

/// [`tetrahedralize_within`] reporting progress: `progress(done, total)` is
/// called with the number of distinct points inserted so far and their
/// total, every [`PROGRESS_STEP`] points and once at the end (not at all
/// when there is nothing to triangulate).
pub fn tetrahedralize_with_progress(
    points: &[[f64; 3]],
    max_bytes: u64,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Vec<[u32; 4]>> {
    let n = points.len();
    if n as u64 >= (u32::MAX - 2) as u64 {
        return Err(Error::invalid(format!(
            "Delaunay: {n} points are more than the {} that 32-bit indices allow",
            u32::MAX - 3
        )));
    }
    input::check_finite(points)?;
    let need = estimated_bytes(n);
    if need > max_bytes {
        return Err(Error::invalid(format!(
            "Delaunay: {n} points need about {need} bytes, more than the limit of {max_bytes}"
        )));
    }
    let pts = input::prepare(points);
    let mut ids = input::distinct(&pts);
    spatial_sort::brio_hilbert(&pts, &mut ids);
    let Some(first) = initial_tet(&pts, &mut ids) else {
        return Ok(Vec::new());
    };
    let fixed = n as u64 * (BYTES_PER_POINT - 8 * TET_BYTES);
    let max_tets = (max_bytes.saturating_sub(fixed) / TET_BYTES).min(u32::MAX as u64 - 4) as usize;
    let capacity = (ids.len() * 15 / 2 + 16).min(max_tets);
    // The points in insertion order: vertex k of the triangulation is
    // input point ids[k], so that points near in space are near in memory.
    let sorted: Vec<[f64; 3]> = ids.iter().map(|&i| pts[i as usize]).collect();
    drop(pts);
    let mut tri = Triangulation::new(&sorted, first, capacity, max_tets);
    let total = sorted.len();
    for k in 4..total {
        tri.insert(k as u32)?;
        if (k + 1) % PROGRESS_STEP == 0 {
            progress(k + 1, total);
        }
    }
    progress(total, total);
    Ok(tri.finite_tets(&ids))
}

/// Picks the first tet: the first point of the order, the next, the first
/// not collinear with them and the first not coplanar with those three,
/// moved to the front of `ids` (the rest keep their order). Returns the
/// positions in `ids` (0..4) of a positive tet on them; `None` when all
/// points are coplanar (or fewer than 4).
fn initial_tet(pts: &[[f64; 3]], ids: &mut Vec<u32>) -> Option<[u32; 4]> {
    if ids.len() < 4 {
        return None;
    }
    let p = |i: u32| pts[i as usize];
    let (a, b) = (ids[0], ids[1]);
    let k2 = (2..ids.len()).find(|&k| !predicates::collinear(p(a), p(b), p(ids[k])))?;
    let c = ids[k2];
    let k3 =
        (k2 + 1..ids.len()).find(|&k| predicates::orient(p(a), p(b), p(c), p(ids[k])) != 0.0)?;
    let d = ids[k3];
    ids.remove(k3);
    ids.remove(k2);
    ids.splice(2..2, [c, d]);
    // Vertices 0..4 of the triangulation are ids[0..4].
    if predicates::orient(p(a), p(b), p(c), p(d)) > 0.0 {
        Some([0, 1, 2, 3])
    } else {
        Some([1, 0, 2, 3])
    }
}
