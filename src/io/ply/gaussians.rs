//! The standard 3DGS PLY ↔ [`Gaussians`].
//!
//! Layout written (the graphdeco `save_ply` order, all `float`):
//! `x y z [nx ny nz] f_dc_0..2 f_rest_0..M-1 opacity scale_0..2 rot_0..3`,
//! then any extra vertex properties the model carried, then any other
//! elements. `f_rest` is channel-major in the file (`f_rest_{c·K+k}`) and
//! coefficient-major in memory; M = 3·((D+1)²−1) gives the SH degree D.
//!
//! Reading is by property name, in any order and any numeric type (converted
//! to f32). Missing normals and missing `f_rest` (degree 0) are accepted.
//! When the vertex element is binary, fixed-stride and every needed property
//! is `float`, rows are decoded straight from the file bytes in one pass.

use std::io::Write;

use super::common::sh_degree_from_rest;
use super::header::{ElementDef, Format, Header, PropertyDef, PropertyKind, write_header};
use super::read::{PlyReader, RawElement, prop_offsets};
use super::write::{element_def, write_element};
use crate::io::source::werr;
use crate::model::{Column, Element, Extras, Gaussians, ScalarData, ScalarType};
use crate::{Error, Result};

/// Property names in model order: means, [normals], dc, rest (coefficient-major
/// in memory: for k, for c → file name `f_rest_{c·K+k}`), opacity, scales, rotation.
fn slot_names(degree: usize, normals: bool) -> Vec<String> {
    let k = (degree + 1) * (degree + 1) - 1;
    let mut v: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    if normals {
        v.extend(["nx", "ny", "nz"].iter().map(|s| s.to_string()));
    }
    v.extend((0..3).map(|c| format!("f_dc_{c}")));
    for kk in 0..k {
        for c in 0..3 {
            v.push(format!("f_rest_{}", c * k + kk));
        }
    }
    v.push("opacity".into());
    v.extend((0..3).map(|c| format!("scale_{c}")));
    v.extend((0..4).map(|c| format!("rot_{c}")));
    v
}

/// File order of the same properties (channel-major `f_rest`).
fn file_names(degree: usize, normals: bool) -> Vec<String> {
    let k = (degree + 1) * (degree + 1) - 1;
    let mut v: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    if normals {
        v.extend(["nx", "ny", "nz"].iter().map(|s| s.to_string()));
    }
    v.extend((0..3).map(|c| format!("f_dc_{c}")));
    v.extend((0..3 * k).map(|i| format!("f_rest_{i}")));
    v.push("opacity".into());
    v.extend((0..3).map(|c| format!("scale_{c}")));
    v.extend((0..4).map(|c| format!("rot_{c}")));
    v
}

/// Works out SH degree and normals from the vertex declaration.
fn schema(name: &str, def: &ElementDef) -> Result<(usize, bool)> {
    let has = |n: &str| def.index_of(n).is_some();
    let required = [
        "x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
        "rot_0", "rot_1", "rot_2", "rot_3",
    ];
    let missing: Vec<&str> = required.iter().copied().filter(|n| !has(n)).collect();
    if !missing.is_empty() {
        return Err(Error::format(
            name,
            format!(
                "element 'vertex' is not a 3DGS Gaussian layout: missing properties {}",
                missing.join(", ")
            ),
        ));
    }
    let degree = sh_degree_from_rest(
        name,
        "vertex",
        def.properties.iter().map(|p| p.name.as_str()),
    )?;
    let normals = ["nx", "ny", "nz"].iter().filter(|n| has(n)).count();
    if normals != 0 && normals != 3 {
        return Err(Error::format(name, "only some of nx, ny, nz are present"));
    }
    for p in &def.properties {
        if matches!(p.kind, PropertyKind::List { .. })
            && (required.contains(&p.name.as_str()) || p.name.starts_with("f_rest_"))
        {
            return Err(Error::format(
                name,
                format!("property '{}' is a list, expected a scalar", p.name),
            ));
        }
    }
    Ok((degree, normals == 3))
}

