//! What a file is, for `info` and the demo's summary: format, kind of scene,
//! a PLY's elements and properties as declared, counts, bounding box, SH
//! degree, camera count. Scene files are opened through [`crate::io::any`].

use std::path::Path;

use serde::Serialize;

use crate::io::any;
use crate::io::cameras;
use crate::io::detect::{FileFormat, PlyKind};
use crate::io::materials::{MaterialInfo, TextureFile};
use crate::io::ply::PlyReader;
use crate::io::ply::header::PropertyKind;
use crate::io::source::shown;
use crate::io::{gltf, obj};
use crate::model::mesh::bounds;
use crate::model::{Column, Mesh, Scene, TriangleSoup};
use crate::{Error, Result};

/// A property as `info` reports it.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PropertyInfo {
    pub name: String,
    /// PLY type: `float`, `uchar`, … or `list uchar int`.
    #[serde(rename = "type")]
    pub ty: String,
}

/// A PLY element as `info` reports it.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ElementInfo {
    pub name: String,
    pub count: u64,
    pub properties: Vec<PropertyInfo>,
}

/// The binding of bound Gaussians, as `info` reports it.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct BindingInfo {
    /// Vertices of the bound mesh.
    pub mesh_vertices: u64,
    /// Faces of the bound mesh.
    pub mesh_faces: u64,
    /// Gaussians per face (face-major order).
    pub per_face: u64,
}

/// Everything `info` says about one file.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct FileInfo {
    pub path: String,
    /// File format (`ply`, `obj`, `off`, `glb`, `gltf`, `pt`, `npz`, `json`, `colmap`, …).
    pub format: String,
    /// What the file holds: `gaussians`, `surfels` (2DGS), `triangle-soup`, `mesh`,
    /// `point-cloud`, `cameras`, …
    pub kind: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub encoding: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vertices: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub faces: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gaussians: Option<usize>,
    /// 2DGS surfels (a `surfels` PLY).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surfels: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub triangles: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sh_degree: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub active_sh_degree: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cameras: Option<usize>,
    /// Distinct image sizes of the cameras, `WxH`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub image_sizes: Vec<String>,
    /// Camera models present (`pinhole`, or the distorted model's name).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub camera_models: Vec<String>,
    /// Axis-aligned bounds of the finite positions (camera centres for cameras).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bbox: Option<[[f32; 3]; 2]>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub elements: Vec<ElementInfo>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub comments: Vec<String>,
    /// Bytes after the data the header declares (ignored by readers).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trailing_bytes: Option<usize>,
    /// For Gaussians bound to a mesh (`bind-gaussians`): the binding.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub binding: Option<BindingInfo>,
    /// Present attributes: `normals`, `vertex-colors`, `face-colors`,
    /// `uvs` (texture coordinates), a mesh's named scalars, …
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub attributes: Vec<String>,
    /// OBJ: the `mtllib` files (resolved path, or `NAME (not found)`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub material_libraries: Vec<String>,
    /// OBJ and glTF: the materials, with their texture maps (and glTF
    /// `alphaMode`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<MaterialInfo>,
    /// OBJ and glTF: the texture image files the materials name, and
    /// whether each exists.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub textures: Vec<TextureFile>,
}

fn mesh_info(info: &mut FileInfo, m: &Mesh) {
    info.kind = "mesh".into();
    info.vertices = Some(m.vertices.len());
    info.faces = Some(m.faces.len());
    info.bbox = bounds(&m.vertices).map(|(a, b)| [a, b]);
    for (present, name) in [
        (m.normals.is_some(), "normals"),
        (m.vertex_colors.is_some(), "vertex-colors"),
        (m.face_colors.is_some(), "face-colors"),
        (m.uvs.is_some(), "uvs"),
    ] {
        if present {
            info.attributes.push(name.into());
        }
    }
    info.attributes
        .extend(m.vertex_scalars.iter().map(|(n, _)| n.clone()));
}

