//! glTF 2.0 meshes, as binary `.glb` or JSON `.gltf` (geometry only:
//! positions, normals, vertex colours, triangles; materials, textures,
//! skins, morph targets and animations are ignored).
//!
//! # Writing
//! One scene, one node without transform, one mesh with one primitive:
//! `POSITION` (f32 VEC3, with the `min`/`max` the specification requires,
//! computed over finite coordinates), `NORMAL` (f32 VEC3) when the mesh has
//! normals, `COLOR_0` (normalised u8 VEC4, RGBA) when it has colours, and u32
//! indices in mode TRIANGLES. Every section of the binary buffer is 4-byte
//! aligned. `.glb` puts the buffer in the BIN chunk; `.gltf` embeds it as a
//! base64 `data:application/octet-stream;base64,…` URI.
//!
//! glTF has no per-face colours: when the mesh has face colours and no vertex
//! colours, vertices are un-shared (three per face, see
//! [`face_colors_to_corners`]) and each face's colour is copied to its three
//! corners. Vertex colours win when both exist. A mesh with vertices but no
//! faces is written as a POINTS primitive without indices; an empty mesh as a
//! document without scene or mesh. Non-finite coordinates are stored as they are in the
//! binary buffer (`min`/`max` ignore them); other tools may reject them.
//!
//! # Reading
//! Buffers come from the GLB BIN chunk, from base64 `data:` URIs, or (with
//! [`read_gltf`] only) from files relative to the `.gltf` file. Meshes are
//! instantiated through the scene graph: the default scene, else the first
//! scene, else every root node. Each node's world transform (parent × local,
//! `matrix` or translation × rotation × scale, computed in f64) is applied
//! to positions, and its inverse transpose to normals (renormalised); a
//! transform with negative determinant also swaps two indices of every
//! triangle so that the winding stays counter-clockwise. A mesh used by two
//! nodes appears twice. When no node references a mesh, every mesh is read
//! once, untransformed.
//!
//! All primitives are merged into one mesh. Modes TRIANGLES, TRIANGLE_STRIP
//! and TRIANGLE_FAN give triangles; POINTS gives vertices only; line modes are
//! skipped. `POSITION` and `NORMAL` must be f32; `COLOR_0` may be f32, or
//! normalised u8/u16, VEC3 (alpha 255) or VEC4; indices u8, u16 or u32. A
//! primitive lacking normals or colours that others have gets (0, 0, 0) /
//! opaque white. Sparse accessors are refused. Errors name the file and the
//! byte offset (container) or the mesh / primitive / accessor (content).
//!
//! # Crates and hand-written parts
//! Base64 in data URIs is the `base64` crate's: the standard alphabet with
//! padding on writing; on reading also the URL-safe alphabet, missing padding
//! and non-zero trailing bits. It replaced hand-written code that was slower
//! on a 50 MB buffer (a 1M-vertex mesh with normals and colours and 2M faces;
//! 2-vCPU machine, release build): encoding 104 ms instead of 238 ms,
//! decoding 92 ms instead of 609 ms.
//!
//! The GLB container is written by `gltf::binary::Glb::to_writer`, but split
//! on reading by our own `split_glb` (~70 lines), not `Glb::from_slice`
//! (gltf 1.4.1). Speed decides nothing (both only slice: under 0.1 µs on that
//! 50 MB file); `from_slice`
//! - panics ("attempt to subtract with overflow") on a header that declares a
//!   length below 12, in builds with overflow checks such as our debug and test
//!   builds;
//! - refuses a chunk of unknown type after the JSON chunk ("unknown chunk
//!   type"), which the glTF 2.0 specification says readers must ignore;
//! - names neither the file nor the byte offset ("could not completely read
//!   the object", "failed to fill whole buffer"), which the `malformed_glb`
//!   test requires.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use gltf_json as json;
use json::validation::{Checked, USize64};

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
        }
    }
}

