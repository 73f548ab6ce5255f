//! Triangle-splat rasteriser with the semantics of Triangle Splatting's
//! `diff-triangle-rasterization` (Held et al. 2025), on the CPU.
//!
//! Per triangle (preprocess):
//! - culled when the opacity is below 0.01, when the view-space z of the 3-D
//!   centroid is ≤ `near` (only the centroid is tested, as the reference does),
//!   or when the face is seen edge-on (|cos| < 0.001 between its normal and
//!   the view ray to the centroid);
//! - the three vertices are projected (divide by z + 1e-7, no clipping) to
//!   A, B, C in pixels; R = max distance from the projected 3-D centroid;
//!   the 2-D incenter s = (a·A + b·B + c·C)/(a + b + c);
//! - edge lines L_i(p) = n_i·p + d_i with unit normals, oriented so that the
//!   inside is negative; φ(s) = L_0(s) = −r (the inradius, pixels);
//! - culled when R > 1600 px, R < 1 px or r < 1 px;
//! - tile box: the edges moved inward by r·(0.01/o)^(1/σ) (the region where
//!   o·I ≥ 0.01), their pairwise intersections bound the box; its tiles are
//!   the kernel's `[(uint)(x0/16), (uint)((x1+15)/16))` in its integer-centred
//!   pixel coordinates ([`crate::tiles::tile_rect_cuda`]), which can leave out
//!   a row or column the box reaches; an empty range culls the triangle;
//! - colour from SH at the 3-D centroid, direction from the camera centre,
//!   + 0.5, clamped at 0; depth = view z of the centroid.
//!
//! Per pixel (tiles sorted by centroid depth): outside when any L_i > 0;
//! φ = max L_i; window I = (φ/φ(s))^σ; α = min(0.99, o·I); skipped when
//! α < 1/255; the pixel ends, without this contribution, when T would fall
//! below 1e-4. Outputs as [`crate::gaussian::RenderOutput`]: depth and normal
//! are the triangle's centroid depth and camera-facing unit face normal
//! (blended into the expected depth Σ w z / Σ w, the accumulated normal
//! Σ w n and its normalisation); the
//! median depth is the depth of the last contribution made while the
//! transmittance before it was above 0.5 (so also where the final alpha
//! stays below 0.5), 0 only where nothing contributed.
//!
//! Pixel centres are at integer + 0.5 in OpenCV pixel coordinates; with the
//! principal point at the image centre this is the reference's convention
//! (its pixel centres at integers after its own half-pixel shift).

use rayon::prelude::*;

use crate::Camera;
use crate::dual::{Real, cross3, dot3, sh_rgb};
use crate::gaussian::{RasterSettings, RenderOutput, rotation_rows};
use crate::sh::coeff_count;
use crate::tiles::{TILE, TileLists, tile_pixels, tile_rect_cuda};

/// Triangles as the rasteriser wants them: activated values.
#[derive(Clone, Debug, Default)]
pub struct Triangles3 {
    /// Three vertices per triangle, world units.
    pub vertices: Vec<[[f32; 3]; 3]>,
    /// Window sharpness σ ≥ 0 (Triangle Splatting: 0.01 + exp(raw); 0 = solid).
    pub sigmas: Vec<f32>,
    /// Opacities in [0, 1].
    pub opacities: Vec<f32>,
    /// SH coefficients, coefficient-major, `(degree+1)²` per triangle.
    pub sh: Vec<[f32; 3]>,
    /// SH degree, 0–3.
    pub sh_degree: usize,
}

impl Triangles3 {
    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.vertices.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.vertices.is_empty()
    }

    /// The same triangles with SH degree 0 (the DC term only), as the
    /// meshing pass renders them.
    pub fn dc_only(&self) -> Triangles3 {
        let n = coeff_count(self.sh_degree);
        Triangles3 {
            vertices: self.vertices.clone(),
            sigmas: self.sigmas.clone(),
            opacities: self.opacities.clone(),
            sh: self.sh.iter().step_by(n.max(1)).copied().collect(),
            sh_degree: 0,
        }
    }
}

/// One projected triangle.
#[derive(Clone, Copy, Debug)]
pub struct ProjectedTri {
    pub id: u32,
    /// Edge lines (n_x, n_y, d): L(p) = n·p + d, negative inside.
    pub edges: [[f32; 3]; 3],
    /// φ(s) = −inradius (pixels).
    pub phi_s: f32,
    pub sigma: f32,
    pub opacity: f32,
    pub rgb: [f32; 3],
    pub depth: f32,
    /// Camera-space face normal facing the camera.
    pub normal: [f32; 3],
    /// Inclusive tile rectangle (x0, y0, x1, y1) by the official rule.
    pub tiles: [u32; 4],
}

