//! SuGaR's texture export (V2 semantics, `reference/sugar.md` §5): a
//! trivial atlas with a private half-square per triangle, filled with the
//! average colour that 3DGS renders (SH DC only, black background) give each
//! texel over the training views.
//!
//! # Atlas ([`Atlas`])
//! Triangles are packed in pairs into squares of `s` texels (`s` ≥ 4; 8 by
//! default, as SuGaR V2). Face `f` lives in square `k = f / 2`, at column
//! `k mod P` and row `⌊k / P⌋` of a grid of `P = ⌊√(⌊F/2⌋ + 1) + 1⌋` squares
//! per side, so the texture is `s·P` texels square. Even faces take the
//! upper-left half of their square, odd faces the lower-right half.
//!
//! Within a square, in texel units with (0, 0) at its top-left corner
//! (x right, y down the image rows) and local texel (p, q) covering
//! [p, p+1] × [q, q+1]:
//! - the even face owns the texels with p + q ≤ s − 2, and its corners 0, 1,
//!   2 are at (0.5, 0.5), (s − 2.5, 0.5), (0.5, s − 2.5);
//! - the odd face owns the texels with p + q ≥ s, and its corners are the
//!   mirror images (s − 0.5, s − 0.5), (2.5, s − 0.5), (s − 0.5, 2.5);
//! - the diagonal p + q = s − 1 between them is a separator.
//!
//! These insets (half a texel at the square's border, a texel and a half
//! across the diagonal) make a bilinear lookup anywhere inside a triangle
//! read only texels that triangle owns (a lookup at the hypotenuse gives the
//! next diagonal zero weight), so nothing bleeds between faces at full
//! resolution. Texture coordinates are u = x / (s·P), v = 1 − y / (s·P) (OBJ's
//! v axis points up; row 0 of the image is v = 1, see [`crate::model::texture`]),
//! three private ones per face.
//!
//! # Colours ([`Baker`], [`bake_texture`])
//! For each view, the mesh is z-buffered (`splatkit_render::mesh`, face and
//! perspective-correct barycentrics per pixel centre) and the Gaussians are
//! rendered with SH degree 0 on black. A covered pixel with face `f` and
//! barycentrics `w` adds its rendered RGB to the texel holding the point
//! `w₀A + w₁B + w₂C` of `f`'s atlas triangle (the texel it falls in; always
//! one `f` owns), and to `f`'s running sum. Then:
//! - a texel hit at least once gets the mean of its hits;
//! - a texel of a face seen in some view but never hit itself gets the
//!   face's mean (over all its pixels in all views);
//! - every texel of a face never seen gets the mean SH-DC colour
//!   (0.5 + C₀·dc) of the Gaussians bound to it ([`face_gaussian_colours`]);
//! - separator texels get the mean of their two neighbours across the
//!   diagonal (the last square's unused half and unused squares stay black);
//! - everything is clamped to [0, 1] and rounded to 8 bits.

use rayon::prelude::*;
use splatkit_render::gaussian::{self, Gaussians3, RasterSettings};
use splatkit_render::mesh::{self as zbuffer, MeshRender};

use crate::model::{Camera, Gaussians, Mesh, ScalarData, Texture};
use crate::{Error, Result};

/// SuGaR V2's square size in texels.
pub const DEFAULT_SQUARE: usize = 8;

/// The texel layout of a baked texture (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Atlas {
    /// Number of faces.
    pub faces: usize,
    /// Square size `s`, texels.
    pub square: usize,
    /// Squares per side, `P = ⌊√(⌊F/2⌋ + 1) + 1⌋`.
    pub per_side: usize,
}

/// ⌊√n⌋ exactly.
fn isqrt(n: u64) -> u64 {
    let mut r = (n as f64).sqrt() as u64;
    while r * r > n {
        r -= 1;
    }
    while (r + 1) * (r + 1) <= n {
        r += 1;
    }
    r
}

impl Atlas {
    /// Squares per side for `faces` faces: ⌊√(⌊F/2⌋ + 1) + 1⌋.
    pub fn squares_per_side(faces: usize) -> usize {
        isqrt(faces as u64 / 2 + 1) as usize + 1
    }