/// Describes one file or camera folder (`-` = stdin). Scene files go
/// through [`any::open`] (one format detection and kind decision for every
/// command); a PLY's elements and properties are listed as declared.
pub fn describe(path: &Path) -> Result<FileInfo> {
    let mut info = FileInfo {
        path: shown(path, false),
        ..Default::default()
    };
    if path.is_dir()
        || path
            .extension()
            .is_some_and(|e| e == "npz" || e == "json" || e == "bin" || e == "txt")
    {
        return describe_cameras(path, info);
    }
    let opened = any::open(path)?;
    info.format = opened.format.name().into();
    match opened.format {
        FileFormat::Npz | FileFormat::Json => return describe_cameras(path, info),
        FileFormat::Ply => describe_ply(&opened, &mut info)?,
        FileFormat::Obj => {
            let (mesh, inv) = obj::parse_obj_inventory(opened.name(), &opened.input, &opened.base)?;
            mesh_info(&mut info, &mesh);
            info.material_libraries = inv
                .mtllibs
                .iter()
                .map(|(lib, found)| match found {
                    Some(p) => p.display().to_string(),
                    None => format!("{lib} (not found)"),
                })
                .collect();
            info.materials = inv.materials;
            info.textures = inv.textures;
        }
        FileFormat::Glb | FileFormat::Gltf => {
            let Scene::Mesh(mesh) = opened.decode()? else {
                unreachable!("a glTF file decodes to a mesh")
            };
            mesh_info(&mut info, &mesh);
            let base = (!opened.input.is_stdin()).then_some(opened.base.as_path());
            let inv = gltf::inventory(opened.name(), &opened.input, base)?;
            if inv.attributes.iter().any(|a| a.starts_with("TEXCOORD_")) {
                info.attributes.push("uvs".into());
            }
            info.materials = inv.materials;
            info.textures = inv.textures;
        }
        _ => match opened.decode()? {
            Scene::Mesh(m) => mesh_info(&mut info, &m),
            Scene::TriangleSoup(s) => soup_info(&mut info, &s),
            Scene::Gaussians(g) => gaussians_info(&mut info, &g),
            other => {
                return Err(Error::format(
                    opened.name(),
                    format!(
                        "unexpected {} in a {} file",
                        other.kind().name(),
                        opened.format.name()
                    ),
                ));
            }
        },
    }
    Ok(info)
}

fn gaussians_info(info: &mut FileInfo, g: &crate::model::Gaussians) {
    info.kind = "gaussians".into();
    info.gaussians = Some(g.len());
    info.sh_degree = Some(g.sh_degree);
    info.bbox = bounds(&g.means).map(|(a, b)| [a, b]);
}

fn soup_info(info: &mut FileInfo, s: &TriangleSoup) {
    info.kind = "triangle-soup".into();
    info.triangles = Some(s.len());
    info.sh_degree = Some(s.sh_degree);
    info.active_sh_degree = Some(s.active_sh_degree);
    let corners: Vec<[f32; 3]> = s.triangles.iter().flatten().copied().collect();
    info.bbox = bounds(&corners).map(|(a, b)| [a, b]);
}

fn describe_cameras(path: &Path, mut info: FileInfo) -> Result<FileInfo> {
    let cams = cameras::read_cameras(path)?;
    info.format = cameras::detect_camera_format(path)
        .map(|f| f.name().to_string())
        .unwrap_or_else(|| "cameras".into());
    info.kind = "cameras".into();
    info.cameras = Some(cams.len());
    let mut sizes: Vec<String> = cams
        .iter()
        .map(|c| format!("{}x{}", c.width, c.height))
        .collect();
    sizes.sort();
    sizes.dedup();
    info.image_sizes = sizes;
    let mut models: Vec<String> = cams
        .iter()
        .map(|c| match &c.model {
            crate::model::CameraModel::Pinhole => "pinhole".to_string(),
            crate::model::CameraModel::Distorted { name, .. } => name.clone(),
        })
        .collect();
    models.sort();
    models.dedup();
    info.camera_models = models;
    let centres: Vec<[f32; 3]> = cams
        .iter()
        .map(|c| c.center().to_array().map(|v| v as f32))
        .collect();
    info.bbox = bounds(&centres).map(|(a, b)| [a, b]);
    Ok(info)
}

