//! Triangle meshes.

use super::Extras;
use super::texture::Texture;
use crate::Error;

/// An indexed triangle mesh. Polygons read from files are fan-triangulated.
/// Optional attributes are either absent or have one entry per vertex / face.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions (world units).
    pub vertices: Vec<[f32; 3]>,
    /// Triangles as vertex indices; winding is counter-clockwise seen from the
    /// side the normal points to, when the source defines one.
    pub faces: Vec<[u32; 3]>,
    /// Per-vertex unit normals.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per-vertex RGBA colours (alpha 255 when the source had none).
    pub vertex_colors: Option<Vec<[u8; 4]>>,
    /// Per-face RGBA colours.
    pub face_colors: Option<Vec<[u8; 4]>>,
    /// Texture coordinates (u, v) of each face's three corners, in face
    /// order (OBJ's `vt`: v points up, see [`super::texture`]). A face whose
    /// corners carry NaN has no texture (its material had none, or another
    /// image than [`Mesh::texture`]).
    pub uvs: Option<Vec<[[f32; 2]; 3]>>,
    /// The texture image the `uvs` index (OBJ `map_Kd`).
    pub texture: Option<Box<Texture>>,
    /// Per-vertex scalars the pipeline uses by name, such as Poisson `density`.
    pub vertex_scalars: Vec<(String, Vec<f32>)>,
    /// Everything else from the source file (extra face properties live in
    /// `extras.item`, extra vertex properties in `extras.vertex`).
    pub extras: Extras,
}

impl Mesh {
    /// A mesh from vertices and triangles, no attributes.
    pub fn new(vertices: Vec<[f32; 3]>, faces: Vec<[u32; 3]>) -> Self {
        Mesh {
            vertices,
            faces,
            ..Default::default()
        }
    }

    /// The per-vertex scalar called `name`.
    pub fn scalar(&self, name: &str) -> Option<&[f32]> {
        self.vertex_scalars
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// Checks that every face index is in range and every attribute has the
    /// right length; the message names the first problem.
    pub fn validate(&self) -> crate::Result<()> {
        let nv = self.vertices.len();
        if let Some((i, f)) = self
            .faces
            .iter()
            .enumerate()
            .find(|(_, f)| f.iter().any(|&v| v as usize >= nv))
        {
            return Err(Error::invalid(format!(
                "face {i} references vertex {} but there are only {nv} vertices",
                f.iter().max().unwrap()
            )));
        }
        let check = |what: &str, len: Option<usize>, want: usize| match len {
            Some(l) if l != want => Err(Error::invalid(format!(
                "{what} has {l} entries, expected {want}"
            ))),
            _ => Ok(()),
        };
        check("normals", self.normals.as_ref().map(Vec::len), nv)?;
        check(
            "vertex colours",
            self.vertex_colors.as_ref().map(Vec::len),
            nv,
        )?;
        check(
            "face colours",
            self.face_colors.as_ref().map(Vec::len),
            self.faces.len(),
        )?;
        check(
            "texture coordinates",
            self.uvs.as_ref().map(Vec::len),
            self.faces.len(),
        )?;
        if let Some(t) = &self.texture {
            t.validate()?;
        }
        for (n, v) in &self.vertex_scalars {
            check(n, Some(v.len()), nv)?;
        }
        for p in &self.extras.vertex {
            check(&p.name, Some(p.data.rows()), nv)?;
        }
        for p in &self.extras.item {
            check(&p.name, Some(p.data.rows()), self.faces.len())?;
        }
        Ok(())
    }

    /// Axis-aligned bounds (min, max), `None` for an empty mesh.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        bounds(&self.vertices)
    }
}

/// Axis-aligned bounds of points, ignoring non-finite coordinates.
pub fn bounds(points: &[[f32; 3]]) -> Option<([f32; 3], [f32; 3])> {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    let mut any = false;
    for p in points {
        if p.iter().all(|c| c.is_finite()) {
            any = true;
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    any.then_some((lo, hi))
}