/// Pushes one Gaussian's values (model slot order) into `g`.
#[inline(always)]
fn push_row(g: &mut Gaussians, v: &[f32], normals: bool, k3: usize) {
    let mut i = 0;
    let take3 = |i: &mut usize| {
        let r = [v[*i], v[*i + 1], v[*i + 2]];
        *i += 3;
        r
    };
    g.means.push(take3(&mut i));
    if normals {
        let n = take3(&mut i);
        g.normals.as_mut().expect("normals allocated").push(n);
    }
    g.sh_dc.push(take3(&mut i));
    g.sh_rest.extend_from_slice(&v[i..i + k3]);
    i += k3;
    g.opacity_logits.push(v[i]);
    i += 1;
    g.log_scales.push(take3(&mut i));
    g.rotations.push([v[i], v[i + 1], v[i + 2], v[i + 3]]);
}

fn empty(n: usize, degree: usize, normals: bool) -> Gaussians {
    let k3 = ((degree + 1) * (degree + 1) - 1) * 3;
    Gaussians {
        means: Vec::with_capacity(n),
        normals: normals.then(|| Vec::with_capacity(n)),
        sh_degree: degree,
        sh_dc: Vec::with_capacity(n),
        sh_rest: Vec::with_capacity(n * k3),
        opacity_logits: Vec::with_capacity(n),
        log_scales: Vec::with_capacity(n),
        rotations: Vec::with_capacity(n),
        extras: Extras::default(),
    }
}

fn vertex_def<'h>(name: &str, header: &'h Header) -> Result<&'h ElementDef> {
    header
        .element("vertex")
        .ok_or_else(|| Error::format(name, "no 'vertex' element: not a Gaussian splat PLY"))
}

/// Checks, from the header alone, that a PLY has the 3DGS vertex layout;
/// the error says which properties are missing or malformed.
pub fn check_layout(name: &str, bytes: &[u8]) -> Result<()> {
    let header = Header::parse(name, bytes)?;
    if is_compressed(&header) {
        return Ok(());
    }
    schema(name, vertex_def(name, &header)?).map(|_| ())
}

/// Refuses Gaussians that hold a NaN or infinite value in anything a
/// trainer, a binding or a renderer reads: means, SH (DC and rest),
/// opacity, scales and rotations. Normals (3DGS writes zeros; nothing reads
/// them) and extra properties are not checked. The error names `name`, the
/// Gaussian (0-based) and the PLY property (`f_rest_{c·K+k}` as the file
/// numbers it), e.g. `Gaussian 3 has f_dc_1 = NaN, not a finite number`.
/// Cost: one branch-free pass over the values (tens of ms for millions of
/// Gaussians).
pub fn check_finite(name: &str, g: &Gaussians) -> Result<()> {
    let k = g.rest_per_channel();
    let k3 = 3 * k;
    let dc = ["f_dc_0", "f_dc_1", "f_dc_2"];
    let scale = ["scale_0", "scale_1", "scale_2"];
    let rot = ["rot_0", "rot_1", "rot_2", "rot_3"];
    // (values, values per row, name of the value at a position in a row)
    type Named<'a> = (&'a [f32], usize, &'a dyn Fn(usize) -> String);
    let arrays: [Named; 6] = [
        (g.means.as_flattened(), 3, &|j| {
            ["x", "y", "z"][j].to_string()
        }),
        (g.sh_dc.as_flattened(), 3, &|j| dc[j].to_string()),
        // in memory (k, c) coefficient-major, in the file f_rest_{c·K+k}
        (&g.sh_rest, k3.max(1), &|j| {
            format!("f_rest_{}", (j % 3) * k + j / 3)
        }),
        (&g.opacity_logits, 1, &|_| "opacity".to_string()),
        (g.log_scales.as_flattened(), 3, &|j| scale[j].to_string()),
        (g.rotations.as_flattened(), 4, &|j| rot[j].to_string()),
    ];
    for (values, width, prop) in arrays {
        if let Some(t) = super::first_non_finite(values) {
            return Err(Error::format(
                name,
                format!(
                    "Gaussian {} has {} = {}, not a finite number",
                    t / width,
                    prop(t % width),
                    values[t]
                ),
            ));
        }
    }
    Ok(())
}

/// A SuperSplat compressed PLY (`packed_position` on the vertex element).
fn is_compressed(h: &Header) -> bool {
    h.element("vertex")
        .is_some_and(|v| v.index_of("packed_position").is_some())
}

