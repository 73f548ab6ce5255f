//! The 2DGS PLY ↔ [`Surfels`].
//!
//! 2DGS (`hbb1/2d-gaussian-splatting`, `GaussianModel.save_ply`) writes one
//! `vertex` element, all `float`, binary little-endian, in this order:
//! `x y z nx ny nz f_dc_0..2 f_rest_0..M-1 opacity scale_0 scale_1 rot_0..3`
//! (normals are zeros; `f_rest` channel-major, `f_rest_{c·K+k}`,
//! M = 3·((D+1)²−1) gives the SH degree D). It is the 3DGS layout with two
//! scales instead of three, and that is how it is told apart
//! ([`crate::io::detect::PlyKind::of`]: `scale_0`, `scale_1` and no
//! `scale_2`). The writer keeps that order, then any extra vertex
//! properties the model carried, then any other elements.
//!
//! Reading is by property name, in any order and any numeric type (converted
//! to f32). Missing normals and missing `f_rest` (degree 0) are accepted.

use std::io::Write;

use super::common::{f32_col, push_xyz, sh_degree_from_rest, take_f32, take_xyz};
use super::header::Header;
use super::{Format, Ply, PlyReader, write_ply};
use crate::model::{Element, Extras, Surfels};
use crate::{Error, Result};

/// The properties a 2DGS vertex element must have (besides `f_rest_*` and
/// the optional normals).
const REQUIRED: [&str; 13] = [
    "x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "rot_0", "rot_1",
    "rot_2", "rot_3",
];

/// Checks, from the header alone, that a PLY has the 2DGS vertex layout;
/// the error says which properties are missing.
pub fn check_layout(name: &str, bytes: &[u8]) -> Result<()> {
    let header = Header::parse(name, bytes)?;
    let v = header
        .element("vertex")
        .ok_or_else(|| Error::format(name, "no 'vertex' element: not a 2DGS surfel PLY"))?;
    let missing: Vec<&str> = REQUIRED
        .iter()
        .copied()
        .filter(|n| v.index_of(n).is_none())
        .collect();
    if !missing.is_empty() {
        return Err(Error::format(
            name,
            format!(
                "element 'vertex' is not a 2DGS surfel layout: missing properties {}",
                missing.join(", ")
            ),
        ));
    }
    if v.index_of("scale_2").is_some() {
        return Err(Error::format(
            name,
            "element 'vertex' has scale_2: a 3DGS Gaussian layout, not 2DGS surfels",
        ));
    }
    Ok(())
}

/// Takes scalar `names` out of `v` as f32 columns; an error names the
/// property that is missing or a list.
fn take_cols(name: &str, v: &mut Element, names: &[String]) -> Result<Vec<Vec<f32>>> {
    names
        .iter()
        .map(|n| {
            take_f32(v, n).ok_or_else(|| {
                Error::format(
                    name,
                    format!(
                        "element 'vertex': property '{n}' is missing or a list, expected a scalar"
                    ),
                )
            })
        })
        .collect()
}

/// Parses a 2DGS PLY from bytes; `name` is used in errors.
pub fn parse_surfels(name: &str, bytes: &[u8]) -> Result<Surfels> {
    check_layout(name, bytes)?;
    let (mut ply, _) = PlyReader::new(name, bytes)?.read()?;
    let mut v = ply
        .take_element("vertex")
        .ok_or_else(|| Error::format(name, "no 'vertex' element"))?;
    let n = v.count;
    let sh_degree =
        sh_degree_from_rest(name, "vertex", v.properties.iter().map(|p| p.name.as_str()))?;
    let means = take_xyz(name, &mut v, ["x", "y", "z"])?
        .ok_or_else(|| Error::format(name, "element 'vertex' has no x, y, z"))?;
    let normals = take_xyz(name, &mut v, ["nx", "ny", "nz"])?;
    let s = |p: &str, r: std::ops::Range<usize>| -> Vec<String> {
        r.map(|i| format!("{p}{i}")).collect()
    };
    let dc = take_cols(name, &mut v, &s("f_dc_", 0..3))?;
    let k = (sh_degree + 1) * (sh_degree + 1) - 1;
    let rest = take_cols(name, &mut v, &s("f_rest_", 0..3 * k))?;
    let opacity = take_cols(name, &mut v, &["opacity".to_string()])?.remove(0);
    let scale = take_cols(name, &mut v, &s("scale_", 0..2))?;
    let rot = take_cols(name, &mut v, &s("rot_", 0..4))?;
    // channel-major columns (file) to coefficient-major rows (memory)
    let mut sh_rest = vec![0f32; n * 3 * k];
    for c in 0..3 {
        for kk in 0..k {
            for (i, &x) in rest[c * k + kk].iter().enumerate() {
                sh_rest[(i * k + kk) * 3 + c] = x;
            }
        }
    }
    let surfels = Surfels {
        means,
        normals,
        sh_degree,
        sh_dc: (0..n).map(|i| [dc[0][i], dc[1][i], dc[2][i]]).collect(),
        sh_rest,
        opacity_logits: opacity,
        log_scales: (0..n).map(|i| [scale[0][i], scale[1][i]]).collect(),
        rotations: (0..n)
            .map(|i| [rot[0][i], rot[1][i], rot[2][i], rot[3][i]])
            .collect(),
        extras: Extras {
            item: v.properties,
            vertex: Vec::new(),
            elements: ply.elements,
            comments: ply.comments,
            obj_info: ply.obj_info,
        },
    };
    surfels.validate().map_err(|e| e.in_file(name))?;
    Ok(surfels)
}