fn describe_ply(opened: &any::Opened, info: &mut FileInfo) -> Result<()> {
    let (name, bytes) = (opened.name(), &opened.input[..]);
    let reader = PlyReader::new(name, bytes)?;
    let h = &reader.header;
    let kind = opened.ply_kind.unwrap_or(PlyKind::Other);
    info.kind = kind.name().into();
    info.encoding = Some(h.format.name().into());
    info.comments = h.comments.clone();
    info.elements = h
        .elements
        .iter()
        .map(|e| ElementInfo {
            name: e.name.clone(),
            count: e.count,
            properties: e
                .properties
                .iter()
                .map(|p| PropertyInfo {
                    name: p.name.clone(),
                    ty: match p.kind {
                        PropertyKind::Scalar(t) => t.name().into(),
                        PropertyKind::List { count, item } => {
                            format!("list {} {}", count.name(), item.name())
                        }
                    },
                })
                .collect(),
        })
        .collect();
    let (ply, trailing) = reader.read()?;
    info.trailing_bytes = (trailing > 0).then_some(trailing);
    let count = |n: &str| ply.element(n).map(|e| e.count);
    if let Some(v) = ply.element("vertex") {
        let col = |n: &str| match v.property(n) {
            Some(Column::Scalar(d)) => Some(d.to_f32()),
            _ => None,
        };
        if let (Some(x), Some(y), Some(z)) = (col("x"), col("y"), col("z")) {
            let pts: Vec<[f32; 3]> = (0..x.len()).map(|i| [x[i], y[i], z[i]]).collect();
            info.bbox = bounds(&pts).map(|(a, b)| [a, b]);
        }
        for (names, attr) in [
            (["nx", "ny", "nz"], "normals"),
            (["red", "green", "blue"], "vertex-colors"),
        ] {
            if names.iter().all(|n| v.property(n).is_some()) {
                info.attributes.push(attr.into());
            }
        }
    }
    match kind {
        PlyKind::Surfels => {
            info.surfels = count("vertex");
            info.sh_degree = sh_degree_of(h);
        }
        PlyKind::Gaussians => {
            info.gaussians = count("vertex");
            info.sh_degree = sh_degree_of(h);
            let bound_faces = h.element(crate::io::ply::bound::MESH_FACE);
            let bound_verts = h.element(crate::io::ply::bound::MESH_VERTEX);
            let has_binding = h.element("vertex").is_some_and(|v| {
                v.index_of("face_index").is_some() && v.index_of("complex_re").is_some()
            });
            if let (Some(f), Some(v), true) = (bound_faces, bound_verts, has_binding) {
                let g = h.element("vertex").map_or(0, |v| v.count);
                info.binding = Some(BindingInfo {
                    mesh_vertices: v.count,
                    mesh_faces: f.count,
                    per_face: g.checked_div(f.count).unwrap_or(0),
                });
            }
        }
        PlyKind::CompressedGaussians => {
            let Scene::Gaussians(g) = opened.decode()? else {
                unreachable!("a compressed PLY decodes to Gaussians")
            };
            gaussians_info(info, &g);
            info.kind = kind.name().into();
        }
        PlyKind::TriangleSoup => {
            let Scene::TriangleSoup(s) = opened.decode()? else {
                unreachable!("a soup PLY decodes to a soup")
            };
            info.triangles = Some(s.len());
            info.sh_degree = Some(s.sh_degree);
            info.active_sh_degree = Some(s.active_sh_degree);
        }
        PlyKind::Mesh => {
            info.vertices = count("vertex");
            info.faces = count("face");
            if let Some(f) = ply.element("face")
                && ["red", "green", "blue"]
                    .iter()
                    .all(|n| f.property(n).is_some())
            {
                info.attributes.push("face-colors".into());
            }
        }
        PlyKind::PointCloud => info.points = count("vertex"),
        PlyKind::Other => {}
    }
    Ok(())
}

/// The SH degree of a splat PLY's vertex element from its count of
/// `f_rest_*` properties (0, 9, 24, 45); `None` for another count.
fn sh_degree_of(h: &crate::io::ply::Header) -> Option<usize> {
    let rest = h.element("vertex").map_or(0, |v| {
        v.properties
            .iter()
            .filter(|p| p.name.starts_with("f_rest_"))
            .count()
    });
    [(0, 0), (9, 1), (24, 2), (45, 3)]
        .iter()
        .find(|(m, _)| *m == rest)
        .map(|(_, d)| *d)
}