/// The differentiable part of a triangle's projection.
pub(crate) struct ProjectedTriT<T> {
    pub edges: [[T; 3]; 3],
    pub phi_s: T,
    /// SH colour + 0.5 before the clamp.
    pub rgb: [T; 3],
    /// View z of the 3-D centroid.
    pub depth: T,
    /// Camera-space unit face normal facing the camera (the flip is taken
    /// on the values: no derivative).
    pub normal: [T; 3],
    /// Inclusive tile rectangle (x0, y0, x1, y1), never empty.
    pub tiles: [u32; 4],
}

/// Projects one triangle; `None` when culled. `verts` are world positions.
#[allow(clippy::too_many_arguments)]
pub(crate) fn project_tri_t<T: Real>(
    verts: [[T; 3]; 3],
    sigma: f32,
    opacity: f32,
    sh: &[[f32; 3]],
    sh_degree: usize,
    cam: &Camera,
    rows: &[[f64; 3]; 3],
    s: &RasterSettings,
) -> Option<ProjectedTriT<T>> {
    if opacity.is_nan() || opacity < 0.01 || sigma.is_nan() || sigma < 0.0 {
        return None;
    }
    let tr = cam.translation;
    let view = verts.map(|v| -> [T; 3] {
        std::array::from_fn(|i| v[0] * rows[i][0] + v[1] * rows[i][1] + v[2] * rows[i][2] + tr[i])
    });
    let third = 1.0 / 3.0;
    let c3: [T; 3] = std::array::from_fn(|i| (view[0][i] + view[1][i] + view[2][i]) * third);
    let z = c3[2].val();
    if z.is_nan() || z <= s.near {
        return None;
    }
    // face normal, for culling and the normal map; its length is clamped
    // at 1e-4 as the reference does (a constant there)
    let e1: [T; 3] = std::array::from_fn(|i| view[1][i] - view[0][i]);
    let e2: [T; 3] = std::array::from_fn(|i| view[2][i] - view[0][i]);
    let nrm = cross3(e1, e2);
    let nl = dot3(nrm, nrm).sqrt();
    let nl = if nl.val() < 1e-4 { T::cst(1e-4) } else { nl };
    let mut normal = nrm.map(|v| v / nl);
    let cv = c3.map(|v| v.val());
    let cl = dot3(cv, cv).sqrt();
    let cos = dot3(normal.map(|v| v.val()), cv) / cl;
    if cos > 0.0 {
        normal = normal.map(|v| -v);
    }
    if cos.is_nan() || cos.abs() < 0.001 {
        return None;
    }
    let proj = |p: [T; 3]| -> [T; 2] {
        let iz = T::cst(1.0) / (p[2] + 1e-7);
        [p[0] * iz * cam.fx + cam.cx, p[1] * iz * cam.fy + cam.cy]
    };
    let pv = view.map(proj);
    let c2 = proj(c3);
    let dist = |a: [T; 2], b: [T; 2]| {
        let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
        (dx * dx + dy * dy).sqrt()
    };
    let big_r = (0..3).map(|i| dist(pv[i], c2).val()).fold(0.0f64, f64::max);
    let la = dist(pv[1], pv[2]);
    let lb = dist(pv[0], pv[2]);
    let lc = dist(pv[0], pv[1]);
    let per = la + lb + lc;
    if per.val().is_nan() || per.val() <= 0.0 {
        return None;
    }
    let inc: [T; 2] =
        std::array::from_fn(|k| (pv[0][k] * la + pv[1][k] * lb + pv[2][k] * lc) / per);
    let mut edges = [[T::cst(0.0); 3]; 3];
    for i in 0..3 {
        let (p, q) = (pv[i], pv[(i + 1) % 3]);
        let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
        let l = (dx * dx + dy * dy).sqrt();
        if l.val().is_nan() || l.val() <= 0.0 {
            return None;
        }
        let (mut nx, mut ny) = (dy / l, -dx / l);
        let mut d = -(nx * p[0] + ny * p[1]);
        if (nx * inc[0] + ny * inc[1] + d).val() > 0.0 {
            nx = -nx;
            ny = -ny;
            d = -d;
        }
        edges[i] = [nx, ny, d];
    }
    let phi_s = edges[0][0] * inc[0] + edges[0][1] * inc[1] + edges[0][2];
    // the kernel's size culls: R outside [1, 1600] px or inradius under
    // 1 px (`min_inradius`, 1 unless set lower)
    let m = s.min_inradius;
    if !(m..=1600.0).contains(&big_r) || phi_s.val().is_nan() || phi_s.val() > -m {
        return None;
    }
    let ev = edges.map(|e| e.map(|v| v.val()));
    let bbox = tight_box(&ev, phi_s.val(), opacity, sigma)?;
    // the official tile range (empty: culled), see `tile_rect_cuda`
    let tiles = tile_rect_cuda(
        bbox.map(|v| v as f32),
        cam.width as usize,
        cam.height as usize,
    )?;
    let world_c: [T; 3] =
        std::array::from_fn(|i| (verts[0][i] + verts[1][i] + verts[2][i]) * third);
    let rgb = sh_rgb(world_c, cam.center().to_array(), sh, sh_degree);
    Some(ProjectedTriT {
        edges,
        phi_s,
        rgb,
        depth: c3[2],
        normal,
        tiles,
    })
}