/// Refuses surfels that hold a NaN or infinite value in anything a renderer
/// reads: means, SH (DC and rest), opacity, scales and rotations. Normals
/// (2DGS writes zeros; nothing reads them) and extra properties are not
/// checked. The error names `name`, the surfel (0-based) and the PLY
/// property, e.g. `surfel 3 has scale_1 = NaN, not a finite number`.
pub fn check_finite(name: &str, s: &Surfels) -> Result<()> {
    let k = s.rest_per_channel();
    let k3 = 3 * k;
    type Named<'a> = (&'a [f32], usize, &'a dyn Fn(usize) -> String);
    let arrays: [Named; 6] = [
        (s.means.as_flattened(), 3, &|j| {
            ["x", "y", "z"][j].to_string()
        }),
        (s.sh_dc.as_flattened(), 3, &|j| format!("f_dc_{j}")),
        // in memory (k, c) coefficient-major, in the file f_rest_{c·K+k}
        (&s.sh_rest, k3.max(1), &|j| {
            format!("f_rest_{}", (j % 3) * k + j / 3)
        }),
        (&s.opacity_logits, 1, &|_| "opacity".to_string()),
        (s.log_scales.as_flattened(), 2, &|j| format!("scale_{j}")),
        (s.rotations.as_flattened(), 4, &|j| format!("rot_{j}")),
    ];
    for (values, width, prop) in arrays {
        if let Some(t) = super::first_non_finite(values) {
            return Err(Error::format(
                name,
                format!(
                    "surfel {} has {} = {}, not a finite number",
                    t / width,
                    prop(t % width),
                    values[t]
                ),
            ));
        }
    }
    Ok(())
}

/// The PLY structure of `s`: 2DGS's vertex element (file order, extras
/// appended), then the other elements it carried.
pub fn surfels_to_ply(s: &Surfels, format: Format) -> Result<Ply> {
    s.validate()
        .map_err(|m| Error::invalid(format!("cannot write surfels: {m}")))?;
    let n = s.len();
    let k = s.rest_per_channel();
    let mut e = Element::new("vertex", n);
    push_xyz(&mut e, ["x", "y", "z"], &s.means);
    if let Some(nrm) = &s.normals {
        push_xyz(&mut e, ["nx", "ny", "nz"], nrm);
    }
    for c in 0..3 {
        e.push(format!("f_dc_{c}"), f32_col(s.sh_dc.iter().map(|d| d[c])));
    }
    for c in 0..3 {
        for kk in 0..k {
            e.push(
                format!("f_rest_{}", c * k + kk),
                f32_col((0..n).map(|i| s.sh_rest[(i * k + kk) * 3 + c])),
            );
        }
    }
    e.push("opacity", f32_col(s.opacity_logits.iter().copied()));
    for c in 0..2 {
        e.push(
            format!("scale_{c}"),
            f32_col(s.log_scales.iter().map(|v| v[c])),
        );
    }
    for c in 0..4 {
        e.push(
            format!("rot_{c}"),
            f32_col(s.rotations.iter().map(|v| v[c])),
        );
    }
    e.properties.extend(s.extras.item.iter().cloned());
    let mut elements = vec![e];
    elements.extend(s.extras.elements.iter().cloned());
    Ok(Ply {
        format,
        comments: s.extras.comments.clone(),
        obj_info: s.extras.obj_info.clone(),
        elements,
    })
}

