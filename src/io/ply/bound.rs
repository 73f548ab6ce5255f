//! The bound-Gaussians PLY: a standard 3DGS PLY that also carries the
//! binding, so it is self-contained (docs/formats.md, "Bound Gaussians").
//!
//! - `vertex` (first element, as graphdeco's `load_ply` and SuperSplat read
//!   it): the 3DGS properties of the materialised Gaussians (means, w-first
//!   unit quaternions, `scale_0` = ln thickness, `scale_1`/`scale_2` = the two
//!   learned in-plane log scales, opacity logit, SH), followed by the
//!   binding: `face_index` (int), `bary_0 bary_1 bary_2` (float, the table
//!   row), `complex_re complex_im` (float, the unnormalised complex rotation).
//!   No name starts with `rot`, `scale_` or `f_`: graphdeco's `load_ply`
//!   collects every property starting with `rot` and sorts them by the
//!   number after the last `_`, so `rot_re` would make it throw;
//! - `bound_vertex` (float x y z, optional uchar red green blue, and alpha
//!   when some vertex is not opaque) and
//!   `bound_face` (int vertex_0 vertex_1 vertex_2): the mesh the Gaussians
//!   are bound to, as extra elements after `vertex`. graphdeco's `load_ply`
//!   reads only `elements[0]`; the PlayCanvas engine's reader (SuperSplat)
//!   reads every element's scalar properties and skips the ones it does not
//!   use, but throws on any `property list`, hence three scalar ints;
//! - a header comment `splatkit bound-gaussians per_face N`.
//!
//! Reading checks every part against the others (counts, the table, the face
//! order, the thickness) and names the first inconsistency; before that it
//! refuses any NaN or infinite value (the 3DGS properties, the binding, the
//! bound mesh's vertices), naming the Gaussian or vertex and the property.

use super::common::{f32_col, push_rgba, push_xyz, take_rgba, take_xyz};
use crate::model::bound::{BoundGaussians, barycentrics};
use crate::model::{Column, Element, Gaussians, Mesh, Property, ScalarData};
use crate::{Error, Result};

/// Names of the binding properties on `vertex`.
pub const BINDING_PROPERTIES: [&str; 6] = [
    "face_index",
    "bary_0",
    "bary_1",
    "bary_2",
    "complex_re",
    "complex_im",
];
/// Element holding the bound mesh's vertices.
pub const MESH_VERTEX: &str = "bound_vertex";
/// Element holding the bound mesh's faces.
pub const MESH_FACE: &str = "bound_face";
/// Its three int properties (scalars, not a list: the PlayCanvas engine's
/// PLY reader that SuperSplat loads files with refuses `property list`).
pub const FACE_PROPERTIES: [&str; 3] = ["vertex_0", "vertex_1", "vertex_2"];
const COMMENT: &str = "splatkit bound-gaussians per_face";

/// True when a vertex property list carries a binding (`face_index` and
/// `complex_re`), i.e. the Gaussians are bound to a mesh.
pub fn is_bound(g: &Gaussians) -> bool {
    ["face_index", "complex_re"]
        .iter()
        .all(|n| g.extras.item.iter().any(|p| p.name == *n))
}