/// Parses a 3DGS PLY from bytes; `name` is used in errors. A SuperSplat
/// compressed PLY is decoded by [`crate::io::splat::compressed_ply::read`].
pub fn parse_gaussians(name: &str, bytes: &[u8]) -> Result<Gaussians> {
    let reader = PlyReader::new(name, bytes)?;
    if is_compressed(&reader.header) {
        return crate::io::splat::compressed_ply::read(name, bytes);
    }
    let def = vertex_def(name, &reader.header)?;
    let vi = reader
        .header
        .elements
        .iter()
        .position(|e| e.name == "vertex")
        .expect("vertex_def found it");
    let (degree, normals) = schema(name, def)?;
    let slots: Vec<usize> = slot_names(degree, normals)
        .iter()
        .map(|n| def.index_of(n).expect("checked by schema"))
        .collect();
    let extra_props: Vec<usize> = (0..def.properties.len())
        .filter(|i| !slots.contains(i))
        .collect();
    let n = def.count as usize;
    let k3 = ((degree + 1) * (degree + 1) - 1) * 3;

    let (mut g, other) = if reader.header.format == Format::Ascii {
        let (mut ply, _) = reader.read()?;
        let mut vertex = ply.take_element("vertex").expect("vertex exists");
        let cols: Vec<Vec<f32>> = slot_names(degree, normals)
            .iter()
            .map(|s| match vertex.property(s) {
                Some(Column::Scalar(d)) => d.to_f32(),
                _ => unreachable!("schema checked"),
            })
            .collect();
        let mut g = empty(n, degree, normals);
        let mut row = vec![0f32; cols.len()];
        for i in 0..n {
            for (r, c) in row.iter_mut().zip(&cols) {
                *r = c[i];
            }
            push_row(&mut g, &row, normals, k3);
        }
        for s in slot_names(degree, normals) {
            vertex.take(&s);
        }
        g.extras.item = vertex.properties;
        (g, ply.elements)
    } else {
        let (raws, _) = reader.locate()?;
        let raw: &RawElement = &raws[vi];
        let all_f32 = slots
            .iter()
            .all(|&i| def.properties[i].kind == PropertyKind::Scalar(ScalarType::F32));
        let mut g = empty(n, degree, normals);
        if let (Some(stride), true) = (raw.stride, all_f32) {
            let offs = prop_offsets(def);
            let src: Vec<usize> = slots.iter().map(|&i| offs[i]).collect();
            let big = reader.header.format == Format::BinaryBigEndian;
            let mut row = vec![0f32; src.len()];
            for bytes in raw.bytes.chunks_exact(stride) {
                for (r, &o) in row.iter_mut().zip(&src) {
                    let a: [u8; 4] = bytes[o..o + 4].try_into().expect("4 bytes");
                    *r = if big {
                        f32::from_be_bytes(a)
                    } else {
                        f32::from_le_bytes(a)
                    };
                }
                push_row(&mut g, &row, normals, k3);
            }
        } else {
            let el = reader.decode_binary(vi, raw, Some(&slots))?;
            let cols: Vec<Vec<f32>> = el
                .properties
                .iter()
                .map(|p| p.data.as_scalar().expect("scalars").to_f32())
                .collect();
            // decode_binary returns properties in `slots` order only for
            // fixed-stride elements; look them up by name to be safe.
            let by_name: Vec<&Vec<f32>> = slot_names(degree, normals)
                .iter()
                .map(|s| &cols[el.index_of(s).expect("decoded")])
                .collect();
            let mut row = vec![0f32; by_name.len()];
            for i in 0..n {
                for (r, c) in row.iter_mut().zip(&by_name) {
                    *r = c[i];
                }
                push_row(&mut g, &row, normals, k3);
            }
        }
        if !extra_props.is_empty() {
            g.extras.item = reader
                .decode_binary(vi, raw, Some(&extra_props))?
                .properties;
        }
        let mut other = Vec::new();
        for (i, r) in raws.iter().enumerate() {
            if i != vi {
                other.push(reader.decode_binary(i, r, None)?);
            }
        }
        (g, other)
    };
    g.extras.elements = other;
    g.extras.comments = reader.header.comments.clone();
    g.extras.obj_info = reader.header.obj_info.clone();
    Ok(g)
}

