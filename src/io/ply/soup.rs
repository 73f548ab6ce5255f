//! PLY ↔ [`TriangleSoup`]: splatkit's interchange file for triangle splats.
//!
//! A mesh viewer opens it as a mesh: element `vertex` (`x y z`, three
//! unshared vertices per triangle) and element `face` with `vertex_indices`,
//! `red green blue` (uchar, the DC colour, for viewers; recomputed on write,
//! ignored on read) and the raw splat parameters: `opacity` (logit), `sigma`
//! (raw, σ = 0.01 + exp(raw)), `f_dc_0..2` and channel-major `f_rest_*` as in
//! 3DGS. A header comment `active_sh_degree D` keeps the training's degree.
//! Readers accept shared vertices too (any triangle mesh with these face
//! properties).

use std::io::Write;

use super::common::{sh_degree_from_rest, take_f32, take_xyz, triangulate, u8_col};
use super::{Format, Ply, PlyReader, write_ply};
use crate::model::{Column, Element, Extras, ScalarData, TriangleSoup};
use crate::{Error, Result};

const ACTIVE_DEGREE: &str = "active_sh_degree ";

/// Parses a triangle-soup PLY.
pub fn parse_soup(name: &str, bytes: &[u8]) -> Result<TriangleSoup> {
    let (mut ply, _) = PlyReader::new(name, bytes)?.read()?;
    let mut v = ply
        .take_element("vertex")
        .ok_or_else(|| Error::format(name, "no 'vertex' element"))?;
    let verts = take_xyz(name, &mut v, ["x", "y", "z"])?
        .ok_or_else(|| Error::format(name, "element 'vertex' has no x, y, z"))?;
    let mut f = ply
        .take_element("face")
        .ok_or_else(|| Error::format(name, "no 'face' element: not a triangle soup"))?;
    for need in ["opacity", "sigma", "f_dc_0", "f_dc_1", "f_dc_2"] {
        if f.property(need).is_none() {
            return Err(Error::format(
                name,
                format!(
                    "element 'face' has no '{need}': not a triangle-splat soup (export a mesh with `export-off` instead)"
                ),
            ));
        }
    }
    let list = f
        .take("vertex_indices")
        .or_else(|| f.take("vertex_index"))
        .ok_or_else(|| Error::format(name, "element 'face' has no vertex_indices list"))?;
    let (tris, src) = triangulate(name, "face", &list, verts.len())?;
    if src.len() != f.count || src.iter().enumerate().any(|(i, &s)| i != s) {
        return Err(Error::format(
            name,
            "triangle soup faces must all be triangles",
        ));
    }
    let triangles = tris.iter().map(|t| t.map(|i| verts[i as usize])).collect();
    let opacity_raw = take_f32(&mut f, "opacity")
        .ok_or_else(|| Error::format(name, "'opacity' must be a scalar"))?;
    let sigma_raw =
        take_f32(&mut f, "sigma").ok_or_else(|| Error::format(name, "'sigma' must be a scalar"))?;
    let dc: Vec<Vec<f32>> = (0..3)
        .map(|c| {
            take_f32(&mut f, &format!("f_dc_{c}"))
                .ok_or_else(|| Error::format(name, "f_dc_* must be scalars"))
        })
        .collect::<Result<_>>()?;
    let sh_degree =
        sh_degree_from_rest(name, "face", f.properties.iter().map(|p| p.name.as_str()))?;
    let k = (sh_degree + 1) * (sh_degree + 1) - 1;
    let m = 3 * k;
    let rest_cols: Vec<Vec<f32>> = (0..m)
        .map(|i| {
            take_f32(&mut f, &format!("f_rest_{i}"))
                .ok_or_else(|| Error::format(name, "f_rest_* must be scalars"))
        })
        .collect::<Result<_>>()?;
    let n = f.count;
    // Channel-major columns (file) to coefficient-major rows (memory).
    let mut sh_rest = vec![0f32; n * m];
    for c in 0..3 {
        for kk in 0..k {
            for (i, &v) in rest_cols[c * k + kk].iter().enumerate() {
                sh_rest[(i * k + kk) * 3 + c] = v;
            }
        }
    }
    for c in ["red", "green", "blue"] {
        f.take(c);
    }
    let mut comments = ply.comments;
    let mut active = sh_degree;
    comments.retain(|c| match c.strip_prefix(ACTIVE_DEGREE) {
        Some(d) => {
            active = d.trim().parse().unwrap_or(sh_degree).min(sh_degree);
            false
        }
        None => true,
    });
    let soup = TriangleSoup {
        triangles,
        opacity_raw,
        sigma_raw,
        sh_degree,
        active_sh_degree: active,
        sh_dc: (0..n).map(|i| [dc[0][i], dc[1][i], dc[2][i]]).collect(),
        sh_rest,
        extras: Extras {
            item: f.properties,
            vertex: Vec::new(),
            elements: ply.elements,
            comments,
            obj_info: ply.obj_info,
        },
    };
    soup.validate().map_err(|e| e.in_file(name))?;
    Ok(soup)
}

/// The PLY structure of a soup.
pub fn soup_to_ply(s: &TriangleSoup, format: Format) -> Result<Ply> {
    s.validate()
        .map_err(|e| Error::invalid(format!("cannot write triangle soup: {e}")))?;
    let n = s.len();
    let mut v = Element::new("vertex", 3 * n);
    for c in 0..3 {
        v.push(
            ["x", "y", "z"][c],
            Column::Scalar(ScalarData::F32(
                s.triangles
                    .iter()
                    .flat_map(|t| t.iter().map(move |p| p[c]))
                    .collect(),
            )),
        );
    }
    let mut f = Element::new("face", n);
    f.push(
        "vertex_indices",
        super::common::triangle_list(
            &(0..n as u32)
                .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
                .collect::<Vec<_>>(),
        ),
    );
    for c in 0..3 {
        f.push(
            ["red", "green", "blue"][c],
            u8_col((0..s.len()).map(|i| s.dc_rgb8(i)[c])),
        );
    }
    let col = |x: &[f32]| Column::Scalar(ScalarData::F32(x.to_vec()));
    f.push("opacity", col(&s.opacity_raw));
    f.push("sigma", col(&s.sigma_raw));
    for c in 0..3 {
        f.push(
            format!("f_dc_{c}"),
            col(&s.sh_dc.iter().map(|d| d[c]).collect::<Vec<_>>()),
        );
    }
    let k = s.rest_per_channel();
    for c in 0..3 {
        for kk in 0..k {
            f.push(
                format!("f_rest_{}", c * k + kk),
                col(&(0..n)
                    .map(|i| s.sh_rest[(i * k + kk) * 3 + c])
                    .collect::<Vec<_>>()),
            );
        }
    }
    f.properties.extend(s.extras.item.iter().cloned());
    let mut comments = s.extras.comments.clone();
    comments.push(format!("{ACTIVE_DEGREE}{}", s.active_sh_degree));
    let mut elements = vec![v, f];
    elements.extend(s.extras.elements.iter().cloned());
    Ok(Ply {
        format,
        comments,
        obj_info: s.extras.obj_info.clone(),
        elements,
    })
}

/// Writes a soup.
pub fn write_soup(w: &mut dyn Write, s: &TriangleSoup, format: Format) -> Result<()> {
    write_ply(w, &soup_to_ply(s, format)?, format)
}