/// `materialized` (from `geom::binding::materialize(b)`) with the binding
/// and the mesh attached, ready for the 3DGS PLY writer.
pub fn attach(b: &BoundGaussians, mut materialized: Gaussians) -> Gaussians {
    let n = b.len();
    let prop = |name: &str, data: Column| Property {
        name: name.into(),
        data,
    };
    let bary: Vec<[f32; 3]> = (0..n).map(|i| b.bary_of(i)).collect();
    let item = &mut materialized.extras.item;
    item.retain(|p| !BINDING_PROPERTIES.contains(&p.name.as_str()));
    item.push(prop(
        "face_index",
        Column::Scalar(ScalarData::I32(
            (0..n).map(|i| b.face_of(i) as i32).collect(),
        )),
    ));
    for k in 0..3 {
        item.push(prop(
            &format!("bary_{k}"),
            f32_col(bary.iter().map(|w| w[k])),
        ));
    }
    item.push(prop("complex_re", f32_col(b.complex.iter().map(|c| c[0]))));
    item.push(prop("complex_im", f32_col(b.complex.iter().map(|c| c[1]))));
    let m = &b.mesh;
    let mut ve = Element::new(MESH_VERTEX, m.vertices.len());
    push_xyz(&mut ve, ["x", "y", "z"], &m.vertices);
    if let Some(c) = &m.vertex_colors {
        push_rgba(&mut ve, c);
    }
    let mut fe = Element::new(MESH_FACE, m.faces.len());
    for (k, name) in FACE_PROPERTIES.iter().enumerate() {
        fe.push(
            *name,
            Column::Scalar(ScalarData::I32(
                m.faces.iter().map(|f| f[k] as i32).collect(),
            )),
        );
    }
    let els = &mut materialized.extras.elements;
    els.retain(|e| e.name != MESH_VERTEX && e.name != MESH_FACE);
    els.push(ve);
    els.push(fe);
    let c = &mut materialized.extras.comments;
    c.retain(|c| !c.starts_with(COMMENT));
    c.push(format!("{COMMENT} {}", b.per_face));
    materialized
}

fn bad(name: &str, msg: impl std::fmt::Display) -> Error {
    Error::format(name, format!("bound Gaussians: {msg}"))
}

fn scalar_f64(name: &str, e: &Element, prop: &str) -> Result<Vec<f64>> {
    match e.property(prop) {
        Some(Column::Scalar(d)) => Ok(d.to_f64()),
        Some(_) => Err(bad(
            name,
            format!("{}.{prop} is a list, expected a scalar", e.name),
        )),
        None => Err(bad(
            name,
            format!("element {} has no property {prop}", e.name),
        )),
    }
}