/// A copy of `mesh` with three vertices per face (vertex `3i + k` is corner
/// `k` of face `i`; positions, normals and vertex colours copied) whose vertex
/// colours are the face colours (when the mesh has face colours). Face
/// colours are kept; scalars and extras are dropped.
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
        ..Default::default()
    }
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
    let mesh = if mesh.vertex_colors.is_none() && mesh.face_colors.is_some() {
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
    let (root, bin) = build_document(mesh)?;
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

fn pad4(n: usize) -> usize {
    n.div_ceil(4) * 4
}

/// Builds the JSON document and the binary buffer for `mesh`.
fn build_document(mesh: &Mesh) -> Result<(json::Root, Vec<u8>)> {
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
    if let Some(c) = &mesh.vertex_colors {
        let view = add_view(
            &mut root,
            &mut bin,
            bytemuck::cast_slice(c),
            Target::ArrayBuffer,
        );
        let a = root.push(accessor(view, nv, Ct::U8, Ty::Vec4, true, None, None));
        attributes.insert(Checked::Valid(json::mesh::Semantic::Colors(0)), a);
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
            material: None,
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

/// Reads a `.glb` or `.gltf` file (`-` = stdin); external buffer files are
/// resolved relative to the file's folder (the current folder for stdin).
pub fn read_gltf(path: &Path) -> Result<Mesh> {
    let input = crate::io::read_input(path)?;
    let base = if input.is_stdin() {
        Path::new(".")
    } else {
        match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        }
    };
    parse_gltf_impl(&input.name, &input, Some(base))
}

/// Parses the bytes of a `.glb` or `.gltf` file; `name` is used in error
/// messages. Buffers must be in the GLB BIN chunk or in data URIs (there is
/// no folder to resolve external files against; use [`read_gltf`] for those).
pub fn parse_gltf(name: &str, bytes: &[u8]) -> Result<Mesh> {
    parse_gltf_impl(name, bytes, None)
}

const GLB_JSON: u32 = 0x4E4F_534A;
const GLB_BIN: u32 = 0x004E_4942;

/// Splits a GLB container into its JSON and (optional) BIN chunks, checking
/// every length against the bytes present.
fn split_glb<'a>(name: &str, bytes: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>)> {
    let err = |off: usize, msg: String| Error::format(name, format!("byte offset {off}: {msg}"));
    let u32_at = |off: usize| -> Result<u32> {
        bytes
            .get(off..off + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .ok_or_else(|| {
                err(
                    off,
                    format!(
                        "GLB truncated: expected 4 more bytes, the file has {}",
                        bytes.len()
                    ),
                )
            })
    };
    let version = u32_at(4)?;
    if version != 2 {
        return Err(err(4, format!("GLB version {version}, expected 2")));
    }
    let length = u32_at(8)? as usize;
    if length > bytes.len() {
        return Err(err(
            8,
            format!(
                "GLB header declares {length} bytes but the file has {}",
                bytes.len()
            ),
        ));
    }
    let bytes = &bytes[..length];
    let mut off = 12;
    let mut json = None;
    let mut bin = None;
    while off < bytes.len() {
        let len = u32_at(off)? as usize;
        let ty = u32_at(off + 4)?;
        let start = off + 8;
        if len > bytes.len() - start {
            return Err(err(
                off,
                format!(
                    "GLB chunk length {len} runs past the end of the data ({} bytes left)",
                    bytes.len() - start
                ),
            ));
        }
        let data = &bytes[start..start + len];
        match ty {
            GLB_JSON if json.is_none() && off == 12 => json = Some(data),
            GLB_JSON => return Err(err(off, "unexpected second JSON chunk".into())),
            GLB_BIN if json.is_some() && bin.is_none() => bin = Some(data),
            GLB_BIN => {
                return Err(err(
                    off,
                    "BIN chunk must come once, right after the JSON chunk".into(),
                ));
            }
            _ if json.is_none() => {
                return Err(err(
                    off,
                    format!("first GLB chunk has type {ty:#010x}, expected JSON"),
                ));
            }
            // Unknown chunk types after the JSON chunk are to be ignored.
            _ => {}
        }
        off = start + pad4(len).min(bytes.len() - start);
    }
    let json = json.ok_or_else(|| err(12, "GLB has no JSON chunk".into()))?;
    Ok((json, bin))
}

fn parse_gltf_impl(name: &str, bytes: &[u8], base: Option<&Path>) -> Result<Mesh> {
    let (json_bytes, blob) = if bytes.starts_with(b"glTF") {
        split_glb(name, bytes)?
    } else {
        (bytes, None)
    };
    let root = json::Root::from_slice(json_bytes)
        .map_err(|e| Error::format(name, format!("invalid glTF JSON: {e}")))?;
    // gltf-json's own validation indexes the POSITION accessor without a
    // bounds check (it panics on a bad index), so check that one first.
    for (mi, m) in root.meshes.iter().enumerate() {
        for (pi, p) in m.primitives.iter().enumerate() {
            for (sem, idx) in &p.attributes {
                if idx.value() >= root.accessors.len() {
                    return Err(Error::format(
                        name,
                        format!(
                            "mesh {mi} primitive {pi} attribute {sem:?}: accessor {} does not exist ({} accessors)",
                            idx.value(),
                            root.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    let doc = gltf::Document::from_json(root)
        .map_err(|e| Error::format(name, format!("invalid glTF: {e}")))?;
    let buffers = load_buffers(name, &doc, blob, base)?;
    let mut out = Merge::default();
    for (mesh, matrix) in mesh_instances(name, &doc)? {
        for prim in mesh.primitives() {
            let ctx = Ctx {
                name,
                mesh: mesh.index(),
                prim: prim.index(),
                buffers: &buffers,
            };
            out.add(&ctx, &prim, &matrix)?;
        }
    }
    let mesh = out.finish();
    debug_assert!(mesh.validate().is_ok());
    Ok(mesh)
}

/// Resolves every buffer to bytes.
fn load_buffers<'a>(
    name: &str,
    doc: &gltf::Document,
    blob: Option<&'a [u8]>,
    base: Option<&Path>,
) -> Result<Vec<Cow<'a, [u8]>>> {
    let mut out = Vec::new();
    for b in doc.buffers() {
        let what = format!("buffer {}", b.index());
        let data: Cow<[u8]> = match b.source() {
            gltf::buffer::Source::Bin => Cow::Borrowed(blob.ok_or_else(|| {
                Error::format(
                    name,
                    format!("{what} refers to the GLB BIN chunk, which is absent"),
                )
            })?),
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                let (_, payload) = uri.split_once(";base64,").ok_or_else(|| {
                    Error::format(name, format!("{what}: data URI is not base64-encoded"))
                })?;
                Cow::Owned(base64_decode(payload).map_err(|off| {
                    Error::format(
                        name,
                        format!(
                            "{what}: invalid base64 at character {off} of the data URI payload"
                        ),
                    )
                })?)
            }
            gltf::buffer::Source::Uri(uri) => {
                let Some(base) = base else {
                    return Err(Error::format(
                        name,
                        format!(
                            "{what}: external file '{uri}' cannot be resolved without a file path"
                        ),
                    ));
                };
                let rel = percent_decode(uri);
                let p = base.join(&rel);
                let input = crate::io::read_input(&p)?;
                Cow::Owned(input.to_vec())
            }
        };
        if data.len() < b.length() {
            return Err(Error::format(
                name,
                format!(
                    "{what} declares {} bytes but only {} are present",
                    b.length(),
                    data.len()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// The meshes to read with their world transforms.
fn mesh_instances<'a>(
    name: &str,
    doc: &'a gltf::Document,
) -> Result<Vec<(gltf::Mesh<'a>, glam::DMat4)>> {
    let roots: Vec<gltf::Node> =
        if let Some(s) = doc.default_scene().or_else(|| doc.scenes().next()) {
            s.nodes().collect()
        } else {
            let mut is_child = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            doc.nodes().filter(|n| !is_child[n.index()]).collect()
        };
    let mut out = Vec::new();
    // Depth-first, parents before children, in document order. The
    // hierarchy must be a forest (glTF 2.0 §3.5.3): a node reached twice has
    // two parents or lies on a cycle.
    let mut stack: Vec<(gltf::Node, glam::DMat4)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, glam::DMat4::IDENTITY))
        .collect();
    let mut seen = vec![false; doc.nodes().len()];
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err(Error::format(
                name,
                format!(
                    "node {} is reached twice: it has two parents or is part of a cycle",
                    node.index()
                ),
            ));
        }
        let world = parent * local_matrix(&node);
        if let Some(m) = node.mesh() {
            out.push((m, world));
        }
        let children: Vec<gltf::Node> = node.children().collect();
        for c in children.into_iter().rev() {
            stack.push((c, world));
        }
    }
    if out.is_empty() {
        out = doc.meshes().map(|m| (m, glam::DMat4::IDENTITY)).collect();
    }
    Ok(out)
}

fn local_matrix(node: &gltf::Node) -> glam::DMat4 {
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            glam::DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)))
        }
        gltf::scene::Transform::Decomposed {
            translation: t,
            rotation: r,
            scale: s,
        } => {
            let q = glam::DQuat::from_array(r.map(f64::from));
            let q = if q.length_squared() > 0.0 {
                q.normalize()
            } else {
                glam::DQuat::IDENTITY
            };
            glam::DMat4::from_scale_rotation_translation(
                glam::DVec3::from_array(s.map(f64::from)),
                q,
                glam::DVec3::from_array(t.map(f64::from)),
            )
        }
    }
}

/// Largest all-zero accessor (no buffer view) accepted, in bytes.
const ZERO_ACCESSOR_LIMIT: usize = 64 << 20;

/// Where an accessor is, for messages and buffer access.
struct Ctx<'a, 'b> {
    name: &'a str,
    mesh: usize,
    prim: usize,
    buffers: &'a [Cow<'b, [u8]>],
}

impl Ctx<'_, '_> {
    fn err(&self, what: &str, msg: impl std::fmt::Display) -> Error {
        Error::format(
            self.name,
            format!("mesh {} primitive {} {what}: {msg}", self.mesh, self.prim),
        )
    }

    /// The bytes of each element of `acc` (element `i` starts at
    /// `i * stride` in the returned slice), with every bound checked; `None`
    /// for an accessor without buffer view (all zeros).
    fn elements<'s>(
        &'s self,
        acc: &gltf::Accessor,
        what: &str,
    ) -> Result<Option<(&'s [u8], usize, usize)>> {
        let what = format!("{what} (accessor {})", acc.index());
        if acc.sparse().is_some() {
            return Err(self.err(&what, "sparse accessors are not supported"));
        }
        let elem = acc.size();
        let Some(view) = acc.view() else {
            // All zeros; bound the declared count before anything allocates it.
            if acc.count().saturating_mul(elem) > ZERO_ACCESSOR_LIMIT {
                return Err(self.err(
                    &what,
                    format!(
                        "accessor without buffer view declares {} elements (more than {ZERO_ACCESSOR_LIMIT} bytes of zeros)",
                        acc.count()
                    ),
                ));
            }
            return Ok(None);
        };
        let buf = &self.buffers[view.buffer().index()];
        let vstart = view.offset();
        let vend = vstart
            .checked_add(view.length())
            .filter(|&e| e <= buf.len())
            .ok_or_else(|| {
                self.err(
                    &what,
                    format!(
                        "buffer view {} (bytes {vstart}+{}) exceeds buffer {} ({} bytes)",
                        view.index(),
                        view.length(),
                        view.buffer().index(),
                        buf.len()
                    ),
                )
            })?;
        let data = &buf[vstart..vend];
        let stride = view.stride().unwrap_or(elem);
        let count = acc.count();
        let need = if count == 0 {
            0
        } else {
            (count - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(elem))
                .and_then(|x| x.checked_add(acc.offset()))
                .unwrap_or(usize::MAX)
        };
        if need > data.len() {
            return Err(self.err(
                &what,
                format!(
                    "{count} elements of {elem} bytes (stride {stride}, offset {}) need {need} bytes but buffer view {} has {}",
                    acc.offset(),
                    view.index(),
                    data.len()
                ),
            ));
        }
        Ok(Some((&data[acc.offset().min(data.len())..], stride, elem)))
    }

    /// Reads an f32 VEC3 attribute.
    fn vec3(&self, acc: &gltf::Accessor, what: &str) -> Result<Vec<[f32; 3]>> {
        if acc.data_type() != DataType::F32 || acc.dimensions() != Dimensions::Vec3 {
            return Err(self.err(
                what,
                format!(
                    "expected f32 VEC3, found {:?} {:?}",
                    acc.data_type(),
                    acc.dimensions()
                ),
            ));
        }
        let Some((data, stride, _)) = self.elements(acc, what)? else {
            return Ok(vec![[0.0; 3]; acc.count()]);
        };
        Ok((0..acc.count())
            .map(|i| {
                let e = &data[i * stride..];
                [0, 4, 8].map(|o| f32::from_le_bytes([e[o], e[o + 1], e[o + 2], e[o + 3]]))
            })
            .collect())
    }

    /// Reads `COLOR_0` as RGBA u8.
    fn colors(&self, acc: &gltf::Accessor) -> Result<Vec<[u8; 4]>> {
        let what = "COLOR_0";
        let n = match acc.dimensions() {
            Dimensions::Vec3 => 3,
            Dimensions::Vec4 => 4,
            d => return Err(self.err(what, format!("expected VEC3 or VEC4, found {d:?}"))),
        };
        let t = acc.data_type();
        let ok =
            t == DataType::F32 || (acc.normalized() && matches!(t, DataType::U8 | DataType::U16));
        if !ok {
            return Err(self.err(
                what,
                format!("expected f32 or normalised u8/u16 components, found {t:?}"),
            ));
        }
        let Some((data, stride, _)) = self.elements(acc, what)? else {
            let a = if n == 3 { 255 } else { 0 };
            return Ok(vec![[0, 0, 0, a]; acc.count()]);
        };
        Ok((0..acc.count())
            .map(|i| {
                let e = &data[i * stride..];
                let mut c = [255u8; 4];
                for (k, ck) in c.iter_mut().enumerate().take(n) {
                    *ck = match t {
                        DataType::U8 => e[k],
                        DataType::U16 => {
                            let v = u32::from(u16::from_le_bytes([e[2 * k], e[2 * k + 1]]));
                            ((v * 255 + 32767) / 65535) as u8
                        }
                        _ => {
                            let o = 4 * k;
                            let v = f32::from_le_bytes([e[o], e[o + 1], e[o + 2], e[o + 3]]);
                            (v.clamp(0.0, 1.0) * 255.0).round() as u8
                        }
                    };
                }
                c
            })
            .collect())
    }

    /// Reads an index accessor.
    fn indices(&self, acc: &gltf::Accessor) -> Result<Vec<u32>> {
        let what = "indices";
        let t = acc.data_type();
        if acc.dimensions() != Dimensions::Scalar
            || !matches!(t, DataType::U8 | DataType::U16 | DataType::U32)
        {
            return Err(self.err(
                what,
                format!(
                    "expected u8, u16 or u32 SCALAR, found {t:?} {:?}",
                    acc.dimensions()
                ),
            ));
        }
        let Some((data, stride, _)) = self.elements(acc, what)? else {
            return Ok(vec![0; acc.count()]);
        };
        Ok((0..acc.count())
            .map(|i| {
                let e = &data[i * stride..];
                match t {
                    DataType::U8 => u32::from(e[0]),
                    DataType::U16 => u32::from(u16::from_le_bytes([e[0], e[1]])),
                    _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
                }
            })
            .collect())
    }
}