    /// Texture side in texels for `faces` faces and squares of `square`
    /// texels, computed without allocating (u64, so no overflow).
    pub fn side_for(faces: usize, square: usize) -> u64 {
        square as u64 * Self::squares_per_side(faces) as u64
    }

    /// The atlas of `faces` faces in squares of `square` texels (≥ 4).
    pub fn new(faces: usize, square: usize) -> Result<Self> {
        if square < 4 {
            return Err(Error::invalid(format!(
                "square size {square} is too small: a square of s texels holds two triangles with insets only for s >= 4"
            )));
        }
        Ok(Atlas {
            faces,
            square,
            per_side: Self::squares_per_side(faces),
        })
    }

    /// Texture side in texels.
    pub fn size(&self) -> usize {
        self.square * self.per_side
    }

    /// Top-left texel (column, row) of face `f`'s square.
    fn origin(&self, f: usize) -> (usize, usize) {
        let k = f / 2;
        (
            (k % self.per_side) * self.square,
            (k / self.per_side) * self.square,
        )
    }

    /// Face `f`'s triangle in atlas texel coordinates (x right, y down the
    /// image rows, texel (c, r) covering [c, c+1] × [r, r+1]), corners in
    /// the face's vertex order.
    pub fn corners(&self, f: usize) -> [[f64; 2]; 3] {
        let (ox, oy) = self.origin(f);
        let s = self.square as f64;
        let local = if f.is_multiple_of(2) {
            [[0.5, 0.5], [s - 2.5, 0.5], [0.5, s - 2.5]]
        } else {
            [[s - 0.5, s - 0.5], [2.5, s - 0.5], [s - 0.5, 2.5]]
        };
        local.map(|[x, y]| [ox as f64 + x, oy as f64 + y])
    }

    /// Face `f`'s texture coordinates (u right, v up).
    pub fn uvs(&self, f: usize) -> [[f32; 2]; 3] {
        let t = self.size() as f64;
        self.corners(f)
            .map(|[x, y]| [(x / t) as f32, (1.0 - y / t) as f32])
    }

    /// Whether local texel (p, q) of a square belongs to its even (`false`)
    /// or odd (`true`) face; `None` on the separator diagonal.
    fn owner(&self, p: usize, q: usize) -> Option<bool> {
        let s = self.square;
        match p + q {
            d if d + 2 <= s => Some(false),
            d if d >= s => Some(true),
            _ => None,
        }
    }

    /// The texel (row-major index in the texture) that barycentrics `w` of
    /// face `f` fall in; always one `f` owns.
    pub fn texel_at(&self, f: usize, w: [f64; 3]) -> usize {
        let c = self.corners(f);
        let x = w[0] * c[0][0] + w[1] * c[1][0] + w[2] * c[2][0];
        let y = w[0] * c[0][1] + w[1] * c[1][1] + w[2] * c[2][1];
        let (ox, oy) = self.origin(f);
        let s = self.square;
        let clamp = |v: f64, o: usize| ((v - o as f64).floor().max(0.0) as usize).min(s - 1);
        let (mut p, mut q) = (clamp(x, ox), clamp(y, oy));
        // guard against rounding on the hypotenuse: step into the own half
        if f.is_multiple_of(2) {
            while p + q > s - 2 {
                if p >= q { p -= 1 } else { q -= 1 }
            }
        } else {
            while p + q < s {
                if p <= q { p += 1 } else { q += 1 }
            }
        }
        (oy + q) * self.size() + ox + p
    }

    /// The texels face `f` owns, row-major indices.
    pub fn texels(&self, f: usize) -> Vec<usize> {
        let (ox, oy) = self.origin(f);
        let odd = f % 2 == 1;
        let mut out = Vec::new();
        for q in 0..self.square {
            for p in 0..self.square {
                if self.owner(p, q) == Some(odd) {
                    out.push((oy + q) * self.size() + ox + p);
                }
            }
        }
        out
    }
}