/// The binding of a 3DGS file written by [`attach`]: the model, checked
/// for consistency. `g` keeps its standard values (means and rotations are
/// for the caller to compare with the mesh if it wishes).
pub fn detach(name: &str, g: &Gaussians) -> Result<BoundGaussians> {
    let n = g.len();
    let item = |p: &str| -> Result<Vec<f64>> {
        match g.extras.item.iter().find(|x| x.name == p) {
            Some(Property {
                data: Column::Scalar(d),
                ..
            }) => Ok(d.to_f64()),
            Some(_) => Err(bad(name, format!("vertex property {p} is a list"))),
            None => Err(bad(
                name,
                format!(
                    "vertex property {p} is missing (a bound file has {}; this looks like \
                     plain Gaussians: bind them with `bind-gaussians MESH`)",
                    BINDING_PROPERTIES.join(", ")
                ),
            )),
        }
    };
    let el = |e: &str| -> Result<&Element> {
        g.extras
            .elements
            .iter()
            .find(|x| x.name == e)
            .ok_or_else(|| bad(name, format!("element {e} (the bound mesh) is missing")))
    };
    let face_index = item("face_index")?;
    let bary: Vec<Vec<f64>> = (0..3)
        .map(|k| item(&format!("bary_{k}")))
        .collect::<Result<_>>()?;
    let (re, im) = (item("complex_re")?, item("complex_im")?);
    let ve = el(MESH_VERTEX)?;
    let fe = el(MESH_FACE)?;
    let mut ve_cols = ve.clone();
    let vertices = take_xyz(name, &mut ve_cols, ["x", "y", "z"])?
        .ok_or_else(|| bad(name, format!("element {MESH_VERTEX} has no x, y, z")))?;
    let vertex_colors = take_rgba(name, &mut ve_cols)?;
    // Finite values before any comparison: a NaN would slip through
    // `(a - b).abs() > tol` and travel into every derived mean and rotation.
    // The bound mesh first, then the binding, then the derived 3DGS values,
    // so that the first value named is the cause, not a consequence.
    if let Some(t) = super::first_non_finite(vertices.as_flattened()) {
        return Err(bad(
            name,
            format!(
                "{MESH_VERTEX} {} has a non-finite coordinate ({} = {})",
                t / 3,
                ["x", "y", "z"][t % 3],
                vertices[t / 3][t % 3]
            ),
        ));
    }
    let binding = [
        ("face_index", &face_index),
        ("bary_0", &bary[0]),
        ("bary_1", &bary[1]),
        ("bary_2", &bary[2]),
        ("complex_re", &re),
        ("complex_im", &im),
    ];
    for (prop, values) in binding {
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(bad(
                name,
                format!(
                    "Gaussian {i} has {prop} = {}, not a finite number",
                    values[i]
                ),
            ));
        }
    }
    super::gaussians::check_finite(name, g)?;
    let corners: Vec<Vec<f64>> = FACE_PROPERTIES
        .iter()
        .map(|p| scalar_f64(name, fe, p))
        .collect::<Result<_>>()?;
    let faces: Vec<[u32; 3]> = (0..fe.count)
        .map(|f| {
            let idx = [corners[0][f], corners[1][f], corners[2][f]];
            if idx
                .iter()
                .any(|&v| v < 0.0 || v >= ve.count as f64 || v.fract() != 0.0)
            {
                return Err(bad(
                    name,
                    format!(
                        "{MESH_FACE} {f} references vertex {idx:?} outside the {} of {MESH_VERTEX}",
                        ve.count
                    ),
                ));
            }
            Ok(idx.map(|v| v as u32))
        })
        .collect::<Result<_>>()?;
    let nf = faces.len();
    if nf == 0 || !n.is_multiple_of(nf) {
        return Err(bad(
            name,
            format!("{n} Gaussians for {nf} bound faces: expected faces × 1, 3, 4 or 6"),
        ));
    }
    let per_face = n / nf;
    let table = barycentrics(per_face).ok_or_else(|| {
        bad(
            name,
            format!(
                "{n} Gaussians on {nf} faces is {per_face} per face; SuGaR defines 1, 3, 4 or 6"
            ),
        )
    })?;
    for i in 0..n {
        if face_index[i] != (i / per_face) as f64 {
            return Err(bad(
                name,
                format!(
                    "Gaussian {i} has face_index {} but face-major order with {per_face} per face \
                     puts it on face {}",
                    face_index[i],
                    i / per_face
                ),
            ));
        }
        let want = table[i % per_face];
        for k in 0..3 {
            // written so that a NaN fails it too (`NaN > tol` is false)
            let d = (bary[k][i] - want[k] as f64).abs();
            if !(d.is_finite() && d <= 1e-6) {
                return Err(bad(
                    name,
                    format!(
                        "Gaussian {i} has bary_{k} = {} but the {per_face}-per-face table gives {}",
                        bary[k][i], want[k]
                    ),
                ));
            }
        }
    }
    let thickness = g.log_scales.first().map_or(1.0, |s| s[0]);
    if let Some(i) = g.log_scales.iter().position(|s| s[0] != thickness) {
        return Err(bad(
            name,
            format!(
                "scale_0 of Gaussian {i} is {} but Gaussian 0 has {thickness}: the thickness \
                 of bound Gaussians is one constant",
                g.log_scales[i][0]
            ),
        ));
    }
    let b = BoundGaussians {
        mesh: Mesh {
            vertices,
            faces,
            vertex_colors,
            ..Default::default()
        },
        per_face,
        log_thickness: thickness,
        complex: (0..n).map(|i| [re[i] as f32, im[i] as f32]).collect(),
        log_scales: g.log_scales.iter().map(|s| [s[1], s[2]]).collect(),
        opacity_logits: g.opacity_logits.clone(),
        sh_degree: g.sh_degree,
        sh_dc: g.sh_dc.clone(),
        sh_rest: g.sh_rest.clone(),
    };
    b.validate().map_err(|m| bad(name, m))?;
    Ok(b)
}
