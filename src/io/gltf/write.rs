//! The glTF writer: one mesh as a `.glb` or `.gltf` document.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use gltf_json as json;
use json::validation::{Checked, USize64};

use super::color::srgb8_to_linear;
use super::{base64_encode, pad4};
use crate::io::source::werr;
use crate::model::Mesh;
use crate::{Error, Result};

/// Which glTF container [`write_gltf`] produces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum GltfContainer {
    /// Binary `.glb`: JSON chunk + BIN chunk.
    #[default]
    Glb,
    /// JSON `.gltf` with the buffer embedded as a base64 data URI.
    Gltf,
}

/// Options of [`write_gltf`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct GltfWriteOptions {
    /// Output container.
    pub container: GltfContainer,
    /// Give the colour material `alphaMode: "BLEND"` even when every alpha
    /// is 255 (it is BLEND anyway when some alpha is below 255).
    pub blend: bool,
    /// Mark the colour material `doubleSided` (for triangle soups, whose
    /// winding is arbitrary).
    pub double_sided: bool,
}

impl GltfWriteOptions {
    /// The container suggested by a file name: `.gltf` gives JSON, anything
    /// else binary.
    pub fn for_path(path: &Path) -> Self {
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
        GltfWriteOptions {
            container: if is_json {
                GltfContainer::Gltf
            } else {
                GltfContainer::Glb
            },
            ..Default::default()
        }
    }
}

