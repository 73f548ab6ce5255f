//! Helpers shared by the PLY file contracts.

use crate::model::{Column, Element, ScalarData, ScalarType};
use crate::{Error, Result};

/// Takes scalar property `name` out of `e` as f32 (any numeric type).
pub fn take_f32(e: &mut Element, name: &str) -> Option<Vec<f32>> {
    match e.take(name)? {
        Column::Scalar(d) => Some(d.to_f32()),
        list => {
            // Put lists back: they are not ours to interpret.
            e.push(name, list);
            None
        }
    }
}

/// Takes x, y, z (all three) as points.
pub fn take_xyz(file: &str, e: &mut Element, names: [&str; 3]) -> Result<Option<Vec<[f32; 3]>>> {
    let present = names.iter().filter(|n| e.property(n).is_some()).count();
    if present == 0 {
        return Ok(None);
    }
    if present != 3 {
        return Err(Error::format(
            file,
            format!("element '{}' has only some of {}", e.name, names.join(", ")),
        ));
    }
    let cols: Vec<Vec<f32>> = names
        .iter()
        .map(|n| take_f32(e, n))
        .collect::<Option<_>>()
        .ok_or_else(|| {
            Error::format(
                file,
                format!("element '{}': {} must be scalars", e.name, names.join(", ")),
            )
        })?;
    Ok(Some(zip3(&cols[0], &cols[1], &cols[2])))
}

/// Interleaves three columns.
pub fn zip3(a: &[f32], b: &[f32], c: &[f32]) -> Vec<[f32; 3]> {
    a.iter()
        .zip(b)
        .zip(c)
        .map(|((&x, &y), &z)| [x, y, z])
        .collect()
}

/// Takes `red green blue [alpha]` as RGBA8. 8-bit integer colours are used
/// as they are; float colours are taken as 0–1 and scaled (rounded, clamped);
/// 16-bit colours are scaled down by 257.
pub fn take_rgba(file: &str, e: &mut Element) -> Result<Option<Vec<[u8; 4]>>> {
    let names = ["red", "green", "blue"];
    let present = names.iter().filter(|n| e.property(n).is_some()).count();
    if present == 0 {
        return Ok(None);
    }
    if present != 3 {
        return Err(Error::format(
            file,
            format!("element '{}' has only some of red, green, blue", e.name),
        ));
    }
    let mut chans: Vec<Vec<u8>> = Vec::with_capacity(4);
    for n in ["red", "green", "blue", "alpha"] {
        let Some(col) = e.take(n) else {
            chans.push(vec![255; e.count]);
            continue;
        };
        let Column::Scalar(d) = col else {
            return Err(Error::format(
                file,
                format!("element '{}': '{n}' is a list, expected a scalar", e.name),
            ));
        };
        chans.push(to_u8(&d));
    }
    Ok(Some(
        (0..e.count)
            .map(|i| [chans[0][i], chans[1][i], chans[2][i], chans[3][i]])
            .collect(),
    ))
}