/// The mean SH-DC colour (0.5 + C₀·dc per channel, clamped to [0, 1]) of
/// the Gaussians bound to each face, `None` for a face with none.
///
/// Binding: the Gaussians' `face_index` integer property when the PLY has
/// one (SuGaR-style bound Gaussians written with their binding); otherwise
/// SuGaR's face-major order, Gaussian `i` on face `i / n` with
/// n = N / F, which needs N to be a multiple of F.
pub fn face_gaussian_colours(g: &Gaussians, faces: usize) -> Result<Vec<Option<[f32; 3]>>> {
    let n = g.len();
    let face_of: Vec<usize> = match g.extras.item.iter().find(|p| p.name == "face_index") {
        Some(p) => {
            let data = p.data.as_scalar().filter(|d| !d.scalar_type().is_float());
            let Some(data) = data else {
                return Err(Error::invalid(
                    "the Gaussians' face_index property is not an integer scalar",
                ));
            };
            let idx = match data {
                ScalarData::I32(v) => v.iter().map(|&x| x as i64).collect::<Vec<_>>(),
                other => (0..other.len()).map(|i| other.get_f64(i) as i64).collect(),
            };
            if let Some((i, &bad)) = idx
                .iter()
                .enumerate()
                .find(|(_, x)| **x < 0 || **x as usize >= faces)
            {
                return Err(Error::invalid(format!(
                    "Gaussian {i} has face_index {bad}, but the mesh has {faces} faces"
                )));
            }
            idx.into_iter().map(|x| x as usize).collect()
        }
        None => {
            if faces == 0 || n == 0 || !n.is_multiple_of(faces) {
                return Err(Error::invalid(format!(
                    "{n} Gaussians cannot be bound to {faces} faces: SuGaR binds n Gaussians per \
                     face in face-major order (Gaussian i on face i / n), so the count must be a \
                     multiple of the face count; give the Gaussians a face_index property, or the \
                     mesh they were bound to"
                )));
            }
            let per = n / faces;
            (0..n).map(|i| i / per).collect()
        }
    };
    let mut sums = vec![[0f64; 3]; faces];
    let mut counts = vec![0u32; faces];
    for (i, &f) in face_of.iter().enumerate() {
        for (s, &dc) in sums[f].iter_mut().zip(&g.sh_dc[i]) {
            *s += splatkit_render::sh::sh_to_rgb(dc) as f64;
        }
        counts[f] += 1;
    }
    Ok(sums
        .iter()
        .zip(&counts)
        .map(|(s, &c)| (c > 0).then(|| s.map(|v| (v / c as f64).clamp(0.0, 1.0) as f32)))
        .collect())
}

/// Accumulates rendered colours into atlas texels over views.
pub struct Baker {
    atlas: Atlas,
    sums: Vec<[f32; 3]>,
    counts: Vec<u32>,
    face_sums: Vec<[f64; 3]>,
    face_counts: Vec<u64>,
    views: usize,
}

/// What a bake did.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeStats {
    pub faces: usize,
    /// Texture side, texels.
    pub texture_size: usize,
    pub views: usize,
    /// Faces covering at least one pixel of some view.
    pub seen_faces: usize,
    /// Owned texels hit at least once.
    pub hit_texels: usize,
    /// Texels owned by faces.
    pub owned_texels: usize,
}

impl BakeStats {
    /// Seen faces / faces (1 for an empty mesh).
    pub fn seen_fraction(&self) -> f64 {
        if self.faces == 0 {
            1.0
        } else {
            self.seen_faces as f64 / self.faces as f64
        }
    }
}

impl Baker {
    /// Bytes a bake of this atlas holds in memory (accumulators and the
    /// 8-bit image): 19 per texel.
    pub fn bytes_for(side: u64) -> f64 {
        side as f64 * side as f64 * 19.0
    }

    /// Empty accumulators for `atlas`.
    pub fn new(atlas: Atlas) -> Self {
        let t = atlas.size() * atlas.size();
        Baker {
            atlas,
            sums: vec![[0.0; 3]; t],
            counts: vec![0; t],
            face_sums: vec![[0.0; 3]; atlas.faces],
            face_counts: vec![0; atlas.faces],
            views: 0,
        }
    }