/// Accumulates primitives into one mesh.
#[derive(Default)]
struct Merge {
    vertices: Vec<[f32; 3]>,
    faces: Vec<[u32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    colors: Option<Vec<[u8; 4]>>,
}

impl Merge {
    fn add(&mut self, ctx: &Ctx, prim: &gltf::Primitive, m: &glam::DMat4) -> Result<()> {
        let tris = match prim.mode() {
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => true,
            Mode::Points => false,
            Mode::Lines | Mode::LineLoop | Mode::LineStrip => return Ok(()),
        };
        let pos_acc = prim
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| ctx.err("POSITION", "the primitive has no POSITION attribute"))?;
        let mut pos = ctx.vec3(&pos_acc, "POSITION")?;
        let n = pos.len();
        let base = self.vertices.len();
        if base + n > u32::MAX as usize {
            return Err(ctx.err("POSITION", "more than 2^32 vertices in total"));
        }
        let mut normals = match prim.get(&gltf::Semantic::Normals) {
            Some(a) => {
                let v = ctx.vec3(&a, "NORMAL")?;
                if v.len() != n {
                    return Err(ctx.err("NORMAL", format!("{} normals for {n} positions", v.len())));
                }
                Some(v)
            }
            None => None,
        };
        let colors = match prim.get(&gltf::Semantic::Colors(0)) {
            Some(a) => {
                let c = ctx.colors(&a)?;
                if c.len() != n {
                    return Err(
                        ctx.err("COLOR_0", format!("{} colours for {n} positions", c.len()))
                    );
                }
                Some(c)
            }
            None => None,
        };
        let flip = m.determinant() < 0.0;
        if *m != glam::DMat4::IDENTITY {
            for p in &mut pos {
                let q = m.transform_point3(glam::DVec3::from_array(p.map(f64::from)));
                *p = q.as_vec3().to_array();
            }
            if let Some(ns) = normals.as_mut() {
                let nm = glam::DMat3::from_mat4(*m).inverse().transpose();
                for v in ns.iter_mut() {
                    let q = (nm * glam::DVec3::from_array(v.map(f64::from))).normalize_or_zero();
                    *v = q.as_vec3().to_array();
                }
            }
        }
        if tris {
            let idx = match prim.indices() {
                Some(a) => {
                    let idx = ctx.indices(&a)?;
                    if let Some((k, &bad)) = idx.iter().enumerate().find(|(_, i)| **i as usize >= n)
                    {
                        return Err(ctx.err(
                            "indices",
                            format!("index {k} is {bad} but the primitive has {n} vertices"),
                        ));
                    }
                    idx
                }
                None => (0..n as u32).collect(),
            };
            let b = base as u32;
            let mut push = |a: u32, c: u32, d: u32| {
                let f = if flip {
                    [a + b, d + b, c + b]
                } else {
                    [a + b, c + b, d + b]
                };
                self.faces.push(f);
            };
            match prim.mode() {
                Mode::Triangles => {
                    for t in idx.chunks_exact(3) {
                        push(t[0], t[1], t[2]);
                    }
                }
                Mode::TriangleStrip => {
                    for k in 2..idx.len() {
                        if k % 2 == 0 {
                            push(idx[k - 2], idx[k - 1], idx[k]);
                        } else {
                            push(idx[k - 1], idx[k - 2], idx[k]);
                        }
                    }
                }
                _ => {
                    for k in 2..idx.len() {
                        push(idx[k - 1], idx[k], idx[0]);
                    }
                }
            }
        }
        match (normals, self.normals.as_mut()) {
            (Some(v), Some(all)) => all.extend(v),
            (Some(v), None) => {
                let mut all = vec![[0.0; 3]; base];
                all.extend(v);
                self.normals = Some(all);
            }
            (None, Some(all)) => all.resize(base + n, [0.0; 3]),
            (None, None) => {}
        }
        match (colors, self.colors.as_mut()) {
            (Some(v), Some(all)) => all.extend(v),
            (Some(v), None) => {
                let mut all = vec![[255; 4]; base];
                all.extend(v);
                self.colors = Some(all);
            }
            (None, Some(all)) => all.resize(base + n, [255; 4]),
            (None, None) => {}
        }
        self.vertices.extend(pos);
        Ok(())
    }