/// The tightened screen box of a projected triangle (Triangle Splatting's
/// supplement, eq. 3; `forward.cu` step "tight tile box"), before tile
/// rounding: (x0, y0, x1, y1) in pixels, `None` when no corner is left.
///
/// o·I(p) ≥ 0.01 ⇔ φ(p) ≤ φ(s)·(0.01/o)^(1/σ), i.e. every edge line
/// L_i(p) = n_i·p + d_i (negative inside, `edges[i]` = (n_x, n_y, d)) moved
/// inward by r·(0.01/o)^(1/σ), r = −φ(s) the inradius. The box bounds the
/// pairwise intersections of consecutive moved lines; pairs with
/// |det| < 1e-3 (almost parallel edges) are skipped as in the reference, so
/// the sliver at such a corner can fall outside. The moved triangle lies in
/// the original one, so the box never exceeds the vertex bounding box.
pub(crate) fn tight_box(
    edges: &[[f64; 3]; 3],
    phi_s: f64,
    opacity: f32,
    sigma: f32,
) -> Option<[f64; 4]> {
    let shrink = -phi_s * (0.01 / opacity as f64).powf(1.0 / sigma as f64);
    let mut bbox = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut corners = 0;
    for i in 0..3 {
        let (a, b) = (edges[i], edges[(i + 1) % 3]);
        let det = a[0] * b[1] - a[1] * b[0];
        if det.abs() < 1e-3 {
            continue;
        }
        let (da, db) = (a[2] + shrink, b[2] + shrink);
        let x = (-da * b[1] + db * a[1]) / det;
        let y = (-a[0] * db + b[0] * da) / det;
        bbox = [
            bbox[0].min(x),
            bbox[1].min(y),
            bbox[2].max(x),
            bbox[3].max(y),
        ];
        corners += 1;
    }
    (corners > 0).then_some(bbox)
}

fn project_tri(
    t: &Triangles3,
    i: usize,
    cam: &Camera,
    rows: &[[f64; 3]; 3],
    s: &RasterSettings,
) -> Option<ProjectedTri> {
    let n = coeff_count(t.sh_degree);
    let p = project_tri_t::<f64>(
        t.vertices[i].map(|v| v.map(f64::from)),
        t.sigmas[i],
        t.opacities[i],
        &t.sh[i * n..(i + 1) * n],
        t.sh_degree,
        cam,
        rows,
        s,
    )?;
    Some(ProjectedTri {
        id: i as u32,
        edges: p.edges.map(|e| e.map(|v| v as f32)),
        phi_s: p.phi_s as f32,
        sigma: t.sigmas[i],
        opacity: t.opacities[i],
        rgb: p.rgb.map(|v| v.max(0.0) as f32),
        depth: p.depth as f32,
        normal: p.normal.map(|v| v as f32),
        tiles: p.tiles,
    })
}

/// The window value I(p) of a projected triangle at pixel position (x, y),
/// with the index of the edge that gives φ; `None` outside.
#[inline]
pub(crate) fn window(p: &ProjectedTri, x: f32, y: f32) -> Option<(f32, usize, f32)> {
    let mut phi = f32::NEG_INFINITY;
    let mut arg = 0;
    for (k, e) in p.edges.iter().enumerate() {
        let l = e[0] * x + e[1] * y + e[2];
        if l > 0.0 {
            return None;
        }
        if l > phi {
            phi = l;
            arg = k;
        }
    }
    let ratio = phi / p.phi_s;
    Some((ratio.powf(p.sigma), arg, phi))
}

/// What the backward pass needs from the forward pass: the projected
/// triangles, the tile lists and, per pixel, the final transmittance, the
/// list position past the last blended contribution, the expected depth and
/// the weight sum Σ w it was divided by.
#[derive(Clone, Debug, Default)]
pub struct TriangleState {
    pub proj: Vec<ProjectedTri>,
    pub tiles: TileLists,
    pub final_t: Vec<f32>,
    pub last: Vec<u32>,
    /// Per pixel, [`RenderOutput::expected_depth`].
    pub expected_depth: Vec<f32>,
    /// Per pixel, Σ w (= 1 − T up to rounding), 0 where nothing was blended.
    pub weight_sum: Vec<f32>,
    /// Per triangle (indexed like the input), the largest blending weight
    /// α·T it added to any pixel (the kernel's `max_blending`, Triangle
    /// Splatting's importance); 0 where it added nothing.
    pub max_weight: Vec<f32>,
}

