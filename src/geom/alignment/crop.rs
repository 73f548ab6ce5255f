//! Cropping by a [`CropVolume`] (a polygon prism along one coordinate axis,
//! as stored in the Tanks-and-Temples `<Scene>.json` files; Open3D
//! `SelectionPolygonVolume`).
//!
//! [`Crop::contains`] reproduces Open3D's
//! `SelectionPolygonVolume::CropInPolygon` (identical in 0.10 and 0.18)
//! decision for every point, including its boundary rules, so that the same
//! points survive cropping as in the TnT toolbox. The volume itself is a
//! plain value of [`crate::model::crop`]; reading and writing its JSON form
//! lives in [`crate::io::tnt`].

use rayon::prelude::*;

use crate::model::CropVolume;

/// The cropping operations on a [`CropVolume`]; bring the trait into scope
/// to call them as methods (`volume.crop(&points)`).
pub trait Crop {
    /// True when `p` is inside the volume, with exactly Open3D's
    /// `CropInPolygon` rule:
    ///
    /// 1. reject when `p[w] < axis_min` or `p[w] > axis_max` (bounds inclusive);
    /// 2. for each polygon edge (i, i+1 mod n) that is crossed by the line
    ///    v = p_v — i.e. one end has v < p_v and the other v ≥ p_v — compute the
    ///    crossing's u as `u_i + (p_v − v_i)/(v_j − v_i)·(u_j − u_i)` (same
    ///    operation order as Open3D);
    /// 3. the point is inside iff the number of crossings with u < p_u
    ///    (strictly) is odd.
    ///
    /// Consequences for a square: points on its left and bottom edges are
    /// outside, points on its right and top edges are inside. A polygon with
    /// fewer than 3 vertices contains nothing. As in Open3D, a NaN coordinate
    /// along the axis passes the bound test (comparisons with NaN are false)
    /// and a NaN in the polygon plane makes the point outside.
    fn contains(&self, p: &[f64; 3]) -> bool;

    /// Indices of the points inside the volume, in input order (Open3D's
    /// `CropInPolygon` output). Runs on the rayon pool; the result does not
    /// depend on the thread count.
    fn crop_indices(&self, points: &[[f64; 3]]) -> Vec<usize>;

    /// The points inside the volume, in input order (Open3D's
    /// `SelectionPolygonVolume::CropPointCloud`).
    fn crop(&self, points: &[[f64; 3]]) -> Vec<[f64; 3]>;
}

impl Crop for CropVolume {
    fn contains(&self, p: &[f64; 3]) -> bool {
        let (u, v, w) = self.orthogonal_axis.uvw();
        // Written as in Open3D: NaN passes this test and is rejected below.
        if p[w] < self.axis_min || p[w] > self.axis_max {
            return false;
        }
        let poly = &self.bounding_polygon;
        let n = poly.len();
        let (pu, pv) = (p[u], p[v]);
        let mut below = 0usize;
        for (i, a) in poly.iter().enumerate() {
            let b = &poly[(i + 1) % n];
            if (a[v] < pv && b[v] >= pv) || (b[v] < pv && a[v] >= pv) {
                let cu = a[u] + (pv - a[v]) / (b[v] - a[v]) * (b[u] - a[u]);
                if cu < pu {
                    below += 1;
                }
            }
        }
        below % 2 == 1
    }

    fn crop_indices(&self, points: &[[f64; 3]]) -> Vec<usize> {
        points
            .par_iter()
            .enumerate()
            .with_min_len(4096)
            .filter(|(_, p)| self.contains(p))
            .map(|(i, _)| i)
            .collect()
    }