/// Writes `g` as a 3DGS PLY in `format` (binary little-endian is what every
/// 3DGS tool expects).
pub fn write_gaussians(w: &mut dyn Write, g: &Gaussians, format: Format) -> Result<()> {
    g.validate()
        .map_err(|m| Error::invalid(format!("cannot write Gaussians: {m}")))?;
    let normals = g.normals.is_some();
    let n = g.len();
    let mut vdef = ElementDef {
        name: "vertex".into(),
        count: n as u64,
        properties: file_names(g.sh_degree, normals)
            .into_iter()
            .map(|name| PropertyDef {
                name,
                kind: PropertyKind::Scalar(ScalarType::F32),
            })
            .collect(),
    };
    let extras_def = element_def(&Element {
        name: "vertex".into(),
        count: n,
        properties: g.extras.item.clone(),
    });
    vdef.properties.extend(extras_def.properties);
    let mut defs = vec![vdef];
    defs.extend(g.extras.elements.iter().map(element_def));
    let mut head = Vec::new();
    write_header(
        &mut head,
        format,
        &g.extras.comments,
        &g.extras.obj_info,
        &defs,
    );
    w.write_all(&head).map_err(werr)?;

    if format != Format::Ascii && g.extras.item.is_empty() {
        // Fast path: encode rows straight from the model.
        let big = format == Format::BinaryBigEndian;
        let k = g.rest_per_channel();
        let nv = defs[0].properties.len();
        let mut buf: Vec<u8> = Vec::with_capacity(nv * 4 * 4096);
        let mut row = vec![0f32; nv];
        for i in 0..n {
            let mut j = 0;
            let mut put = |x: f32| {
                row[j] = x;
                j += 1;
            };
            g.means[i].iter().for_each(|&x| put(x));
            if let Some(nrm) = &g.normals {
                nrm[i].iter().for_each(|&x| put(x));
            }
            g.sh_dc[i].iter().for_each(|&x| put(x));
            let rest = &g.sh_rest[i * k * 3..(i + 1) * k * 3];
            for c in 0..3 {
                for kk in 0..k {
                    put(rest[kk * 3 + c]);
                }
            }
            put(g.opacity_logits[i]);
            g.log_scales[i].iter().for_each(|&x| put(x));
            g.rotations[i].iter().for_each(|&x| put(x));
            if big {
                row.iter()
                    .for_each(|x| buf.extend_from_slice(&x.to_be_bytes()));
            } else {
                buf.extend_from_slice(bytemuck::cast_slice(&row));
            }
            if buf.len() >= nv * 4 * 4096 {
                w.write_all(&buf).map_err(werr)?;
                buf.clear();
            }
        }
        w.write_all(&buf).map_err(werr)?;
    } else {
        write_element(w, &gaussian_element(g), format)?;
    }
    for e in &g.extras.elements {
        write_element(w, e, format)?;
    }
    Ok(())
}

/// The vertex element of `g` as columns (file order, extras appended).
pub fn gaussian_element(g: &Gaussians) -> Element {
    let n = g.len();
    let k = g.rest_per_channel();
    let mut e = Element::new("vertex", n);
    let col = |f: &dyn Fn(usize) -> f32| Column::Scalar(ScalarData::F32((0..n).map(f).collect()));
    for c in 0..3 {
        e.push(["x", "y", "z"][c], col(&|i| g.means[i][c]));
    }
    if let Some(nrm) = &g.normals {
        for c in 0..3 {
            e.push(["nx", "ny", "nz"][c], col(&|i| nrm[i][c]));
        }
    }
    for c in 0..3 {
        e.push(format!("f_dc_{c}"), col(&|i| g.sh_dc[i][c]));
    }
    for c in 0..3 {
        for kk in 0..k {
            e.push(
                format!("f_rest_{}", c * k + kk),
                col(&|i| g.sh_rest[(i * k + kk) * 3 + c]),
            );
        }
    }
    e.push("opacity", col(&|i| g.opacity_logits[i]));
    for c in 0..3 {
        e.push(format!("scale_{c}"), col(&|i| g.log_scales[i][c]));
    }
    for c in 0..4 {
        e.push(format!("rot_{c}"), col(&|i| g.rotations[i][c]));
    }
    e.properties.extend(g.extras.item.iter().cloned());
    e
}