    fn finish(self) -> Mesh {
        Mesh {
            vertices: self.vertices,
            faces: self.faces,
            normals: self.normals,
            vertex_colors: self.colors,
            ..Default::default()
        }
    }
}

/// Standard base64 (RFC 4648, with `=` padding), as data URIs carry it.
fn base64_encode(data: &[u8]) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(data)
}

/// Decodes base64 (standard or URL-safe alphabet, padding optional, unused
/// trailing bits ignored); `Err(position)` names the first invalid character.
fn base64_decode(s: &str) -> std::result::Result<Vec<u8>, usize> {
    use base64::engine::{DecodePaddingMode, GeneralPurpose, GeneralPurposeConfig};
    use base64::{DecodeError, Engine};
    const LENIENT: GeneralPurpose = GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        GeneralPurposeConfig::new()
            .with_decode_padding_mode(DecodePaddingMode::Indifferent)
            .with_decode_allow_trailing_bits(true),
    );
    // The URL-safe alphabet differs in two characters only.
    let text: Cow<str> = if s.contains(['-', '_']) {
        Cow::Owned(s.replace('-', "+").replace('_', "/"))
    } else {
        Cow::Borrowed(s)
    };
    LENIENT.decode(text.as_bytes()).map_err(|e| match e {
        DecodeError::InvalidByte(at, _) | DecodeError::InvalidLastSymbol { offset: at, .. } => at,
        // A last group of one character cannot encode a byte.
        DecodeError::InvalidLength(symbols) => symbols.saturating_sub(1),
        DecodeError::InvalidPadding => s.find('=').unwrap_or(s.len()),
    })
}

