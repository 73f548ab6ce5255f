//! A triangle-splat soup as a plain coloured mesh, the way Triangle
//! Splatting's `create_off.py` makes one for game engines (used by
//! `export-off` and the demo).
//!
//! Soup colours (reference behaviour, `create_off.py`): SH of all
//! stored bands evaluated once per triangle at its centroid, view direction
//! `normalize(centroid − eye)` with the eye at the world origin unless
//! `--view-from` says otherwise; `rgb = clamp(SH + 0.5, 0, 1)`, 8-bit value
//! `trunc(rgb · 255)`. Vertices are deduplicated bit-exactly and sorted
//! lexicographically by (x, y, z) like `torch.unique(dim=0)`, faces keep the
//! soup's order, alpha is 255 (or `trunc(opacity · 255)` with `--alpha`).
//! Opacity and sigma are not exported: engines render the triangles hard,
//! double-sided (winding is arbitrary).

use std::cmp::Ordering;

use crate::model::{Mesh, TriangleSoup};
use splatkit_render::sh;

/// How soup colours and vertices are produced.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportParams {
    /// Merge bit-identical vertices (sorted as `torch.unique` sorts them).
    pub dedup: bool,
    /// Colours on vertices (each corner gets its face's colour; implies no
    /// merging across faces) instead of on faces.
    pub per_vertex_colors: bool,
    /// Alpha from the activated opacity instead of 255.
    pub alpha: bool,
    /// View-independent colour (DC term only).
    pub dc_only: bool,
    /// Eye position for the SH view direction (world units).
    pub view_from: [f32; 3],
}

impl Default for ExportParams {
    fn default() -> Self {
        ExportParams {
            dedup: true,
            per_vertex_colors: false,
            alpha: false,
            dc_only: false,
            view_from: [0.0; 3],
        }
    }
}

/// Per-triangle RGBA8 colours of `soup` (see module docs).
pub fn triangle_colors(soup: &TriangleSoup, p: &ExportParams) -> Vec<[u8; 4]> {
    let degree = if p.dc_only { 0 } else { soup.sh_degree };
    (0..soup.len())
        .map(|i| {
            let c = soup.centroid(i);
            let dir = [0, 1, 2].map(|k| c[k] - p.view_from[k]);
            let rgb = sh::eval_rgb(degree, &soup.sh_coeffs(i), dir);
            // `as u8` truncates toward zero like torch's float→uint8 cast; the
            // clamp keeps NaN at 0.
            let q = |x: f32| (x.clamp(0.0, 1.0) * 255.0) as u8;
            let a = if p.alpha { q(soup.opacity(i)) } else { 255 };
            [q(rgb[0]), q(rgb[1]), q(rgb[2]), a]
        })
        .collect()
}

/// Lexicographic order on (x, y, z) where -0.0 equals 0.0 (as float `==`
/// does in `torch.unique`); NaN sorts last and never merges.
fn cmp_vertex(a: &[f32; 3], b: &[f32; 3]) -> Ordering {
    for k in 0..3 {
        let o = match a[k].partial_cmp(&b[k]) {
            Some(o) => o,
            None => a[k].is_nan().cmp(&b[k].is_nan()),
        };
        if o != Ordering::Equal {
            return o;
        }
    }
    Ordering::Equal
}

fn same_vertex(a: &[f32; 3], b: &[f32; 3]) -> bool {
    (0..3).all(|k| a[k] == b[k])
}

