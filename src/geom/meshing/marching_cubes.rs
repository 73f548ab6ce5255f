//! Marching-cubes polygon table shared by the iso-surface extractors
//! (Poisson, TSDF), built at start-up from face rules rather than typed in.
//!
//! Corners of the unit cube are numbered by their bits: corner k sits at
//! (k & 1, (k >> 1) & 1, k >> 2). Edge e runs along axis e / 4 from the
//! corner with that axis bit clear (see [`edge_corners`]). A case is the
//! 8-bit set of *inside* corners.
//!
//! On every cube face the iso-segments join the crossings so that inside
//! corners are kept apart (on a face whose diagonal corners are inside and
//! the others outside, the two inside corners get a segment each). Both
//! cubes sharing a face see it the same way, so the surface is watertight
//! and edge-manifold. The segments chain into loops, [`table`]`()[case]`,
//! oriented so that a loop's right-hand normal points away from the inside
//! corners; [`triangulate`] splits a loop of more than three vertices by a
//! minimum-area triangulation.
//!
//! This is not the Lorensen/Bourke table that Open3D and skimage use: that
//! table resolves an ambiguous face by which of the two complementary cases
//! was typed, so neighbouring cubes can disagree and leave cracks. On cubes
//! without an ambiguous face both give the same polygon (the triangulation
//! of a polygon with more than three vertices may differ).

use std::sync::OnceLock;

/// Edge `e` of the unit cube: axis `e / 4`, the other two coordinates from
/// the bits of `e % 4` (lower axis first). Returns its two corners.
pub fn edge_corners(e: usize) -> (usize, usize) {
    let axis = e / 4;
    let (u, v) = match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let base = ((e & 1) << u) | (((e >> 1) & 1) << v);
    (base, base | (1 << axis))
}

pub fn edge_between(a: usize, b: usize) -> usize {
    (0..12)
        .find(|&e| {
            let (p, q) = edge_corners(e);
            (p == a && q == b) || (p == b && q == a)
        })
        .expect("adjacent corners")
}

/// Loops (as cube-edge lists) for each of the 256 inside/outside cases.
pub fn table() -> &'static Vec<Vec<Vec<u8>>> {
    static T: OnceLock<Vec<Vec<Vec<u8>>>> = OnceLock::new();
    T.get_or_init(|| {
        // Faces: corners counter-clockwise seen from outside the cube.
        let mut faces: Vec<[usize; 4]> = Vec::new();
        for a in 0..3usize {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            for s in 0..2usize {
                let c = |cu: usize, cv: usize| (s << a) | (cu << u) | (cv << v);
                faces.push(if s == 1 {
                    [c(0, 0), c(1, 0), c(1, 1), c(0, 1)]
                } else {
                    [c(0, 0), c(0, 1), c(1, 1), c(1, 0)]
                });
            }
        }
        (0..256usize)
            .map(|case| {
                let inside = |k: usize| case >> k & 1 == 1;
                let mut next = [usize::MAX; 12];
                for f in &faces {
                    let e = |i: usize| edge_between(f[i], f[(i + 1) % 4]);
                    let cross: Vec<usize> = (0..4)
                        .filter(|&i| inside(f[i]) != inside(f[(i + 1) % 4]))
                        .collect();
                    if cross.len() == 2 {
                        let (i, j) = (cross[0], cross[1]);
                        // entering: outside → inside along the face order
                        let (enter, leave) = if inside(f[(i + 1) % 4]) {
                            (i, j)
                        } else {
                            (j, i)
                        };
                        next[e(enter)] = e(leave);
                    } else if cross.len() == 4 {
                        for i in 0..4 {
                            if inside(f[i]) {
                                next[e((i + 3) % 4)] = e(i);
                            }
                        }
                    }
                }
                let mut seen = [false; 12];
                let mut loops = Vec::new();
                for s in 0..12 {
                    if next[s] == usize::MAX || seen[s] {
                        continue;
                    }
                    let mut l = Vec::new();
                    let mut c = s;
                    while !seen[c] {
                        seen[c] = true;
                        l.push(c as u8);
                        c = next[c];
                    }
                    loops.push(l);
                }
                loops
            })
            .collect()
    })
}

fn tri_area(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3]) -> f64 {
    let x = crate::geom::mesh_ops::clean::triangle_cross(*a, *b, *c);
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

/// Minimum-area triangulation of a polygon (indices into `pos`), keeping
/// its orientation.
pub fn triangulate(poly: &[u32], pos: &[[f64; 3]], out: &mut Vec<[u32; 3]>) {
    let n = poly.len();
    if n == 3 {
        out.push([poly[0], poly[1], poly[2]]);
        return;
    }
    let p = |i: usize| &pos[poly[i] as usize];
    let mut cost = vec![0.0f64; n * n];
    let mut split = vec![0usize; n * n];
    for len in 2..n {
        for i in 0..n - len {
            let j = i + len;
            let mut best = f64::INFINITY;
            for k in i + 1..j {
                let c = cost[i * n + k] + cost[k * n + j] + tri_area(p(i), p(k), p(j));
                if c < best {
                    best = c;
                    split[i * n + j] = k;
                }
            }
            cost[i * n + j] = best;
        }
    }
    let mut stack = vec![(0usize, n - 1)];
    while let Some((i, j)) = stack.pop() {
        if j <= i + 1 {
            continue;
        }
        let k = split[i * n + j];
        out.push([poly[i], poly[k], poly[j]]);
        stack.push((i, k));
        stack.push((k, j));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_is_closed_and_complementary() {
        let t = table();
        assert!(t[0].is_empty() && t[255].is_empty());
        for (case, loops) in t.iter().enumerate() {
            // every crossing edge appears in exactly one loop
            let mut count = [0usize; 12];
            for l in loops {
                assert!(l.len() >= 3, "case {case}: loop {l:?}");
                for &e in l {
                    count[e as usize] += 1;
                }
            }
            for (e, &c) in count.iter().enumerate() {
                let (a, b) = edge_corners(e);
                let crossing = (case >> a & 1) != (case >> b & 1);
                assert_eq!(c, usize::from(crossing), "case {case} edge {e}");
            }
        }
    }

    #[test]
    fn single_corner_loop_faces_away_from_inside() {
        // Only corner 0 inside: one triangle whose normal points to (1,1,1).
        let l = &table()[1][0];
        let mid = |e: u8| {
            let (a, b) = edge_corners(e as usize);
            let c = |k: usize| [(k & 1) as f64, ((k >> 1) & 1) as f64, (k >> 2) as f64];
            let (pa, pb) = (c(a), c(b));
            [
                0.5 * (pa[0] + pb[0]),
                0.5 * (pa[1] + pb[1]),
                0.5 * (pa[2] + pb[2]),
            ]
        };
        let (a, b, c) = (mid(l[0]), mid(l[1]), mid(l[2]));
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        assert!(n.iter().all(|&x| x > 0.0), "{n:?}");
    }
}