/// A copy of `mesh` with three vertices per face (vertex `3i + k` is corner
/// `k` of face `i`; positions, normals and vertex colours copied) whose vertex
/// colours are the face colours (when the mesh has face colours). Face
/// colours, texture coordinates and texture are kept; scalars and extras
/// are dropped.
pub fn face_colors_to_corners(mesh: &Mesh) -> Mesh {
    let corners = || {
        mesh.faces
            .iter()
            .flat_map(|f| f.iter().map(|&i| i as usize))
    };
    let vertices = corners().map(|i| mesh.vertices[i]).collect();
    let normals = mesh
        .normals
        .as_ref()
        .map(|n| corners().map(|i| n[i]).collect());
    let vertex_colors = match (&mesh.face_colors, &mesh.vertex_colors) {
        (Some(fc), _) => Some(fc.iter().flat_map(|&c| [c, c, c]).collect()),
        (None, Some(vc)) => Some(corners().map(|i| vc[i]).collect()),
        (None, None) => None,
    };
    let faces = (0..mesh.faces.len() as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    Mesh {
        vertices,
        faces,
        normals,
        vertex_colors,
        face_colors: mesh.face_colors.clone(),
        uvs: mesh.uvs.clone(),
        texture: mesh.texture.clone(),
        ..Default::default()
    }
}

/// Whether [`write_gltf`] un-shares the vertices of `mesh` (three per
/// face, [`face_colors_to_corners`]): it has face colours and no vertex
/// colours.
pub fn unshares_vertices(mesh: &Mesh) -> bool {
    mesh.vertex_colors.is_none() && mesh.face_colors.is_some()
}

/// Writes `mesh` as glTF 2.0 (see the module documentation).
///
/// Errors: the mesh fails [`Mesh::validate`], un-sharing would need more than
/// 2^32 vertices, the buffer would exceed the 4 GiB limit of GLB, or writing
/// fails.
pub fn write_gltf(w: &mut dyn Write, mesh: &Mesh, opts: &GltfWriteOptions) -> Result<()> {
    mesh.validate()
        .map_err(|e| Error::invalid(format!("cannot write glTF: {e}")))?;
    let unshared;
    let mesh = if unshares_vertices(mesh) {
        if mesh.faces.len() as u64 * 3 > u64::from(u32::MAX) {
            return Err(Error::invalid(
                "cannot write glTF: un-sharing vertices for face colours needs more than 2^32 vertices",
            ));
        }
        unshared = face_colors_to_corners(mesh);
        &unshared
    } else {
        mesh
    };
    let (root, bin) = build_document(mesh, opts)?;
    match opts.container {
        GltfContainer::Glb => {
            let json = root
                .to_vec()
                .map_err(|e| Error::invalid(format!("cannot serialise glTF JSON: {e}")))?;
            let total = 12 + 8 + pad4(json.len()) + 8 + pad4(bin.len());
            if total > u32::MAX as usize {
                return Err(Error::invalid(format!(
                    "cannot write GLB: {total} bytes exceed the 4 GiB limit of the format"
                )));
            }
            let glb = gltf::binary::Glb {
                header: gltf::binary::Header {
                    magic: *b"glTF",
                    version: 2,
                    length: total as u32,
                },
                json: Cow::Owned(json),
                bin: (!bin.is_empty()).then_some(Cow::Owned(bin)),
            };
            glb.to_writer(w).map_err(|e| match e {
                gltf::Error::Io(e) => werr(e),
                other => Error::invalid(format!("cannot write GLB: {other}")),
            })
        }
        GltfContainer::Gltf => {
            let mut root = root;
            if let Some(b) = root.buffers.first_mut() {
                b.uri = Some(format!("{DATA_URI_PREFIX}{}", base64_encode(&bin)));
            }
            root.to_writer_pretty(&mut *w).map_err(|e| {
                if e.is_io() {
                    werr(e.into())
                } else {
                    Error::invalid(format!("cannot serialise glTF JSON: {e}"))
                }
            })?;
            w.write_all(b"\n").map_err(werr)
        }
    }
}

const DATA_URI_PREFIX: &str = "data:application/octet-stream;base64,";

/// Builds the JSON document and the binary buffer for `mesh`.
fn build_document(mesh: &Mesh, opts: &GltfWriteOptions) -> Result<(json::Root, Vec<u8>)> {
    let mut root = json::Root {
        asset: json::Asset {
            generator: Some(format!("splatkit {}", env!("CARGO_PKG_VERSION"))),
            ..Default::default()
        },
        ..Default::default()
    };
    let mut bin: Vec<u8> = Vec::new();
    let nv = mesh.vertices.len();
    if nv == 0 {
        // No scene at all: gltf-json refuses scenes without nodes on reading.
        return Ok((root, bin));
    }
    let buffer_index = json::Index::new(0);
    // Appends a section to `bin` and a buffer view for it.
    let add_view = |root: &mut json::Root,
                    bin: &mut Vec<u8>,
                    bytes: &[u8],
                    target: json::buffer::Target|
     -> json::Index<json::buffer::View> {
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        bin.resize(pad4(bin.len()), 0);
        root.push(json::buffer::View {
            buffer: buffer_index,
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            target: Some(Checked::Valid(target)),
            extensions: None,
            extras: Default::default(),
        })
    };
    let accessor = |view, count: usize, ct, ty, normalized, min, max| json::Accessor {
        buffer_view: Some(view),
        byte_offset: None,
        count: USize64::from(count),
        component_type: Checked::Valid(json::accessor::GenericComponentType(ct)),
        extensions: None,
        extras: Default::default(),
        type_: Checked::Valid(ty),
        min,
        max,
        normalized,
        sparse: None,
    };
    use json::accessor::{ComponentType as Ct, Type as Ty};
    use json::buffer::Target;

    let mut attributes = BTreeMap::new();
    let pos_view = add_view(
        &mut root,
        &mut bin,
        bytemuck::cast_slice(&mesh.vertices),
        Target::ArrayBuffer,
    );
    let (lo, hi) = mesh.bounds().unwrap_or(([0.0; 3], [0.0; 3]));
    let pos = root.push(accessor(
        pos_view,
        nv,
        Ct::F32,
        Ty::Vec3,
        false,
        Some(json::Value::from(lo.to_vec())),
        Some(json::Value::from(hi.to_vec())),
    ));
    attributes.insert(Checked::Valid(json::mesh::Semantic::Positions), pos);
    if let Some(n) = &mesh.normals {
        let view = add_view(
            &mut root,
            &mut bin,
            bytemuck::cast_slice(n),
            Target::ArrayBuffer,
        );
        let a = root.push(accessor(view, nv, Ct::F32, Ty::Vec3, false, None, None));
        attributes.insert(Checked::Valid(json::mesh::Semantic::Normals), a);
    }
    let mut material = None;
    if let Some(c) = &mesh.vertex_colors {
        // Linear float RGBA (see the module documentation).
        let lut: [f32; 256] = std::array::from_fn(|k| srgb8_to_linear(k as u8));
        let linear: Vec<[f32; 4]> = c
            .iter()
            .map(|c| {
                [
                    lut[c[0] as usize],
                    lut[c[1] as usize],
                    lut[c[2] as usize],
                    f32::from(c[3]) / 255.0,
                ]
            })
            .collect();
        let view = add_view(
            &mut root,
            &mut bin,
            bytemuck::cast_slice(&linear),
            Target::ArrayBuffer,
        );
        let a = root.push(accessor(view, nv, Ct::F32, Ty::Vec4, false, None, None));
        attributes.insert(Checked::Valid(json::mesh::Semantic::Colors(0)), a);
        let blend = opts.blend || c.iter().any(|c| c[3] < 255);
        material = Some(root.push(color_material(blend, opts.double_sided)));
    }
    let (indices, mode) = if mesh.faces.is_empty() {
        (None, json::mesh::Mode::Points)
    } else {
        let view = add_view(
            &mut root,
            &mut bin,
            bytemuck::cast_slice(&mesh.faces),
            Target::ElementArrayBuffer,
        );
        let a = root.push(accessor(
            view,
            mesh.faces.len() * 3,
            Ct::U32,
            Ty::Scalar,
            false,
            None,
            None,
        ));
        (Some(a), json::mesh::Mode::Triangles)
    };
    root.push(json::Buffer {
        byte_length: USize64::from(bin.len()),
        uri: None,
        extensions: None,
        extras: Default::default(),
    });
    let m = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        primitives: vec![json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices,
            material,
            mode: Checked::Valid(mode),
            targets: None,
        }],
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(m),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        nodes: vec![node],
    });
    root.scene = Some(scene);
    Ok((root, bin))
}

/// The material of a coloured mesh: the colour is `COLOR_0` alone
/// (`baseColorFactor` 1, no texture), dielectric and fully rough
/// (`metallicFactor` 0, `roughnessFactor` 1, so PBR viewers show the
/// colour rather than a dark metal), `alphaMode` BLEND when `blend` (the
/// alpha of `COLOR_0` then sets the coverage) and OPAQUE otherwise.
fn color_material(blend: bool, double_sided: bool) -> json::Material {
    use json::material::{AlphaMode, PbrBaseColorFactor, PbrMetallicRoughness, StrengthFactor};
    json::Material {
        alpha_mode: Checked::Valid(if blend {
            AlphaMode::Blend
        } else {
            AlphaMode::Opaque
        }),
        double_sided,
        pbr_metallic_roughness: PbrMetallicRoughness {
            base_color_factor: PbrBaseColorFactor([1.0; 4]),
            metallic_factor: StrengthFactor(0.0),
            roughness_factor: StrengthFactor(1.0),
            ..Default::default()
        },
        ..Default::default()
    }
}