/// Renders `t` from `cam`.
pub fn render(t: &Triangles3, cam: &Camera, s: &RasterSettings) -> RenderOutput {
    rasterize(t, cam, s).0
}

/// Renders `t` from `cam` and keeps what [`crate::triangle_grad::backward`] needs.
pub fn rasterize(
    t: &Triangles3,
    cam: &Camera,
    s: &RasterSettings,
) -> (RenderOutput, TriangleState) {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let rows = rotation_rows(cam);
    let proj: Vec<ProjectedTri> = (0..t.len())
        .into_par_iter()
        .filter_map(|i| project_tri(t, i, cam, &rows, s))
        .collect();
    let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let mut out = RenderOutput {
        width: w,
        height: h,
        rgb: vec![s.background; w * h],
        alpha: vec![0.0; w * h],
        expected_depth: vec![0.0; w * h],
        median_depth: vec![0.0; w * h],
        normal: vec![[0.0; 3]; w * h],
        normal_sum: vec![[0.0; 3]; w * h],
        count: vec![0; w * h],
    };
    if tw == 0 || th == 0 {
        return (out, TriangleState::default());
    }
    let tiles = TileLists::build(&proj, |p| Some(p.tiles), |p| p.depth, w, h);
    let mut final_t = vec![1.0f32; w * h];
    let mut lastv = vec![0u32; w * h];
    let mut weight_sum = vec![0.0f32; w * h];
    let mut max_weight = vec![0.0f32; t.len()];
    // per tile: its pixels, and per list entry the largest weight it added
    let done: Vec<(Vec<Shaded>, Vec<f32>)> = (0..tw * th)
        .into_par_iter()
        .map(|ti| {
            let list = tiles.list(ti);
            let mut best = vec![0.0f32; list.len()];
            let px = tile_pixels(ti, tw, w, h)
                .map(|(x, y)| shade(&proj, list, x, y, s, &mut best))
                .collect();
            (px, best)
        })
        .collect();
    for (ti, (pixels, best)) in done.into_iter().enumerate() {
        for (&pi, b) in tiles.list(ti).iter().zip(best) {
            let id = proj[pi as usize].id as usize;
            max_weight[id] = max_weight[id].max(b);
        }
        for ((x, y), px) in tile_pixels(ti, tw, w, h).zip(pixels) {
            let o = y * w + x;
            out.rgb[o] = px.rgb;
            out.alpha[o] = 1.0 - px.final_t;
            out.expected_depth[o] = px.expected_depth;
            out.median_depth[o] = px.median_depth;
            out.normal[o] = px.normal;
            out.normal_sum[o] = px.normal_sum;
            out.count[o] = px.count;
            final_t[o] = px.final_t;
            lastv[o] = px.last;
            weight_sum[o] = px.weight_sum;
        }
    }
    let state = TriangleState {
        proj,
        tiles,
        final_t,
        last: lastv,
        expected_depth: out.expected_depth.clone(),
        weight_sum,
        max_weight,
    };
    (out, state)
}

/// One pixel's outputs.
#[derive(Clone, Copy, Debug, Default)]
struct Shaded {
    rgb: [f32; 3],
    expected_depth: f32,
    median_depth: f32,
    normal: [f32; 3],
    normal_sum: [f32; 3],
    weight_sum: f32,
    count: u32,
    final_t: f32,
    last: u32,
}