/// Groups digits by thousands: 35947 → "35,947".
pub fn thousands(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// Human-readable text for one file.
pub fn render_text(i: &FileInfo) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "{}", i.path);
    let enc = i
        .encoding
        .as_deref()
        .map(|e| format!(" ({e})"))
        .unwrap_or_default();
    let _ = writeln!(s, "  format:     {}{enc}", i.format);
    let what = if i.kind == "surfels" {
        " (2DGS surfels)"
    } else {
        ""
    };
    let _ = writeln!(s, "  kind:       {}{what}", i.kind);
    for (label, v) in [
        ("gaussians", i.gaussians),
        ("surfels", i.surfels),
        ("triangles", i.triangles),
        ("points", i.points),
        ("vertices", i.vertices),
        ("faces", i.faces),
        ("cameras", i.cameras),
    ] {
        if let Some(v) = v {
            let _ = writeln!(s, "  {:<11} {}", format!("{label}:"), thousands(v));
        }
    }
    if let Some(b) = &i.binding {
        let _ = writeln!(
            s,
            "  bound to:   a mesh of {} vertices and {} faces, {} Gaussian(s) per face (SuGaR binding)",
            thousands(b.mesh_vertices as usize),
            thousands(b.mesh_faces as usize),
            b.per_face
        );
    }
    if let Some(d) = i.sh_degree {
        let active = i
            .active_sh_degree
            .map(|a| format!(" (active {a})"))
            .unwrap_or_default();
        let _ = writeln!(s, "  SH degree:  {d}{active}");
    }
    if !i.image_sizes.is_empty() {
        let _ = writeln!(s, "  images:     {}", i.image_sizes.join(", "));
        let _ = writeln!(s, "  models:     {}", i.camera_models.join(", "));
    }
    if let Some([lo, hi]) = i.bbox {
        let _ = writeln!(
            s,
            "  bbox:       [{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}]",
            lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
        );
    }
    if !i.attributes.is_empty() {
        let _ = writeln!(s, "  attributes: {}", i.attributes.join(", "));
    }
    for l in &i.material_libraries {
        let _ = writeln!(s, "  mtllib:     {l}");
    }
    for m in &i.materials {
        let mode = m
            .alpha_mode
            .as_deref()
            .map(|a| format!(", alphaMode {a}"))
            .unwrap_or_default();
        let defined = if m.defined {
            ""
        } else {
            ", not defined in any MTL file"
        };
        let maps: Vec<String> = m
            .textures
            .iter()
            .map(|t| format!("{} {}", t.slot, t.file))
            .collect();
        let maps = if maps.is_empty() {
            "no texture".to_string()
        } else {
            maps.join(", ")
        };
        // glTF materials (the ones with an alphaMode) are used by primitives.
        let unit = if m.alpha_mode.is_some() {
            "primitive(s)"
        } else {
            "face(s)"
        };
        let _ = writeln!(
            s,
            "  material:   {} (used by {} {unit}{mode}{defined}): {maps}",
            m.name,
            thousands(m.used_by)
        );
    }
    for t in &i.textures {
        let state = if t.exists { "" } else { " (missing)" };
        let _ = writeln!(s, "  texture:    {}{state}", t.file);
    }
    for c in &i.comments {
        let _ = writeln!(s, "  comment:    {c}");
    }
    for e in &i.elements {
        let props: Vec<String> = e
            .properties
            .iter()
            .map(|p| format!("{} {}", p.ty, p.name))
            .collect();
        let shown_props = if props.len() > 12 {
            format!("{} … ({} properties)", props[..12].join(", "), props.len())
        } else {
            props.join(", ")
        };
        let _ = writeln!(
            s,
            "  element {} {}: {shown_props}",
            e.name,
            thousands(e.count as usize)
        );
    }
    if let Some(t) = i.trailing_bytes {
        let _ = writeln!(
            s,
            "  warning:    {} bytes after the declared data (ignored)",
            thousands(t)
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thousands_groups_digits() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(35_947), "35,947");
        assert_eq!(thousands(1_234_567), "1,234,567");
    }
}