    fn crop(&self, points: &[[f64; 3]]) -> Vec<[f64; 3]> {
        points
            .par_iter()
            .with_min_len(4096)
            .filter(|p| self.contains(p))
            .copied()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::crop::Axis;
    use crate::model::rng;
    use rand::RngExt;

    fn unit_square_z() -> CropVolume {
        CropVolume {
            orthogonal_axis: Axis::Z,
            axis_min: -1.0,
            axis_max: 2.0,
            // z of the polygon vertices is deliberately not 0: it is ignored.
            bounding_polygon: vec![
                [0.0, 0.0, 7.0],
                [1.0, 0.0, 7.0],
                [1.0, 1.0, 7.0],
                [0.0, 1.0, 7.0],
            ],
        }
    }

    #[test]
    fn square_interior_exterior_and_axis_bounds() {
        let c = unit_square_z();
        assert!(c.contains(&[0.5, 0.5, 0.0]));
        assert!(!c.contains(&[1.5, 0.5, 0.0]));
        assert!(!c.contains(&[-0.5, 0.5, 0.0]));
        assert!(!c.contains(&[0.5, 1.5, 0.0]));
        assert!(!c.contains(&[0.5, -0.5, 0.0]));
        // Axis bounds are inclusive.
        assert!(c.contains(&[0.5, 0.5, -1.0]));
        assert!(c.contains(&[0.5, 0.5, 2.0]));
        assert!(!c.contains(&[0.5, 0.5, -1.0 - 1e-12]));
        assert!(!c.contains(&[0.5, 0.5, 2.0 + 1e-12]));
        assert!(!c.contains(&[f64::NAN, 0.5, 0.0]));
        // Open3D's bound test lets a NaN axis coordinate through; the
        // polygon test then decides.
        assert!(c.contains(&[0.5, 0.5, f64::NAN]));
        assert!(!c.contains(&[0.5, f64::NAN, 0.0]));
    }

    /// Edges and vertices of the square, worked out by hand from the rule
    /// (crossing iff one end has v < p_v and the other v ≥ p_v; count the
    /// crossings with u < p_u).
    #[test]
    fn square_edges_and_vertices_follow_the_crossing_rule() {
        let c = unit_square_z();
        // Left edge u = 0: crossings at u = 0 and 1, none < 0 → outside.
        assert!(!c.contains(&[0.0, 0.5, 0.0]));
        // Right edge u = 1: the crossing at 0 is < 1 → inside.
        assert!(c.contains(&[1.0, 0.5, 0.0]));
        // Bottom edge v = 0: no edge has an end with v < 0 → outside.
        assert!(!c.contains(&[0.5, 0.0, 0.0]));
        // Top edge v = 1: the side edges are crossed (0 < 1 ≤ 1) → inside.
        assert!(c.contains(&[0.5, 1.0, 0.0]));
        // Vertices.
        assert!(!c.contains(&[0.0, 0.0, 0.0]));
        assert!(!c.contains(&[1.0, 0.0, 0.0]));
        assert!(c.contains(&[1.0, 1.0, 0.0]));
        assert!(!c.contains(&[0.0, 1.0, 0.0]));
    }

    /// Each axis uses its own (u, v) plane: the same polygon, given in the
    /// plane coordinates of X and Y prisms, selects the rotated points.
    #[test]
    fn x_and_y_axes_use_their_planes() {
        // Triangle in (u, v) = (0,0), (2,0), (0,2).
        let tri = [[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]];
        let place = |axis: Axis, uv: [f64; 2], w: f64| {
            let (u, v, wi) = axis.uvw();
            let mut p = [0.0; 3];
            p[u] = uv[0];
            p[v] = uv[1];
            p[wi] = w;
            p
        };
        for axis in [Axis::X, Axis::Y, Axis::Z] {
            let c = CropVolume {
                orthogonal_axis: axis,
                axis_min: 0.0,
                axis_max: 1.0,
                bounding_polygon: tri.iter().map(|&t| place(axis, t, 99.0)).collect(),
            };
            assert!(c.contains(&place(axis, [0.5, 0.5], 0.5)), "{axis:?}");
            assert!(!c.contains(&place(axis, [1.5, 1.5], 0.5)), "{axis:?}");
            assert!(!c.contains(&place(axis, [0.5, 0.5], 1.5)), "{axis:?}");
            // On the hypotenuse u + v = 2 (a right-hand side): inside.
            assert!(c.contains(&place(axis, [1.0, 1.0], 0.5)), "{axis:?}");
        }
    }

    /// A concave polygon (a "U"), against an independent inside test for points
    /// away from the boundary (winding number), plus the crop order.
    #[test]
    fn concave_polygon_matches_winding_number() {
        let poly2 = [
            [0.0, 0.0],
            [3.0, 0.0],
            [3.0, 3.0],
            [2.0, 3.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 3.0],
            [0.0, 3.0],
        ];
        let c = CropVolume {
            orthogonal_axis: Axis::Z,
            axis_min: -10.0,
            axis_max: 10.0,
            bounding_polygon: poly2.iter().map(|p| [p[0], p[1], 0.0]).collect(),
        };
        let winding = |x: f64, y: f64| {
            let mut angle = 0.0f64;
            for i in 0..poly2.len() {
                let a = poly2[i];
                let b = poly2[(i + 1) % poly2.len()];
                let (ax, ay) = (a[0] - x, a[1] - y);
                let (bx, by) = (b[0] - x, b[1] - y);
                angle += (ax * by - ay * bx).atan2(ax * bx + ay * by);
            }
            angle.abs() > std::f64::consts::PI
        };
        let mut rng = rng::seeded(3);
        let pts: Vec<[f64; 3]> = (0..5000)
            .map(|_| {
                [
                    rng.random_range(-1.0..4.0),
                    rng.random_range(-1.0..4.0),
                    0.0,
                ]
            })
            .collect();
        let mut expected = Vec::new();
        for (i, p) in pts.iter().enumerate() {
            // Random f64 points never land exactly on the integer edges.
            let want = winding(p[0], p[1]);
            assert_eq!(c.contains(p), want, "{p:?}");
            if want {
                expected.push(i);
            }
        }
        assert_eq!(c.crop_indices(&pts), expected);
        let cropped = c.crop(&pts);
        assert_eq!(cropped.len(), expected.len());
        assert!(expected.iter().zip(&cropped).all(|(&i, q)| pts[i] == *q));
    }

    #[test]
    fn degenerate_polygon_contains_nothing() {
        let mut c = unit_square_z();
        c.bounding_polygon.truncate(2);
        assert!(!c.contains(&[0.5, 0.5, 0.0]));
        c.bounding_polygon.clear();
        assert!(!c.contains(&[0.5, 0.5, 0.0]));
    }
}
