//! PLY ↔ [`Mesh`].
//!
//! Vertex element: `x y z`, optional `nx ny nz`, optional `red green blue
//! [alpha]`; other `float` properties (such as Poisson `density`) become
//! `vertex_scalars`, anything else is kept in `extras.vertex`. Face element:
//! `vertex_indices` (or `vertex_index`), polygons fan-triangulated, optional
//! per-face colours; other face properties are kept in `extras.item`
//! (repeated for each triangle of a split polygon). Other elements (such as
//! the `material` of Stanford scans) are kept in `extras.elements`.

use std::io::Write;

use super::common::{push_rgba, push_xyz, take_rgba, take_xyz, triangle_list, triangulate};
use super::{Format, Ply, PlyReader, write_ply};
use crate::model::{Column, Element, Extras, Mesh, ScalarData};
use crate::{Error, Result};

/// Parses a mesh (a PLY with `vertex` and, usually, `face`).
pub fn parse_mesh(name: &str, bytes: &[u8]) -> Result<Mesh> {
    let (ply, _) = PlyReader::new(name, bytes)?.read()?;
    mesh_from_ply(name, ply)
}

/// Builds a mesh from a decoded PLY.
pub fn mesh_from_ply(name: &str, mut ply: Ply) -> Result<Mesh> {
    let mut v = ply
        .take_element("vertex")
        .ok_or_else(|| Error::format(name, "no 'vertex' element"))?;
    let vertices = take_xyz(name, &mut v, ["x", "y", "z"])?
        .ok_or_else(|| Error::format(name, "element 'vertex' has no x, y, z"))?;
    let normals = take_xyz(name, &mut v, ["nx", "ny", "nz"])?;
    let vertex_colors = take_rgba(name, &mut v)?;
    let mut vertex_scalars = Vec::new();
    let mut extra_vertex = Vec::new();
    for p in v.properties {
        match p.data {
            Column::Scalar(ScalarData::F32(values)) => vertex_scalars.push((p.name, values)),
            _ => extra_vertex.push(p),
        }
    }
    let mut faces = Vec::new();
    let mut face_colors = None;
    let mut extra_face = Vec::new();
    if let Some(mut f) = ply.take_element("face") {
        let list = f
            .take("vertex_indices")
            .or_else(|| f.take("vertex_index"))
            .ok_or_else(|| Error::format(name, "element 'face' has no vertex_indices list"))?;
        let (tris, src) = triangulate(name, "face", &list, vertices.len())?;
        let colors = take_rgba(name, &mut f)?;
        let identity = src.len() == f.count && src.iter().enumerate().all(|(i, &s)| i == s);
        face_colors = colors.map(|c| {
            if identity {
                c
            } else {
                src.iter().map(|&s| c[s]).collect()
            }
        });
        extra_face = f
            .properties
            .into_iter()
            .map(|mut p| {
                if !identity {
                    p.data = p.data.gather(&src);
                }
                p
            })
            .collect();
        faces = tris;
    }
    Ok(Mesh {
        vertices,
        faces,
        normals,
        vertex_colors,
        face_colors,
        vertex_scalars,
        uvs: None,
        texture: None,
        extras: Extras {
            item: extra_face,
            vertex: extra_vertex,
            elements: ply.elements,
            comments: ply.comments,
            obj_info: ply.obj_info,
        },
    })
}

/// The PLY structure of a mesh.
pub fn mesh_to_ply(m: &Mesh, format: Format) -> Result<Ply> {
    m.validate()
        .map_err(|e| Error::invalid(format!("cannot write mesh: {e}")))?;
    let mut v = Element::new("vertex", m.vertices.len());
    push_xyz(&mut v, ["x", "y", "z"], &m.vertices);
    if let Some(n) = &m.normals {
        push_xyz(&mut v, ["nx", "ny", "nz"], n);
    }
    if let Some(c) = &m.vertex_colors {
        push_rgba(&mut v, c);
    }
    for (name, vals) in &m.vertex_scalars {
        v.push(name.clone(), Column::Scalar(ScalarData::F32(vals.clone())));
    }
    v.properties.extend(m.extras.vertex.iter().cloned());
    let mut f = Element::new("face", m.faces.len());
    f.push("vertex_indices", triangle_list(&m.faces));
    if let Some(c) = &m.face_colors {
        push_rgba(&mut f, c);
    }
    f.properties.extend(m.extras.item.iter().cloned());
    let mut elements = vec![v, f];
    elements.extend(m.extras.elements.iter().cloned());
    Ok(Ply {
        format,
        comments: m.extras.comments.clone(),
        obj_info: m.extras.obj_info.clone(),
        elements,
    })
}

/// Writes a mesh.
pub fn write_mesh(w: &mut dyn Write, m: &Mesh, format: Format) -> Result<()> {
    write_ply(w, &mesh_to_ply(m, format)?, format)
}