    /// Adds one view: the mesh z-buffer and the colour image of the same
    /// camera (same size, row-major).
    pub fn add_view(&mut self, z: &MeshRender, rgb: &[[f32; 3]]) {
        assert_eq!(z.face.len(), rgb.len(), "z-buffer and image sizes differ");
        // the texel of every covered pixel, in parallel; summed in pixel
        // order, so the result does not depend on the thread count
        let atlas = self.atlas;
        let hits: Vec<(usize, u32, usize)> = z
            .face
            .par_iter()
            .zip(&z.bary)
            .enumerate()
            .filter_map(|(i, (&f, &[u, v]))| {
                if f == zbuffer::NO_FACE || f as usize >= atlas.faces {
                    return None;
                }
                let (u, v) = (u as f64, v as f64);
                Some((i, f, atlas.texel_at(f as usize, [1.0 - u - v, u, v])))
            })
            .collect();
        for &(i, f, t) in &hits {
            let c = rgb[i];
            let s = &mut self.sums[t];
            for k in 0..3 {
                s[k] += c[k];
                self.face_sums[f as usize][k] += c[k] as f64;
            }
            self.counts[t] += 1;
            self.face_counts[f as usize] += 1;
        }
        self.views += 1;
    }

    /// The texture (see the module docs for the rules) and the statistics;
    /// `fallback[f]` is the colour of a face never seen (black when `None`
    /// or missing).
    pub fn finish(self, fallback: &[Option<[f32; 3]>]) -> (Texture, BakeStats) {
        let a = self.atlas;
        let size = a.size();
        let s = a.square;
        let face_colour = |f: usize| -> [f32; 3] {
            let c = self.face_counts[f];
            if c > 0 {
                self.face_sums[f].map(|v| (v / c as f64) as f32)
            } else {
                fallback.get(f).copied().flatten().unwrap_or([0.0; 3])
            }
        };
        let to8 = |c: [f32; 3]| c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
        let mut pixels = vec![[0u8; 3]; size * size];
        // one band of square rows at a time: faces never share a band
        pixels
            .par_chunks_mut(s * size)
            .enumerate()
            .for_each(|(band, px)| {
                for col in 0..a.per_side {
                    let k = band * a.per_side + col;
                    let even = 2 * k;
                    if even >= a.faces {
                        break;
                    }
                    let faces = [Some(even), (even + 1 < a.faces).then_some(even + 1)];
                    let mut colour_of = [[0f32; 3]; 2];
                    for (h, f) in faces.iter().enumerate() {
                        if let Some(f) = *f {
                            colour_of[h] = face_colour(f);
                        }
                    }
                    let texel = |p: usize, q: usize| -> Option<[f32; 3]> {
                        let h = a.owner(p, q)? as usize;
                        faces[h]?;
                        let g = (band * s + q) * size + col * s + p;
                        Some(match self.counts[g] {
                            0 => colour_of[h],
                            c => self.sums[g].map(|v| v / c as f32),
                        })
                    };
                    for q in 0..s {
                        for p in 0..s {
                            let c = match a.owner(p, q) {
                                Some(_) => texel(p, q),
                                None => {
                                    // separator: mean of the neighbours across it
                                    let lo = if q >= 1 {
                                        texel(p, q - 1)
                                    } else {
                                        texel(p - 1, q)
                                    };
                                    let hi = if q + 1 < s {
                                        texel(p, q + 1)
                                    } else {
                                        texel(p + 1, q)
                                    };
                                    match (lo, hi) {
                                        (Some(l), Some(h)) => {
                                            Some(std::array::from_fn(|k| 0.5 * (l[k] + h[k])))
                                        }
                                        (l, h) => l.or(h),
                                    }
                                }
                            };
                            if let Some(c) = c {
                                px[q * size + col * s + p] = to8(c);
                            }
                        }
                    }
                }
            });
        let owned_per_square = |p_q_sum_ok: &dyn Fn(usize) -> bool| {
            (0..s * s).filter(|&i| p_q_sum_ok(i % s + i / s)).count()
        };
        let lower = owned_per_square(&|d| d + 2 <= s);
        let upper = owned_per_square(&|d| d >= s);
        let owned = a.faces.div_ceil(2) * lower + (a.faces / 2) * upper;
        let stats = BakeStats {
            faces: a.faces,
            texture_size: size,
            views: self.views,
            seen_faces: self.face_counts.iter().filter(|&&c| c > 0).count(),
            hit_texels: self.counts.iter().filter(|&&c| c > 0).count(),
            owned_texels: owned,
        };
        let texture = Texture {
            name: String::new(),
            width: size,
            height: size,
            pixels,
        };
        (texture, stats)
    }
}

