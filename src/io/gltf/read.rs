//! The glTF reader: `.glb` containers, buffers, the scene graph and the
//! accessors of every primitive, merged into one mesh.

use std::borrow::Cow;
use std::path::Path;

use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use gltf_json as json;

use super::color::{linear_to_srgb8, linear8_to_srgb8_table};
use super::{base64_decode, pad4};
use crate::model::Mesh;
use crate::{Error, Result};

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

/// [`parse_gltf`] with external buffer files resolved relative to `base`
/// (the folder of the file the bytes came from).
pub fn parse_gltf_in(name: &str, bytes: &[u8], base: &Path) -> Result<Mesh> {
    parse_gltf_impl(name, bytes, Some(base))
}

const GLB_JSON: u32 = 0x4E4F_534A;
const GLB_BIN: u32 = 0x004E_4942;

/// Splits a GLB container into its JSON and (optional) BIN chunks, checking
/// every length against the bytes present.
pub(super) fn split_glb<'a>(name: &str, bytes: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>)> {
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
        // The chunk header must lie inside the declared length (the file
        // may hold more bytes than the header declares).
        if off + 8 > bytes.len() {
            return Err(err(
                off,
                format!("GLB chunk header runs past the declared length {length}"),
            ));
        }
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
    let doc = gltf::Document::from_json(root).map_err(|e| {
        // gltf's own message may already start with "invalid glTF".
        let msg = e.to_string();
        let msg = if msg.starts_with("invalid glTF") {
            msg
        } else {
            format!("invalid glTF: {msg}")
        };
        Error::format(name, msg)
    })?;
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
                Cow::Owned(read_external(name, &what, uri, &p, b.length())?)
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

/// Reads exactly the `len` bytes a buffer declares from its external file
/// `path` (`uri` as written in `name`): the length is checked against the
/// memory budget, and against the file's size when it is a regular file,
/// before anything is read; a device or FIFO is read up to `len` bytes only.
/// Errors name the glTF file, the buffer and the URI.
fn read_external(name: &str, what: &str, uri: &str, path: &Path, len: usize) -> Result<Vec<u8>> {
    use std::io::Read;
    let fail = |msg: String| Error::format(name, format!("{what} ('{uri}'): {msg}"));
    crate::io::budget::check(&format!("byteLength {len}"), len as u64)
        .map_err(|e| fail(e.to_string()))?;
    crate::io::transaction::note_input(path)?;
    let file = std::fs::File::open(path).map_err(|e| fail(format!("{}: {e}", path.display())))?;
    let meta = file
        .metadata()
        .map_err(|e| fail(format!("{}: {e}", path.display())))?;
    if meta.is_dir() {
        return Err(fail(format!("{} is a folder", path.display())));
    }
    if meta.is_file() && meta.len() < len as u64 {
        return Err(fail(format!(
            "byteLength is {len} but {} has only {} bytes",
            path.display(),
            meta.len()
        )));
    }
    let mut v = Vec::with_capacity(len.min(1 << 20));
    (&file)
        .take(len as u64)
        .read_to_end(&mut v)
        .map_err(|e| fail(format!("{}: {e}", path.display())))?;
    if v.len() < len {
        return Err(fail(format!(
            "byteLength is {len} but {} gave only {} bytes",
            path.display(),
            v.len()
        )));
    }
    Ok(v)
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

    /// Reads `COLOR_0` (linear) as 8-bit sRGB RGBA (see the module
    /// documentation).
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
        let lut8 = linear8_to_srgb8_table();
        Ok((0..acc.count())
            .map(|i| {
                let e = &data[i * stride..];
                let mut c = [255u8; 4];
                for (k, ck) in c.iter_mut().enumerate().take(n) {
                    let alpha = k == 3;
                    *ck = match t {
                        DataType::U8 if alpha => e[k],
                        DataType::U8 => lut8[e[k] as usize],
                        DataType::U16 => {
                            let v = u32::from(u16::from_le_bytes([e[2 * k], e[2 * k + 1]]));
                            if alpha {
                                ((v * 255 + 32767) / 65535) as u8
                            } else {
                                linear_to_srgb8(f64::from(v) / 65535.0)
                            }
                        }
                        _ => {
                            let o = 4 * k;
                            let v = f32::from_le_bytes([e[o], e[o + 1], e[o + 2], e[o + 3]]);
                            if alpha {
                                (if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) } * 255.0).round()
                                    as u8
                            } else {
                                linear_to_srgb8(f64::from(v))
                            }
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

/// Decodes `%XX` escapes in a relative URI (invalid escapes are kept).
pub(super) fn percent_decode(uri: &str) -> String {
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