fn to_u8(d: &ScalarData) -> Vec<u8> {
    match d {
        ScalarData::U8(v) => v.clone(),
        ScalarData::F32(_) | ScalarData::F64(_) => (0..d.len())
            .map(|i| (d.get_f64(i).clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect(),
        ScalarData::U16(v) => v.iter().map(|&x| (x / 257) as u8).collect(),
        _ => (0..d.len())
            .map(|i| d.get_f64(i).clamp(0.0, 255.0) as u8)
            .collect(),
    }
}

/// A float column.
pub fn f32_col(v: impl IntoIterator<Item = f32>) -> Column {
    Column::Scalar(ScalarData::F32(v.into_iter().collect()))
}

/// A uchar column.
pub fn u8_col(v: impl IntoIterator<Item = u8>) -> Column {
    Column::Scalar(ScalarData::U8(v.into_iter().collect()))
}

/// Pushes x/y/z-style columns of `v` under `names`.
pub fn push_xyz(e: &mut Element, names: [&str; 3], v: &[[f32; 3]]) {
    for (c, n) in names.iter().enumerate() {
        e.push(*n, f32_col(v.iter().map(|p| p[c])));
    }
}

/// Pushes red/green/blue (and alpha unless every alpha is 255).
pub fn push_rgba(e: &mut Element, v: &[[u8; 4]]) {
    for (c, n) in ["red", "green", "blue"].iter().enumerate() {
        e.push(*n, u8_col(v.iter().map(|p| p[c])));
    }
    if v.iter().any(|p| p[3] != 255) {
        e.push("alpha", u8_col(v.iter().map(|p| p[3])));
    }
}

/// A `vertex_indices` list column (uchar counts, int indices — the type pair
/// every mesh tool reads) for triangles.
pub fn triangle_list(faces: &[[u32; 3]]) -> Column {
    Column::List {
        count_type: ScalarType::U8,
        offsets: (0..=faces.len()).map(|i| 3 * i).collect(),
        values: ScalarData::I32(
            faces
                .iter()
                .flat_map(|f| f.iter().map(|&i| i as i32))
                .collect(),
        ),
    }
}

/// Reads a face list column into fan-triangulated triangles. Returns the
/// triangles and, for each triangle, the index of the polygon it came from.
pub fn triangulate(
    file: &str,
    element: &str,
    col: &Column,
    vertex_count: usize,
) -> Result<(Vec<[u32; 3]>, Vec<usize>)> {
    let Column::List {
        offsets, values, ..
    } = col
    else {
        return Err(Error::format(
            file,
            format!("element '{element}': vertex_indices must be a list"),
        ));
    };
    if values.scalar_type().is_float() {
        return Err(Error::format(
            file,
            format!("element '{element}': vertex_indices has a float type"),
        ));
    }
    let idx = values.to_f64();
    let mut tris = Vec::with_capacity(offsets.len().saturating_sub(1));
    let mut src = Vec::with_capacity(offsets.len().saturating_sub(1));
    for row in 0..offsets.len() - 1 {
        let poly = &idx[offsets[row]..offsets[row + 1]];
        for &v in poly {
            if v < 0.0 || v >= vertex_count as f64 {
                return Err(Error::format(
                    file,
                    format!(
                        "element '{element}' row {row}: vertex index {v} is out of range (there are {vertex_count} vertices)"
                    ),
                ));
            }
        }
        if poly.len() < 3 {
            // Points and edges are not surfaces; skipped (documented).
            continue;
        }
        for k in 1..poly.len() - 1 {
            tris.push([poly[0] as u32, poly[k] as u32, poly[k + 1] as u32]);
            src.push(row);
        }
    }
    Ok((tris, src))
}

/// SH degree from the `f_rest_*` property names of `element`: they must be
/// numbered 0..M without gaps, M ∈ {0, 9, 24, 45} for degree 0–3.
pub fn sh_degree_from_rest<'a>(
    file: &str,
    element: &str,
    names: impl Iterator<Item = &'a str>,
) -> Result<usize> {
    // only the canonical spelling names an SH coefficient: `f_rest_036` or
    // `f_rest_+3` parse as numbers but are not the names the readers look
    // up, so they count as other properties (found by fuzzing)
    let mut rest: Vec<usize> = names
        .filter_map(|n| n.strip_prefix("f_rest_"))
        .filter_map(|s| s.parse::<usize>().ok().filter(|r| r.to_string() == s))
        .collect();
    rest.sort_unstable();
    let m = rest.len();
    if rest.iter().enumerate().any(|(i, &r)| i != r) {
        return Err(Error::format(
            file,
            format!(
                "element '{element}': f_rest_* properties are not numbered 0..{m} without gaps"
            ),
        ));
    }
    match m {
        0 => Ok(0),
        9 => Ok(1),
        24 => Ok(2),
        45 => Ok(3),
        _ => Err(Error::format(
            file,
            format!(
                "element '{element}': {m} f_rest_* properties do not match an SH degree (expected 0, 9, 24 or 45)"
            ),
        )),
    }
}