/// Settings of [`bake_texture`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BakeParams {
    /// Square size in texels (≥ 4).
    pub square: usize,
    /// Near plane (camera z) of both renders.
    pub near: f64,
    /// Largest texture side accepted, texels; a larger atlas is refused
    /// before anything is allocated.
    pub max_texture: usize,
}

impl Default for BakeParams {
    fn default() -> Self {
        BakeParams {
            square: DEFAULT_SQUARE,
            near: 0.2,
            max_texture: 16384,
        }
    }
}

/// Bytes per atlas texel a bake holds: the accumulators (RGB sums 12,
/// counts 4), the 8-bit texture (3) and, when it is written, the PNG
/// encoder's raw and filtered rows and compressed output (at most 3 each).
pub const BAKE_BYTES_PER_TEXEL: u64 = 12 + 4 + 3 + 9;
/// Bytes per mesh face a bake holds: the per-face colour sums and counts
/// of the views (24 + 8) and of the bound Gaussians (24 + 4), the fallback
/// colour (16), and in the textured mesh its corner UVs (24) and a copy of
/// the face (12).
pub const BAKE_BYTES_PER_FACE: u64 = 24 + 8 + 24 + 4 + 16 + 24 + 12;
/// Bytes per pixel of the one view a bake renders at a time: the mesh
/// z-buffer (face 4, barycentrics 8, depth 4, normal 12 = 28) and the
/// Gaussian render (52 of output + 12 of working buffers = 64).
pub const BAKE_BYTES_PER_VIEW_PIXEL: u64 = 28 + 64;

/// Bytes [`bake_texture`] needs for a mesh of `faces` faces in squares of
/// `square` texels, rendered from views whose largest has
/// `largest_view_pixels` pixels: side² × [`BAKE_BYTES_PER_TEXEL`] (side =
/// [`Atlas::side_for`]) + faces × [`BAKE_BYTES_PER_FACE`] +
/// largest_view_pixels × [`BAKE_BYTES_PER_VIEW_PIXEL`]; saturating. The
/// mesh's vertices and the Gaussians, already in memory, are not counted.
pub fn bake_bytes(faces: usize, square: usize, largest_view_pixels: u64) -> u64 {
    let side = Atlas::side_for(faces, square);
    side.saturating_mul(side)
        .saturating_mul(BAKE_BYTES_PER_TEXEL)
        .saturating_add((faces as u64).saturating_mul(BAKE_BYTES_PER_FACE))
        .saturating_add(largest_view_pixels.saturating_mul(BAKE_BYTES_PER_VIEW_PIXEL))
}

/// Checks the atlas size against `max_texture` without allocating; the
/// error names the size, the memory it would take and the flags to change.
pub fn check_texture_size(faces: usize, p: &BakeParams) -> Result<Atlas> {
    let atlas = Atlas::new(faces, p.square)?;
    let side = Atlas::side_for(faces, p.square);
    if side > p.max_texture as u64 {
        return Err(Error::invalid(format!(
            "the texture for {faces} faces at --square-size {} would be {side}x{side} texels \
             (about {:.0} MB to bake), above --max-texture {}: raise --max-texture, lower \
             --square-size, or decimate the mesh",
            p.square,
            Baker::bytes_for(side) / 1e6,
            p.max_texture
        )));
    }
    Ok(atlas)
}