/// Decodes `%XX` escapes in a relative URI (invalid escapes are kept).
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(mesh: &Mesh, container: GltfContainer) -> Vec<u8> {
        let mut out = Vec::new();
        write_gltf(&mut out, mesh, &GltfWriteOptions { container }).unwrap();
        out
    }

    fn sample() -> Mesh {
        Mesh {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [-3.5, 1e-30, 7e20],
            ],
            faces: vec![[0, 1, 2], [2, 1, 3]],
            normals: Some(vec![[0.0, 0.0, 1.0]; 4]),
            vertex_colors: Some(vec![
                [1, 2, 3, 4],
                [5, 6, 7, 8],
                [9, 10, 11, 12],
                [0, 255, 0, 128],
            ]),
            ..Default::default()
        }
    }

    #[test]
    fn base64_known_vectors() {
        // RFC 4648 section 10 test vectors.
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, enc) in cases {
            assert_eq!(base64_encode(plain.as_bytes()), enc);
            assert_eq!(base64_decode(enc).unwrap(), plain.as_bytes());
        }
        assert_eq!(base64_decode("Zm9v!mFy"), Err(4));
        assert_eq!(base64_decode("Z"), Err(0));
        let all: Vec<u8> = (0..=255).collect();
        assert_eq!(base64_decode(&base64_encode(&all)).unwrap(), all);
    }

    #[test]
    fn glb_and_gltf_round_trip() {
        let m = sample();
        for c in [GltfContainer::Glb, GltfContainer::Gltf] {
            let bytes = write(&m, c);
            let back = parse_gltf("t", &bytes).unwrap();
            assert_eq!(back, m, "{c:?}");
        }
        let glb = write(&m, GltfContainer::Glb);
        assert_eq!(&glb[..4], b"glTF");
        assert_eq!(glb.len() % 4, 0, "GLB chunks are 4-byte aligned");
        assert_eq!(
            u32::from_le_bytes(glb[8..12].try_into().unwrap()) as usize,
            glb.len()
        );
        let text = String::from_utf8(write(&m, GltfContainer::Gltf)).unwrap();
        assert!(text.contains("data:application/octet-stream;base64,"));
        // POSITION min/max as the specification requires.
        let root: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(
            root["accessors"][0]["min"],
            serde_json::json!([-3.5, 0.0, 0.0])
        );
        assert_eq!(root["accessors"][0]["max"][0], serde_json::json!(1.0));
    }

    #[test]
    fn face_colours_become_corner_colours() {
        let m = Mesh {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
            faces: vec![[0, 1, 2], [2, 1, 3]],
            face_colors: Some(vec![[10, 20, 30, 40], [50, 60, 70, 80]]),
            ..Default::default()
        };
        let back = parse_gltf("t", &write(&m, GltfContainer::Glb)).unwrap();
        assert_eq!(back.faces, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(
            back.vertices[3..],
            [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]
        );
        let c = back.vertex_colors.unwrap();
        assert_eq!(c[..3], [[10, 20, 30, 40]; 3]);
        assert_eq!(c[3..], [[50, 60, 70, 80]; 3]);
    }

    #[test]
    fn empty_and_point_meshes() {
        let empty = Mesh::default();
        for c in [GltfContainer::Glb, GltfContainer::Gltf] {
            assert_eq!(parse_gltf("t", &write(&empty, c)).unwrap(), empty);
        }
        let pts = Mesh::new(vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], vec![]);
        assert_eq!(
            parse_gltf("t", &write(&pts, GltfContainer::Glb)).unwrap(),
            pts
        );
    }

    /// A hand-made glTF: vertex data in a data URI, u16 indices and u8
    /// normalised VEC3 colours, and the mesh instanced by two nodes.
    fn hand_made(node_json: &str, mode: u32, indices: &[u16]) -> String {
        let mut bin = Vec::new();
        for p in [
            [0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ] {
            for x in p {
                bin.extend_from_slice(&x.to_le_bytes());
            }
        }
        for k in 0..4u8 {
            // VEC3 u8 colours, padded to 4 bytes per element via byteStride.
            bin.extend_from_slice(&[10 * k, 20, 30, 0]);
        }
        for i in indices {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let n = indices.len();
        format!(
            r#"{{"asset":{{"version":"2.0"}},
            "buffers":[{{"byteLength":{len},"uri":"data:application/gltf-buffer;base64,{b64}"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},
                           {{"buffer":0,"byteOffset":48,"byteLength":16,"byteStride":4}},
                           {{"buffer":0,"byteOffset":64,"byteLength":{ilen}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5121,"normalized":true,"count":4,"type":"VEC3"}},
                         {{"bufferView":2,"componentType":5123,"count":{n},"type":"SCALAR"}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"COLOR_0":1}},"indices":2,"mode":{mode}}},
                                      {{"attributes":{{"POSITION":0}},"mode":1}}]}}],
            {node_json}}}"#,
            len = bin.len(),
            b64 = base64_encode(&bin),
            ilen = 2 * n,
        )
    }

    #[test]
    fn node_transforms_and_merging() {
        // Node 0: translation (10, 0, 0) and child node 1 scaled by 2 (so the
        // child's world transform is translate(10,0,0) * scale(2)); both
        // instance mesh 0. The LINES primitive is skipped.
        let nodes = r#""nodes":[{"mesh":0,"translation":[10,0,0],"children":[1]},
                                 {"mesh":0,"scale":[2,2,2]}],
                       "scenes":[{"nodes":[0]}],"scene":0"#;
        let text = hand_made(nodes, 4, &[0, 1, 2, 2, 1, 3]);
        let m = parse_gltf("t.gltf", text.as_bytes()).unwrap();
        let want: Vec<[f32; 3]> = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ]
        .iter()
        .map(|p| [p[0] + 10.0, p[1], p[2]])
        .chain(
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
            ]
            .iter()
            .map(|p| [2.0 * p[0] + 10.0, 2.0 * p[1], 2.0 * p[2]]),
        )
        .collect();
        assert_eq!(m.vertices, want);
        assert_eq!(m.faces, vec![[0, 1, 2], [2, 1, 3], [4, 5, 6], [6, 5, 7]]);
        let c = m.vertex_colors.unwrap();
        assert_eq!(c.len(), 8);
        assert_eq!(c[1], [10, 20, 30, 255]);
        assert_eq!(c[7], [30, 20, 30, 255]);
    }

    #[test]
    fn mirroring_flips_winding_and_strips_fans() {
        let mirror = r#""nodes":[{"mesh":0,"matrix":[-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]"#;
        let m = parse_gltf("t", hand_made(mirror, 4, &[0, 1, 2]).as_bytes()).unwrap();
        assert_eq!(m.vertices[1], [-1.0, 0.0, 0.0]);
        assert_eq!(m.faces, vec![[0, 2, 1]]);
        // TRIANGLE_STRIP 0 1 2 3 -> (0 1 2), (2 1 3); no nodes at all: the mesh
        // is read untransformed.
        let m = parse_gltf("t", hand_made(r#""nodes":[]"#, 5, &[0, 1, 2, 3]).as_bytes()).unwrap();
        assert_eq!(m.faces, vec![[0, 1, 2], [2, 1, 3]]);
        // TRIANGLE_FAN 0 1 3 2 -> (1 3 0), (3 2 0).
        let m = parse_gltf("t", hand_made(r#""nodes":[]"#, 6, &[0, 1, 3, 2]).as_bytes()).unwrap();
        assert_eq!(m.faces, vec![[1, 3, 0], [3, 2, 0]]);
    }

    fn err_of(bytes: &[u8]) -> String {
        parse_gltf("t.glb", bytes).unwrap_err().to_string()
    }

    #[test]
    fn malformed_glb() {
        let glb = write(&sample(), GltfContainer::Glb);
        // Every truncation fails cleanly: the header declares the length.
        for cut in 4..glb.len() {
            let e = err_of(&glb[..cut]);
            assert!(e.starts_with("t.glb: byte offset "), "cut {cut}: {e}");
        }
        // JSON chunk length too large.
        let mut bad = glb.clone();
        bad[12..16].copy_from_slice(&(glb.len() as u32).to_le_bytes());
        let e = err_of(&bad);
        assert!(
            e.contains("byte offset 12") && e.contains("chunk length"),
            "{e}"
        );
        // BIN chunk length too large.
        let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
        let bin_at = 20 + json_len;
        let mut bad = glb.clone();
        bad[bin_at..bin_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = err_of(&bad);
        assert!(e.contains(&format!("byte offset {bin_at}")), "{e}");
        // BIN chunk shorter than the buffer it holds.
        let mut bad = glb.clone();
        let short = u32::from_le_bytes(glb[bin_at..bin_at + 4].try_into().unwrap()) - 8;
        bad[bin_at..bin_at + 4].copy_from_slice(&short.to_le_bytes());
        bad.truncate(glb.len() - 8);
        bad[8..12].copy_from_slice(&(glb.len() as u32 - 8).to_le_bytes());
        let e = err_of(&bad);
        assert!(e.contains("buffer 0 declares"), "{e}");
        // Wrong version.
        let mut bad = glb.clone();
        bad[4] = 1;
        assert!(err_of(&bad).contains("byte offset 4: GLB version 1"));
        // Broken JSON.
        let mut bad = glb.clone();
        bad[20] = b'[';
        assert!(err_of(&bad).contains("invalid glTF JSON"));
    }

    #[test]
    fn malformed_content() {
        // Index out of range.
        let text = hand_made(r#""nodes":[]"#, 4, &[0, 1, 9]);
        let e = parse_gltf("t", text.as_bytes()).unwrap_err().to_string();
        assert!(
            e.contains("mesh 0 primitive 0 indices") && e.contains("is 9"),
            "{e}"
        );
        // Accessor larger than its view.
        let text = hand_made(r#""nodes":[]"#, 4, &[0, 1, 2]).replace(
            r#""count":4,"type":"VEC3","min""#,
            r#""count":5,"type":"VEC3","min""#,
        );
        let e = parse_gltf("t", text.as_bytes()).unwrap_err().to_string();
        assert!(
            e.contains("POSITION (accessor 0)") && e.contains("need 60 bytes"),
            "{e}"
        );
        // External buffer without a folder to resolve it.
        let text = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":4,"uri":"x.bin"}]}"#;
        let e = parse_gltf("t", text.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("external file 'x.bin'"), "{e}");
        // Node cycle.
        let text = r#"{"asset":{"version":"2.0"},"nodes":[{"children":[1]},{"children":[0]}],"scenes":[{"nodes":[0]}]}"#;
        let e = parse_gltf("t", text.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("node 0 is reached twice"), "{e}");
    }

    #[test]
    fn every_number_replaced_never_panics() {
        // Each integer in a valid document (indices, offsets, lengths,
        // counts, component types, modes) replaced by extreme values: the
        // reader returns a mesh or an error, never panics or over-allocates.
        let nodes = r#""nodes":[{"mesh":0,"translation":[10,0,0],"children":[1]},{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0"#;
        let text = hand_made(nodes, 4, &[0, 1, 2, 2, 1, 3]);
        let json_start = text.find("\"bufferViews\"").unwrap();
        let bytes = text.as_bytes();
        let mut tried = 0;
        let mut i = json_start;
        while i < bytes.len() {
            if bytes[i].is_ascii_digit() && !bytes[i - 1].is_ascii_alphanumeric() {
                let end = i + bytes[i..].iter().take_while(|b| b.is_ascii_digit()).count();
                for rep in [
                    "0",
                    "1",
                    "3",
                    "7",
                    "5121",
                    "4294967295",
                    "18446744073709551615",
                    "-1",
                ] {
                    let t = format!("{}{rep}{}", &text[..i], &text[end..]);
                    if let Err(e) = parse_gltf("t.gltf", t.as_bytes()) {
                        assert!(e.to_string().starts_with("t.gltf: "), "{e}");
                    }
                    tried += 1;
                }
                i = end;
            } else {
                i += 1;
            }
        }
        assert!(tried > 200, "only {tried} variants");
        // The panic gltf-json would raise on a bad POSITION accessor index.
        let t = text.replace(r#""POSITION":0,"COLOR_0""#, r#""POSITION":9,"COLOR_0""#);
        let e = parse_gltf("t.gltf", t.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("accessor 9 does not exist"), "{e}");
    }

    #[test]
    fn external_buffer_file() {
        let dir = tempfile::tempdir().unwrap();
        let bin: Vec<u8> = [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        std::fs::write(dir.path().join("my data.bin"), &bin).unwrap();
        let text = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"my%20data.bin"}],
            "bufferViews":[{"buffer":0,"byteLength":36}],
            "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
            "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#;
        let p = dir.path().join("m.gltf");
        std::fs::write(&p, text).unwrap();
        let m = read_gltf(&p).unwrap();
        assert_eq!(m.faces, vec![[0, 1, 2]]);
        assert_eq!(m.vertices[1], [1.0, 0.0, 0.0]);
    }
}