/// Writes `s` as a 2DGS PLY in `format` (binary little-endian is what 2DGS
/// writes and reads).
pub fn write_surfels(w: &mut dyn Write, s: &Surfels, format: Format) -> Result<()> {
    write_ply(w, &surfels_to_ply(s, format)?, format)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Column, Property, ScalarData};

    fn sample(degree: usize, normals: bool) -> Surfels {
        let n = 3;
        let k = (degree + 1) * (degree + 1) - 1;
        Surfels {
            means: (0..n).map(|i| [i as f32, 1.0, -2.5]).collect(),
            normals: normals.then(|| vec![[0.0; 3]; n]),
            sh_degree: degree,
            sh_dc: (0..n).map(|i| [0.1 * i as f32, 0.2, 0.3]).collect(),
            sh_rest: (0..n * k * 3).map(|v| v as f32 * 0.01).collect(),
            opacity_logits: vec![-1.0, 0.0, 2.0],
            log_scales: (0..n).map(|i| [-3.0 - i as f32, -4.0]).collect(),
            rotations: (0..n).map(|i| [1.0, 0.1 * i as f32, 0.0, 0.5]).collect(),
            extras: Extras::default(),
        }
    }

    #[test]
    fn round_trips_in_every_encoding_with_extras() {
        for degree in 0..=3 {
            for fmt in [
                Format::Ascii,
                Format::BinaryLittleEndian,
                Format::BinaryBigEndian,
            ] {
                let mut s = sample(degree, degree % 2 == 0);
                s.extras.item.push(Property {
                    name: "label".into(),
                    data: Column::Scalar(ScalarData::U8(vec![1, 2, 3])),
                });
                s.extras.comments.push("made by a test".into());
                let mut buf = Vec::new();
                write_surfels(&mut buf, &s, fmt).unwrap();
                let back = parse_surfels("t.ply", &buf).unwrap();
                assert_eq!(back, s, "degree {degree} {fmt:?}");
            }
        }
    }

    #[test]
    fn file_order_is_2dgs_order() {
        let mut buf = Vec::new();
        write_surfels(&mut buf, &sample(1, true), Format::BinaryLittleEndian).unwrap();
        let h = Header::parse("t", &buf).unwrap();
        let names: Vec<&str> = h.elements[0]
            .properties
            .iter()
            .map(|p| p.name.as_str())
            .collect();
        let mut want = vec![
            "x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2",
        ];
        let rest: Vec<String> = (0..9).map(|i| format!("f_rest_{i}")).collect();
        want.extend(rest.iter().map(|s| s.as_str()));
        want.extend([
            "opacity", "scale_0", "scale_1", "rot_0", "rot_1", "rot_2", "rot_3",
        ]);
        assert_eq!(names, want);
        // channel-major in the file: f_rest_{c·K+k}; memory (k, c)
        let s = sample(1, true);
        let ply = super::super::parse_ply("t", &buf).unwrap();
        let v = ply.element("vertex").unwrap();
        let Some(Column::Scalar(d)) = v.property("f_rest_4") else {
            panic!()
        };
        // c = 1, k = 1 for surfel 2
        assert_eq!(d.to_f32()[2], s.sh_rest[(2 * 3 + 1) * 3 + 1]);
    }

    #[test]
    fn missing_and_non_finite_values_are_named() {
        let mut buf = Vec::new();
        write_surfels(&mut buf, &sample(0, false), Format::Ascii).unwrap();
        let text = String::from_utf8(buf).unwrap();
        let bad = text.replace("property float rot_3\n", "");
        let e = parse_surfels("m.ply", bad.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("m.ply"), "{e}");
        assert!(e.contains("missing properties rot_3"), "{e}");
        let mut s = sample(1, false);
        s.log_scales[2][1] = f32::NAN;
        let e = check_finite("m.ply", &s).unwrap_err().to_string();
        assert!(e.contains("surfel 2 has scale_1 = NaN"), "{e}");
        let mut s = sample(1, false);
        s.sh_rest[(3 + 2) * 3] = f32::INFINITY; // surfel 1 (K = 3), k = 2, c = 0
        let e = check_finite("m.ply", &s).unwrap_err().to_string();
        // k = 2, c = 0 → f_rest_2 of surfel 1
        assert!(e.contains("surfel 1 has f_rest_2 = inf"), "{e}");
    }
}