/// Bakes the Gaussians' colour into a texture on `mesh` from `cameras`
/// (see the module docs). Returns the mesh with [`Mesh::uvs`] and
/// [`Mesh::texture`] set (vertex and face colours dropped, since the texture
/// replaces them; positions, faces and normals kept) and the statistics.
/// `on_view` is called after each view.
pub fn bake_texture(
    mesh: &Mesh,
    gaussians: &Gaussians,
    cameras: &[Camera],
    p: &BakeParams,
    mut on_view: impl FnMut(usize),
) -> Result<(Mesh, BakeStats)> {
    let atlas = check_texture_size(mesh.faces.len(), p)?;
    mesh.validate()?;
    for c in cameras {
        c.require_pinhole()
            .map_err(|e| Error::invalid(format!("camera {:?}: {e}", c.name)))?;
    }
    let fallback = face_gaussian_colours(gaussians, mesh.faces.len())?;
    let g: Gaussians3 = gaussians.to_raster().dc_only();
    let settings = RasterSettings {
        background: [0.0; 3],
        near: p.near,
        ..Default::default()
    };
    let mut baker = Baker::new(atlas);
    for (i, cam) in cameras.iter().enumerate() {
        let z = zbuffer::render(&mesh.vertices, &mesh.faces, cam, p.near);
        let img = gaussian::render(&g, cam, &settings);
        baker.add_view(&z, &img.rgb);
        on_view(i);
    }
    let (texture, stats) = baker.finish(&fallback);
    let out = Mesh {
        vertices: mesh.vertices.clone(),
        faces: mesh.faces.clone(),
        normals: mesh.normals.clone(),
        uvs: Some((0..mesh.faces.len()).map(|f| atlas.uvs(f)).collect()),
        texture: Some(Box::new(texture)),
        ..Default::default()
    };
    Ok((out, stats))
}

#[cfg(test)]
mod tests {
    use std::collections::HashSet;

    use super::*;
    use crate::model::rng;
    use crate::model::{Column, Property};
    use rand::RngExt;

    #[test]
    fn size_formula_is_sugars() {
        for f in [
            0usize, 1, 2, 3, 6, 7, 100, 1151, 200_000, 2_000_000, 9_999_999,
        ] {
            let float = ((f / 2 + 1) as f64).sqrt() + 1.0;
            assert_eq!(
                Atlas::squares_per_side(f),
                float.floor() as usize,
                "F = {f}"
            );
            let a = Atlas::new(f, 8).unwrap();
            // every face has a square
            assert!(a.per_side * a.per_side >= f.div_ceil(2));
        }
        assert_eq!(Atlas::side_for(200_000, 8), 8 * 317);
        // SuGaR's OOM example: 2M triangles at square 10 is about 10k texels
        assert_eq!(Atlas::side_for(2_000_000, 10), 10010);
        assert!(Atlas::new(10, 3).is_err());
    }

    /// The estimate covers what a bake allocates: the Baker's vectors
    /// (their real element sizes), the 8-bit texture, and one view's mesh
    /// z-buffer and Gaussian render; the 60k faces at square 90 is
    /// 15660² texels, several GiB.
    #[test]
    fn bake_bytes_cover_the_allocations() {
        use std::mem::size_of;
        for (faces, square, px) in [(10usize, 8usize, 64u64 * 48), (60_000, 90, 0), (7, 4, 1)] {
            let a = Atlas::new(faces, square).unwrap();
            let t = (a.size() * a.size()) as u64;
            let baker = t * (size_of::<[f32; 3]>() + size_of::<u32>()) as u64
                + faces as u64 * (size_of::<[f64; 3]>() + size_of::<u64>()) as u64;
            let texture = t * size_of::<[u8; 3]>() as u64;
            let fallback = faces as u64 * size_of::<Option<[f32; 3]>>() as u64;
            let view = px
                * (size_of::<u32>()
                    + size_of::<[f32; 2]>()
                    + size_of::<f32>()
                    + size_of::<[f32; 3]>()) as u64
                + px * 52;
            assert!(
                bake_bytes(faces, square, px) >= baker + texture + fallback + view,
                "{faces} {square}"
            );
        }
        assert_eq!(Atlas::side_for(60_000, 90), 15660);
        assert!(bake_bytes(60_000, 90, 0) > 6 << 30);
        assert_eq!(bake_bytes(usize::MAX, 256, u64::MAX), u64::MAX);
    }