/// The soup as an indexed mesh with per-face (or per-vertex) colours.
pub fn soup_to_mesh(soup: &TriangleSoup, p: &ExportParams) -> Mesh {
    let colors = triangle_colors(soup, p);
    let corners: Vec<[f32; 3]> = soup.triangles.iter().flatten().copied().collect();
    if p.per_vertex_colors || !p.dedup {
        let n = soup.len() as u32;
        let mut m = Mesh::new(
            corners,
            (0..n).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
        );
        if p.per_vertex_colors {
            m.vertex_colors = Some(colors.iter().flat_map(|&c| [c, c, c]).collect());
        } else {
            m.face_colors = Some(colors);
        }
        return m;
    }
    let mut order: Vec<u32> = (0..corners.len() as u32).collect();
    order.sort_by(|&a, &b| cmp_vertex(&corners[a as usize], &corners[b as usize]).then(a.cmp(&b)));
    let mut remap = vec![0u32; corners.len()];
    let mut vertices: Vec<[f32; 3]> = Vec::with_capacity(corners.len());
    for &i in &order {
        let v = corners[i as usize];
        if vertices.last().is_none_or(|last| !same_vertex(last, &v)) {
            vertices.push(v);
        }
        remap[i as usize] = vertices.len() as u32 - 1;
    }
    let faces = (0..soup.len())
        .map(|t| [0, 1, 2].map(|k| remap[3 * t + k]))
        .collect();
    let mut m = Mesh::new(vertices, faces);
    m.face_colors = Some(colors);
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Extras;

    fn two_triangles() -> TriangleSoup {
        TriangleSoup {
            // Share an edge: (1,0,0) and (0,1,0) appear twice.
            triangles: vec![
                [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 2.0, 0.5]],
            ],
            opacity_raw: vec![0.0, 2.0],
            sigma_raw: vec![0.0, 0.0],
            sh_degree: 0,
            active_sh_degree: 0,
            // DC giving rgb 0.5 + C0·dc: dc = 1 → 0.7821 → 199; dc = −10 → clamp 0.
            sh_dc: vec![[1.0, 0.0, -10.0], [0.5, 2.0, 0.0]],
            sh_rest: vec![],
            extras: Extras::default(),
        }
    }

    #[test]
    fn dedup_sorts_like_torch_unique_and_colours_truncate() {
        let m = soup_to_mesh(&two_triangles(), &ExportParams::default());
        assert_eq!(
            m.vertices,
            vec![
                [-1.0, 2.0, 0.5],
                [0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 0.0, 0.0]
            ]
        );
        assert_eq!(m.faces, vec![[1, 3, 2], [3, 2, 0]]);
        // 0.5 + 0.28209479·1 = 0.78209479 → ·255 = 199.43 → 199; 0.5 → 127.5 → 127.
        // 0.5 + 0.28209479·0.5 = 0.6410 → 163.46 → 163; 0.5 + 0.5642 = 1.06 → clamp → 255.
        assert_eq!(
            m.face_colors.unwrap(),
            vec![[199, 127, 0, 255], [163, 255, 127, 255]]
        );
    }

    #[test]
    fn view_direction_uses_the_centroid_from_the_eye() {
        // Degree 1, only the coefficient of Y_3 = −C1·x set: colour depends on
        // the x component of the view direction.
        let mut s = two_triangles();
        s.sh_degree = 1;
        s.sh_dc = vec![[0.0; 3]; 2];
        s.sh_rest = vec![0.0; 2 * 9];
        s.sh_rest[2 * 3] = 1.0; // triangle 0, k = 2 (Y_3), red
        let p = ExportParams {
            view_from: [10.0, 1.0 / 3.0, 0.0],
            ..Default::default()
        };
        // Centroid (1/3, 1/3, 0): dir = (−1, 0, 0) → red = 0.5 + C1 = 0.98860 → 252.
        let c = triangle_colors(&s, &p);
        assert_eq!(c[0][0], 252);
        assert_eq!(c[0][1], 127);
        let dc = triangle_colors(&s, &ExportParams { dc_only: true, ..p });
        assert_eq!(dc[0][0], 127);
    }

    #[test]
    fn alpha_is_truncated_opacity() {
        let p = ExportParams {
            alpha: true,
            ..Default::default()
        };
        let c = triangle_colors(&two_triangles(), &p);
        // sigmoid(0) = 0.5 → 127; sigmoid(2) = 0.8808 → 224.6 → 224.
        assert_eq!((c[0][3], c[1][3]), (127, 224));
    }
}