/// Blends the tile list `list` front to back at pixel (x, y).
/// `best[li]` is raised to each added weight α·T of list entry `li`.
fn shade(
    proj: &[ProjectedTri],
    list: &[u32],
    x: usize,
    y: usize,
    s: &RasterSettings,
    best: &mut [f32],
) -> Shaded {
    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
    let mut tr = 1.0f32;
    let mut c = [0.0f32; 3];
    let mut nsum = [0.0f32; 3];
    let (mut dsum, mut wsum, mut median, mut n, mut last) = (0.0f32, 0.0f32, 0.0f32, 0u32, 0u32);
    for (li, &pi) in list.iter().enumerate() {
        let p = &proj[pi as usize];
        let Some((win, _, _)) = window(p, px, py) else {
            continue;
        };
        let alpha = (p.opacity * win).min(0.99);
        if alpha < 1.0 / 255.0 {
            continue;
        }
        let next = tr * (1.0 - alpha);
        if next < 1e-4 {
            break;
        }
        let wgt = alpha * tr;
        best[li] = best[li].max(wgt);
        for k in 0..3 {
            c[k] += p.rgb[k] * wgt;
            nsum[k] += p.normal[k] * wgt;
        }
        dsum += p.depth * wgt;
        wsum += wgt;
        // the official kernels: the last contribution made while the
        // transmittance before it is above 0.5
        if tr > 0.5 {
            median = p.depth;
        }
        tr = next;
        n += 1;
        last = li as u32 + 1;
    }
    let mut o = Shaded {
        rgb: std::array::from_fn(|k| c[k] + tr * s.background[k]),
        count: n,
        final_t: tr,
        last,
        median_depth: median,
        normal_sum: nsum,
        weight_sum: wsum,
        ..Default::default()
    };
    if wsum > 0.0 {
        o.expected_depth = dsum / wsum;
        let l = (nsum[0] * nsum[0] + nsum[1] * nsum[1] + nsum[2] * nsum[2]).sqrt();
        if l > 0.0 {
            o.normal = nsum.map(|v| v / l);
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::rgb_to_sh;
    use crate::testutil::test_camera;

    fn one(v: [[f32; 3]; 3], sigma: f32, opacity: f32, rgb: [f32; 3]) -> Triangles3 {
        Triangles3 {
            vertices: vec![v],
            sigmas: vec![sigma],
            opacities: vec![opacity],
            sh: vec![rgb.map(rgb_to_sh)],
            sh_degree: 0,
        }
    }

    /// The size cull: a triangle of inradius 0.600 px (equilateral-ish,
    /// side 2.08 px, height 1.8 px, R = 1.2 px) is culled by the kernel's
    /// 1-px rule (nothing drawn, no projected entry) and drawn with
    /// `min_inradius` 0.5 (some pixel centre inside gets α > 0), and again
    /// culled at 0.61 (just above its inradius).
    #[test]
    fn min_inradius_culls_sub_pixel_triangles() {
        let cam = test_camera(64, 48, 80.0);
        let v = [
            [-0.052f32, -0.03, 4.0],
            [0.052, -0.03, 4.0],
            [0.0, 0.06, 4.0],
        ];
        let t = one(v, 1.0, 0.9, [1.0, 1.0, 1.0]);
        let drawn = |m: f64| {
            let s = RasterSettings {
                min_inradius: m,
                ..Default::default()
            };
            let (img, st) = rasterize(&t, &cam, &s);
            (img.alpha.iter().sum::<f32>(), st.proj.len())
        };
        assert_eq!(drawn(1.0), (0.0, 0));
        assert_eq!(drawn(0.61), (0.0, 0));
        let (a, n) = drawn(0.5);
        assert_eq!(n, 1);
        assert!(a > 0.0, "alpha {a}");
    }

    /// σ → 0: the window is 1 wherever φ < 0, so α = opacity exactly on the
    /// pixels whose centre lies inside the projected triangle (an independent
    /// f64 point-in-triangle test) and 0 elsewhere: the exact pixel coverage;
    /// median and expected depth are the plane's z inside, median 0 outside.
    #[test]
    fn hard_triangle_covers_exactly_its_pixels() {
        let cam = test_camera(64, 48, 80.0);
        let z = 4.0f32;
        let v = [[-1.3f32, -0.9, z], [1.45, -0.2, z], [-0.2, 1.1, z]];
        let img = render(
            &one(v, 1e-6, 0.7, [1.0, 1.0, 1.0]),
            &cam,
            &RasterSettings::default(),
        );
        let p2: Vec<[f64; 2]> = v
            .iter()
            .map(|p| {
                [
                    80.0 * p[0] as f64 / z as f64 + 32.0,
                    80.0 * p[1] as f64 / z as f64 + 24.0,
                ]
            })
            .collect();
        let edge = |a: [f64; 2], b: [f64; 2], x: f64, y: f64| {
            (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])
        };
        let mut inside_count = 0;
        for y in 0..48 {
            for x in 0..64 {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let e = [
                    edge(p2[0], p2[1], px, py),
                    edge(p2[1], p2[2], px, py),
                    edge(p2[2], p2[0], px, py),
                ];
                let inside = e.iter().all(|&v| v > 0.0) || e.iter().all(|&v| v < 0.0);
                let a = img.alpha[y * 64 + x];
                if inside {
                    inside_count += 1;
                    // (φ/φ(s))^1e-6 ≥ 0.99998 for φ/φ(s) ≥ 1e-9
                    assert!((a - 0.7).abs() < 1e-4, "({x},{y}) inside, α {a}");
                    // a plane facing the camera: both depths are its z
                    // (median although α stays under 0.5: the kernel's rule)
                    let o = y * 64 + x;
                    assert!((img.median_depth[o] - z).abs() <= 1e-4 * z);
                    assert!((img.expected_depth[o] - z).abs() <= 1e-4 * z);
                } else {
                    assert_eq!(a, 0.0, "({x},{y}) outside");
                    assert_eq!(img.median_depth[y * 64 + x], 0.0);
                }
            }
        }
        // area of the projected triangle ≈ number of covered pixel centres
        let area = 0.5 * edge(p2[0], p2[1], p2[2][0], p2[2][1]).abs();
        assert!((inside_count as f64 - area).abs() < 0.05 * area);
    }

    /// The window at the incenter is 1 and falls as (φ/φ(s))^σ toward the
    /// edges; two overlapping layers composite as hand-computed.
    #[test]
    fn two_layers_composite_and_window_shape() {
        let cam = test_camera(32, 32, 40.0);
        // big triangles centred on the optical axis
        let tri = |z: f32| {
            [
                [-3.0 * z, -2.0 * z, z],
                [3.0 * z, -2.0 * z, z],
                [0.0, 4.0 * z, z],
            ]
        };
        let mut t = one(tri(2.0), 1.0, 0.6, [1.0, 0.0, 0.0]);
        let back = one(tri(3.0), 1.0, 0.5, [0.0, 0.0, 1.0]);
        t.vertices.extend(back.vertices);
        t.sigmas.extend(back.sigmas);
        t.opacities.extend(back.opacities);
        t.sh.extend(back.sh);
        let s = RasterSettings {
            background: [0.0, 1.0, 0.0],
            ..Default::default()
        };
        let img = render(&t, &cam, &s);
        // Both triangles project to the same 2-D triangle (scaled with z):
        // incenter at (16, 16 + 0) in pixels? The incenter of the isosceles
        // triangle (−3,−2),(3,−2),(0,4) (units of f/z·z = 40 px) is at
        // (0, −2 + r) with r = area/semiperimeter.
        let (a, b) = (6.0f64, (9.0f64 + 36.0).sqrt());
        let r = 0.5 * 6.0 * 6.0 / (0.5 * (a + 2.0 * b));
        let phi_s = -r * 40.0;
        // pixel (16, 16): centre (16.5, 16.5) → (0.0125, 0.0125) in units
        let (ux, uy) = (0.5 / 40.0, 0.5 / 40.0);
        // φ = max over the edges of the signed distances (pixels)
        let d_bottom = -(uy + 2.0);
        let n1 = [6.0, 3.0].map(|v: f64| v / 45f64.sqrt()); // right edge normal
        let d_right = n1[0] * (ux - 3.0) + n1[1] * (uy + 2.0);
        let n2 = [-6.0, 3.0].map(|v: f64| v / 45f64.sqrt());
        let d_left = n2[0] * (ux + 3.0) + n2[1] * (uy + 2.0);
        let phi = d_bottom.max(d_right).max(d_left) * 40.0;
        let win = phi / phi_s;
        let (a1, a2) = (0.6 * win, 0.5 * win);
        let want = [a1, (1.0 - a1) * (1.0 - a2), a2 * (1.0 - a1)];
        let c = 16 * 32 + 16;
        for k in 0..3 {
            assert!(
                (img.rgb[c][k] as f64 - want[k]).abs() < 1e-4,
                "{:?} vs {want:?}",
                img.rgb[c]
            );
        }
        assert_eq!(img.count[c], 2);
        assert_eq!(img.median_depth[c], 2.0, "the front layer takes T to 0.4");
        let ed = (a1 * 2.0 + a2 * (1.0 - a1) * 3.0) / (a1 + a2 * (1.0 - a1));
        assert!((img.expected_depth[c] as f64 - ed).abs() < 1e-4);
        assert_eq!(img.normal[c], [0.0, 0.0, -1.0]);
    }

    /// Culling rules: tiny (inradius < 1 px), edge-on, behind the near plane,
    /// transparent (o < 0.01) triangles draw nothing.
    #[test]
    fn culled_triangles_draw_nothing() {
        let cam = test_camera(32, 32, 40.0);
        let cases = [
            one(
                [[0.0, 0.0, 4.0], [0.05, 0.0, 4.0], [0.0, 0.05, 4.0]],
                1.0,
                0.9,
                [1.0; 3],
            ),
            one(
                [[-1.0, 0.0, 3.0], [1.0, 0.0, 3.0], [0.0, 0.0, 5.0]],
                1.0,
                0.9,
                [1.0; 3],
            ),
            one(
                [[-1.0, -1.0, 0.1], [1.0, -1.0, 0.1], [0.0, 1.0, 0.1]],
                1.0,
                0.9,
                [1.0; 3],
            ),
            one(
                [[-1.0, -1.0, 4.0], [1.0, -1.0, 4.0], [0.0, 1.0, 4.0]],
                1.0,
                0.005,
                [1.0; 3],
            ),
        ];
        for (k, t) in cases.iter().enumerate() {
            let img = render(t, &cam, &RasterSettings::default());
            assert!(img.alpha.iter().all(|&a| a == 0.0), "case {k}");
        }
        // and the control: the same as the last with o = 0.9 draws
        let t = one(
            [[-1.0, -1.0, 4.0], [1.0, -1.0, 4.0], [0.0, 1.0, 4.0]],
            1.0,
            0.9,
            [1.0; 3],
        );
        assert!(
            render(&t, &cam, &RasterSettings::default())
                .alpha
                .iter()
                .any(|&a| a > 0.5)
        );
    }

    /// A near-solid triangle (σ → 0: the tile box is the vertex box) given
    /// by its pixel corners, at depth 4 under a 64×48 camera with f = 80.
    fn pixel_triangle(c: [[f32; 2]; 3]) -> Triangles3 {
        let z = 4.0f32;
        one(
            c.map(|p| [(p[0] - 32.0) * z / 80.0, (p[1] - 24.0) * z / 80.0, z]),
            1e-6,
            0.7,
            [1.0; 3],
        )
    }

    /// The official tile range: a right edge at x = 16.7 (kernel 16.2:
    /// (16.2 + 15)/16 < 2) leaves tile column 1 out, so pixel 16, whose
    /// centre 16.5 is inside the triangle, stays empty while pixel 15 is
    /// drawn; moved right by 0.9 px (kernel 17.1) the column is in. A
    /// triangle whose right edge is at 1.2 (kernel 0.7 → no column) is
    /// culled although pixel 0's centre is inside it.
    #[test]
    fn tile_range_is_the_kernels() {
        let cam = test_camera(64, 48, 80.0);
        let s = RasterSettings::default();
        let img = render(
            &pixel_triangle([[2.0, 2.0], [16.7, 2.0], [16.7, 14.0]]),
            &cam,
            &s,
        );
        let at = |img: &RenderOutput, x: usize, y: usize| img.alpha[y * 64 + x];
        assert!((at(&img, 15, 5) - 0.7).abs() < 1e-4);
        assert_eq!(
            at(&img, 16, 5),
            0.0,
            "column 16 is not in the kernel's range"
        );
        let img = render(
            &pixel_triangle([[2.9, 2.0], [17.6, 2.0], [17.6, 14.0]]),
            &cam,
            &s,
        );
        assert!((at(&img, 16, 5) - 0.7).abs() < 1e-4);
        let img = render(
            &pixel_triangle([[-10.0, 2.0], [1.2, 2.0], [1.2, 14.0]]),
            &cam,
            &s,
        );
        assert!(img.alpha.iter().all(|&a| a == 0.0), "empty range: culled");
    }

    /// Median depth as the official kernel keeps it: the depth of the last
    /// contribution made while the transmittance before it is above 0.5.
    /// Layers of opacity 0.3 (window ≈ 1, σ → 0) at z = 2, 3, 4: T before
    /// each is 1, 0.7, 0.49, so the median is 3; one layer alone, whose
    /// final alpha 0.3 never takes T to 0.5, still has its depth; uncovered
    /// pixels have 0.
    #[test]
    fn median_depth_follows_the_kernel_rule() {
        let cam = test_camera(32, 32, 40.0);
        let tri = |z: f32| {
            one(
                [
                    [-3.0 * z, -2.0 * z, z],
                    [3.0 * z, -2.0 * z, z],
                    [0.0, 4.0 * z, z],
                ],
                1e-6,
                0.3,
                [1.0; 3],
            )
        };
        let mut t = tri(4.0);
        for z in [2.0, 3.0] {
            let l = tri(z);
            t.vertices.extend(l.vertices);
            t.sigmas.extend(l.sigmas);
            t.opacities.extend(l.opacities);
            t.sh.extend(l.sh);
        }
        let c = 16 * 32 + 16;
        let img = render(&t, &cam, &RasterSettings::default());
        assert_eq!(img.count[c], 3);
        assert_eq!(img.median_depth[c], 3.0);
        let single = render(&tri(2.5), &cam, &RasterSettings::default());
        assert!(single.alpha[c] < 0.31);
        assert_eq!(single.median_depth[c], 2.5);
        let small = render(
            &pixel_triangle([[20.0, 20.0], [40.0, 20.0], [30.0, 40.0]]),
            &test_camera(64, 48, 80.0),
            &RasterSettings::default(),
        );
        assert_eq!(small.count[0], 0);
        assert_eq!(small.median_depth[0], 0.0);
    }

    /// The tightened screen box (step 8 of the reference's preprocess, the
    /// supplement's eq. 3), before tile rounding: for random triangles,
    /// opacities in [0.01, 1] and σ from 0.01 to 5 (log-uniform), every
    /// point whose influence o·I(p) is ≥ 0.01 (all pixel centres around the
    /// triangle and a quarter-pixel grid, I evaluated in f64 from the same
    /// edge lines) lies in the box, and the box lies in the bounding box of
    /// the projected vertices (tolerance 1e-6 px, far below a pixel and
    /// above the f64 rounding of intersecting lines some 100 px long).
    /// Triangles with a corner under 1° are left out: there consecutive
    /// edge normals can be within 1e-3 of parallel and the reference skips
    /// that corner (see [`tight_box`]). At least one point of each region
    /// is seen, so the test is not empty.
    #[test]
    fn tight_box_contains_the_influence_region() {
        use crate::testutil::Lcg;
        let cam = test_camera(96, 80, 80.0);
        let rows = rotation_rows(&cam);
        let s = RasterSettings::default();
        let mut r = Lcg(17);
        let (mut tested, mut seen) = (0, 0);
        while tested < 300 {
            let c = [r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(3.0, 6.0)];
            let size = r.range(0.05, 1.5);
            let verts: [[f64; 3]; 3] = std::array::from_fn(|_| {
                [
                    (c[0] + size * r.range(-1.0, 1.0)) as f64,
                    (c[1] + size * r.range(-1.0, 1.0)) as f64,
                    (c[2] + 0.5 * size * r.range(-1.0, 1.0)) as f64,
                ]
            });
            let opacity = r.range(0.01, 1.0);
            let sigma = (0.01f64.ln() + (500f64).ln() * r.next_f64()).exp() as f32;
            let Some(p) =
                project_tri_t::<f64>(verts, sigma, opacity, &[[0.0; 3]], 0, &cam, &rows, &s)
            else {
                continue;
            };
            // projected vertices (identity pose: view = world)
            let pv = verts.map(|v| {
                let iz = 1.0 / (v[2] + 1e-7);
                [v[0] * iz * cam.fx + cam.cx, v[1] * iz * cam.fy + cam.cy]
            });
            let min_angle = (0..3)
                .map(|i| {
                    let (a, b, c) = (pv[i], pv[(i + 1) % 3], pv[(i + 2) % 3]);
                    let (u, v) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
                    let cos = (u[0] * v[0] + u[1] * v[1])
                        / ((u[0] * u[0] + u[1] * u[1]).sqrt() * (v[0] * v[0] + v[1] * v[1]).sqrt());
                    cos.clamp(-1.0, 1.0).acos().to_degrees()
                })
                .fold(180.0f64, f64::min);
            if min_angle < 1.0 {
                continue;
            }
            tested += 1;
            let b = tight_box(&p.edges, p.phi_s, opacity, sigma).expect("a box");
            let vb = [
                pv.iter().map(|q| q[0]).fold(f64::INFINITY, f64::min),
                pv.iter().map(|q| q[1]).fold(f64::INFINITY, f64::min),
                pv.iter().map(|q| q[0]).fold(f64::NEG_INFINITY, f64::max),
                pv.iter().map(|q| q[1]).fold(f64::NEG_INFINITY, f64::max),
            ];
            let eps = 1e-6;
            assert!(
                b[0] >= vb[0] - eps
                    && b[1] >= vb[1] - eps
                    && b[2] <= vb[2] + eps
                    && b[3] <= vb[3] + eps,
                "box {b:?} outside the vertex box {vb:?}"
            );
            let influence = |x: f64, y: f64| {
                let phi = p
                    .edges
                    .iter()
                    .map(|e| e[0] * x + e[1] * y + e[2])
                    .fold(f64::NEG_INFINITY, f64::max);
                if phi > 0.0 {
                    0.0
                } else {
                    opacity as f64 * (phi / p.phi_s).powf(sigma as f64)
                }
            };
            let check = |x: f64, y: f64| {
                let hit = influence(x, y) >= 0.01;
                if hit {
                    assert!(
                        x >= b[0] - eps && x <= b[2] + eps && y >= b[1] - eps && y <= b[3] + eps,
                        "({x}, {y}) has o·I ≥ 0.01 outside the box {b:?} (o {opacity}, σ {sigma})"
                    );
                }
                hit as usize
            };
            let (x0, y0) = ((vb[0] - 2.0).floor(), (vb[1] - 2.0).floor());
            let (x1, y1) = ((vb[2] + 2.0).ceil(), (vb[3] + 2.0).ceil());
            let (nx, ny) = (((x1 - x0) * 4.0) as usize, ((y1 - y0) * 4.0) as usize);
            let before = seen;
            for j in 0..=ny {
                for i in 0..=nx {
                    // quarter-pixel grid; every fourth point (offset 2) is a
                    // pixel centre
                    seen += check(x0 + i as f64 * 0.25, y0 + j as f64 * 0.25);
                }
            }
            // the incenter has influence o ≥ 0.01
            let inc = {
                let (la, lb, lc) = (
                    ((pv[1][0] - pv[2][0]).powi(2) + (pv[1][1] - pv[2][1]).powi(2)).sqrt(),
                    ((pv[0][0] - pv[2][0]).powi(2) + (pv[0][1] - pv[2][1]).powi(2)).sqrt(),
                    ((pv[0][0] - pv[1][0]).powi(2) + (pv[0][1] - pv[1][1]).powi(2)).sqrt(),
                );
                let per = la + lb + lc;
                [
                    (la * pv[0][0] + lb * pv[1][0] + lc * pv[2][0]) / per,
                    (la * pv[0][1] + lb * pv[1][1] + lc * pv[2][1]) / per,
                ]
            };
            seen += check(inc[0], inc[1]);
            assert!(seen > before, "no point of the region seen");
        }
    }
}