    fn random_bary(rng: &mut impl rand::Rng) -> [f64; 3] {
        let (mut a, mut b): (f64, f64) = (rng.random(), rng.random());
        if a + b > 1.0 {
            (a, b) = (1.0 - a, 1.0 - b);
        }
        [1.0 - a - b, a, b]
    }

    #[test]
    fn faces_stay_in_their_half_squares_and_never_share_texels() {
        for (faces, square) in [(37usize, 8usize), (10, 4), (7, 10)] {
            let a = Atlas::new(faces, square).unwrap();
            let t = a.size() as f64;
            let mut all = HashSet::new();
            let mut rng = rng::seeded(faces as u64);
            for f in 0..faces {
                let own: HashSet<usize> = a.texels(f).into_iter().collect();
                assert!(!own.is_empty());
                for &x in &own {
                    assert!(all.insert(x), "texel {x} owned twice");
                }
                let (ox, oy) = a.origin(f);
                let s = square as f64;
                for ([x, y], [u, v]) in a.corners(f).iter().zip(a.uvs(f)) {
                    let (lx, ly) = (x - ox as f64, y - oy as f64);
                    assert!((0.0..=s).contains(&lx) && (0.0..=s).contains(&ly));
                    // lower half: x + y <= s − 2; upper half: >= s + 2
                    if f % 2 == 0 {
                        assert!(lx + ly <= s - 2.0 + 1e-9);
                    } else {
                        assert!(lx + ly >= s + 2.0 - 1e-9);
                    }
                    assert!(
                        (u as f64 - x / t).abs() < 1e-6 && (v as f64 - (1.0 - y / t)).abs() < 1e-6
                    );
                }
                for _ in 0..200 {
                    let w = random_bary(&mut rng);
                    assert!(own.contains(&a.texel_at(f, w)), "face {f} {w:?}");
                }
                for w in [
                    [1.0, 0.0, 0.0],
                    [0.0, 1.0, 0.0],
                    [0.0, 0.0, 1.0],
                    [0.0, 0.5, 0.5],
                ] {
                    assert!(own.contains(&a.texel_at(f, w)));
                }
            }
        }
    }

