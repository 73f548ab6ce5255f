//! Exact geometric predicates for the tetrahedralisation: Shewchuk's
//! adaptive orientation and in-sphere tests (the `robust` crate), and the
//! symbolic perturbation that breaks co-spherical ties.
//!
//! Sign conventions are `robust`'s:
//! - [`orient`]`(a, b, c, d) > 0` when `d` lies below the plane of `a, b, c`,
//!   "below" meaning the side from which `a, b, c` appear clockwise; in terms
//!   of the usual signed volume, `((b − a) × (c − a)) · (d − a) < 0`. Every tet
//!   of the triangulation has `orient > 0` ("positive").
//! - [`insphere`]`(a, b, c, d, e) > 0` when `e` lies strictly inside the sphere
//!   through a positive tet `a, b, c, d`.
//!
//! Both are exact as long as no intermediate product overflows or underflows
//! (the caller keeps coordinates within about 2^±60 of 1, see
//! `super::input`).

use robust::Coord3D;

/// A point as `robust` takes it.
#[inline(always)]
fn c(p: [f64; 3]) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

/// The exact orientation of `a, b, c, d` (sign convention in the module doc).
#[inline(always)]
pub(super) fn orient(a: [f64; 3], b: [f64; 3], c_: [f64; 3], d: [f64; 3]) -> f64 {
    robust::orient3d(c(a), c(b), c(c_), c(d))
}

/// The exact in-sphere determinant of `e` against the positive tet
/// `a, b, c, d`: positive inside, negative outside, zero on the sphere.
#[inline(always)]
pub(super) fn insphere(a: [f64; 3], b: [f64; 3], c_: [f64; 3], d: [f64; 3], e: [f64; 3]) -> f64 {
    robust::insphere(c(a), c(b), c(c_), c(d), c(e))
}

/// True when the three points are collinear (exactly: every coordinate-plane
/// projection of the triangle has zero signed area, i.e. the cross product
/// `(b − a) × (c − a)` is exactly zero).
pub(super) fn collinear(a: [f64; 3], b: [f64; 3], c_: [f64; 3]) -> bool {
    use robust::{Coord, orient2d};
    let proj = |p: [f64; 3], i: usize, j: usize| Coord { x: p[i], y: p[j] };
    [(0, 1), (1, 2), (2, 0)]
        .iter()
        .all(|&(i, j)| orient2d(proj(a, i, j), proj(b, i, j), proj(c_, i, j)) == 0.0)
}

/// Whether point `e` (vertex number `ie`) is in conflict with the positive
/// tet `p[0..4]` (vertex numbers `ids`): strictly inside its circumsphere, with
/// exact ties broken by a symbolic perturbation.
///
/// The perturbation raises the lifted coordinate |x|² of every point by an
/// infinitesimal ε_i, where ε_i ≫ ε_j whenever vertex number i > j (a fixed total
/// order, so every test sees the same perturbed point set: the result is the
/// Delaunay triangulation of the perturbed points, a regular triangulation
/// with infinitesimal weights, which is one of the Delaunay triangulations of
/// the input). The in-sphere determinant is linear in each lift, so its
/// perturbed sign is that of the first non-zero term, taken in decreasing
/// vertex-number order: for `e` itself the term is −orient(tet) < 0 (outside); for
/// tet vertex k it is +orient(tet with vertex k replaced by `e`).
#[inline]
pub(super) fn conflict_sos(p: [[f64; 3]; 4], ids: [u32; 4], e: [f64; 3], ie: u32) -> bool {
    let s = insphere(p[0], p[1], p[2], p[3], e);
    if s != 0.0 {
        return s > 0.0;
    }
    perturbed_tie(p, ids, e, ie)
}

/// The perturbed sign of an exactly co-spherical configuration (see
/// [`conflict_sos`]); split out so the hot path stays small.
#[cold]
fn perturbed_tie(p: [[f64; 3]; 4], ids: [u32; 4], e: [f64; 3], ie: u32) -> bool {
    // Positions 0..4 are the tet's vertices, 4 is `e`; highest index first.
    let all = [ids[0], ids[1], ids[2], ids[3], ie];
    let mut order = [0usize, 1, 2, 3, 4];
    order.sort_unstable_by(|&a, &b| all[b].cmp(&all[a]));
    for k in order {
        if k == 4 {
            return false;
        }
        let mut q = p;
        q[k] = e;
        let o = orient(q[0], q[1], q[2], q[3]);
        if o != 0.0 {
            return o > 0.0;
        }
    }
    // Not reached: the term of `e` is never zero for a non-flat tet.
    false
}