    /// Bilinear lookups inside a face read only that face's texels: a
    /// texture painted one colour per face gives exactly that colour.
    #[test]
    fn bilinear_lookups_do_not_bleed() {
        let a = Atlas::new(41, 8).unwrap();
        let colour = |f: usize| [(f * 37 % 256) as u8, (f * 91 % 256) as u8, 255 - f as u8];
        let mut tex = Texture {
            name: String::new(),
            width: a.size(),
            height: a.size(),
            pixels: vec![[7, 7, 7]; a.size() * a.size()],
        };
        for f in 0..41 {
            for t in a.texels(f) {
                tex.pixels[t] = colour(f);
            }
        }
        let mut rng = rng::seeded(3);
        for f in 0..41 {
            let uv = a.uvs(f);
            for _ in 0..100 {
                let w = random_bary(&mut rng);
                let u = (0..3).map(|j| w[j] as f32 * uv[j][0]).sum::<f32>();
                let v = (0..3).map(|j| w[j] as f32 * uv[j][1]).sum::<f32>();
                let got = tex.sample(u, v);
                let want = colour(f).map(|c| c as f32 / 255.0);
                for k in 0..3 {
                    assert!(
                        (got[k] - want[k]).abs() < 1e-3,
                        "face {f}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }

    /// Hit texels average their hits, unhit texels of a seen face take the
    /// face's mean, a face never seen takes its Gaussians' colour.
    #[test]
    fn hit_unhit_and_unseen_faces() {
        let a = Atlas::new(2, 8).unwrap();
        // a 2×1 "view" whose two pixels both see face 0 at its first corner
        let z = MeshRender {
            width: 3,
            height: 1,
            face: vec![0, 0, zbuffer::NO_FACE],
            bary: vec![[0.0, 0.0], [0.0, 0.0], [0.0; 2]],
            depth: vec![1.0, 1.0, 0.0],
            normal: vec![[0.0, 0.0, -1.0]; 3],
        };
        let mut b = Baker::new(a);
        b.add_view(&z, &[[0.2, 0.4, 0.6], [0.4, 0.4, 0.4], [1.0; 3]]);
        // a second view hits face 0 elsewhere, with a colour above 1
        let z2 = MeshRender {
            bary: vec![[1.0, 0.0], [1.0, 0.0], [0.0; 2]],
            ..z.clone()
        };
        b.add_view(&z2, &[[1.5, 0.0, 0.0], [1.5, 0.0, 0.0], [0.0; 3]]);
        let (tex, stats) = b.finish(&[Some([0.0; 3]), Some([0.2, 0.4, 0.6])]);
        assert_eq!(stats.seen_faces, 1);
        assert_eq!(stats.hit_texels, 2);
        assert_eq!(stats.views, 2);
        let to8 = |c: [f32; 3]| c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
        let corner0 = a.texel_at(0, [1.0, 0.0, 0.0]);
        let corner1 = a.texel_at(0, [0.0, 1.0, 0.0]);
        assert_eq!(tex.pixels[corner0], to8([0.3, 0.4, 0.5]));
        assert_eq!(tex.pixels[corner1], [255, 0, 0]); // clamped
        let face_mean = to8([(0.2 + 0.4 + 3.0) / 4.0, 0.2, 0.25]);
        for t in a.texels(0) {
            if t != corner0 && t != corner1 {
                assert_eq!(tex.pixels[t], face_mean);
            }
        }
        for t in a.texels(1) {
            assert_eq!(tex.pixels[t], to8([0.2, 0.4, 0.6]));
        }
    }

    fn gaussians_with_dc(dc: Vec<[f32; 3]>) -> Gaussians {
        let n = dc.len();
        Gaussians {
            means: vec![[0.0; 3]; n],
            sh_dc: dc,
            opacity_logits: vec![0.0; n],
            log_scales: vec![[0.0; 3]; n],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
            ..Default::default()
        }
    }

    #[test]
    fn gaussian_colours_face_major_or_face_index() {
        let dc = |rgb: f32| [splatkit_render::sh::rgb_to_sh(rgb); 3];
        let g = gaussians_with_dc(vec![dc(0.1), dc(0.3), dc(0.6), dc(0.8)]);
        let c = face_gaussian_colours(&g, 2).unwrap();
        assert!((c[0].unwrap()[0] - 0.2).abs() < 1e-6 && (c[1].unwrap()[1] - 0.7).abs() < 1e-6);
        let e = face_gaussian_colours(&g, 3).unwrap_err().to_string();
        assert!(e.contains("4 Gaussians cannot be bound to 3 faces"), "{e}");
        assert!(e.contains("face_index"), "{e}");
        let mut g = g;
        g.extras.item.push(Property {
            name: "face_index".into(),
            data: Column::Scalar(ScalarData::I32(vec![2, 0, 2, 0])),
        });
        let c = face_gaussian_colours(&g, 3).unwrap();
        assert!((c[0].unwrap()[0] - 0.55).abs() < 1e-6);
        assert_eq!(c[1], None);
        assert!((c[2].unwrap()[0] - 0.35).abs() < 1e-6);
        let e = face_gaussian_colours(&g, 2).unwrap_err().to_string();
        assert!(e.contains("face_index 2"), "{e}");
    }

    #[test]
    fn oversized_atlas_is_refused_before_allocating() {
        let p = BakeParams {
            max_texture: 1000,
            ..Default::default()
        };
        let e = check_texture_size(2_000_000, &p).unwrap_err().to_string();
        assert!(
            e.contains("8008x8008") && e.contains("--max-texture 1000"),
            "{e}"
        );
        // a size whose accumulators could never be allocated is refused
        // just the same (no allocation happens before the check)
        let huge = check_texture_size(usize::MAX / 4, &BakeParams::default());
        assert!(huge.is_err());
    }
}
