//! Wavefront OBJ meshes: positions, normals, vertex colours, faces, texture
//! coordinates and one diffuse texture (`mtllib` / `usemtl` / `map_Kd`, PNG).
//!
//! # Reading
//! The reader is hand-written rather than built on `tobj`, because `tobj`
//! renumbers vertices in order of first use by a face, drops vertices no face
//! uses and duplicates vertices shared between groups; here the file's vertex
//! order and count are kept, so per-vertex data stays aligned and a
//! write→read round trip is exact. Errors name the file and line.
//!
//! - `v x y z` gives a vertex; `v x y z r g b` adds a colour (floats 0–1,
//!   clamped, scaled by 255 and rounded; alpha 255); `v x y z w` is accepted
//!   and `w` ignored (it only matters for rational curves). When some vertices
//!   have colours, the others get opaque white.
//! - `vn` lines give normals; `vt u [v [w]]` lines give texture coordinates
//!   (`v` defaults to 0, `w` is ignored; v points up, row 0 of the image is
//!   v = 1, see [`crate::model::texture`]). Each face corner's `vt` goes to
//!   [`Mesh::uvs`] (per face corner, so seams need no vertex copies); a
//!   corner naming none gets NaN. The mesh has `uvs` when some corner names
//!   a `vt`.
//! - `mtllib` and `usemtl` are recorded; [`parse_obj_in`] / [`read_obj`]
//!   (and `io::any::load`) then read the material files next to the OBJ and
//!   attach the `map_Kd` image of the first textured material that faces use
//!   as [`Mesh::texture`]; faces of other materials get NaN coordinates.
//! - `f` corners are `v`, `v/vt`, `v//vn` or `v/vt/vn`, 1-based, or negative
//!   (relative to the vertices / normals defined so far). Polygons are
//!   fan-triangulated (`a b c`, `a c d`, …); faces with fewer than 3 corners
//!   give nothing. `l`, `p`, groups, objects, smoothing groups and every
//!   other statement are ignored; all groups go into one mesh.
//! - Normals: OBJ indexes normals separately from positions, the mesh stores
//!   one per vertex. A vertex takes the normal of the first face corner that
//!   names one; a corner naming a different normal (different value) for the
//!   same vertex gets a copy of that vertex appended at the end of the vertex
//!   list. Vertices that no corner gives a normal take `vn` number *i* when the
//!   file has as many `vn` as `v` lines, else (0, 0, 0). The mesh has normals
//!   when the file has `vn` lines and either some corner uses them or their
//!   count equals the vertex count.
//! - Lines ending in `\` continue on the next line; `#` starts a comment.
//!
//! # Writing
//! `v x y z [r g b]`, `vn nx ny nz`, `f a b c` or `f a//a b//b c//c`, 1-based,
//! floats in shortest round-trip form ([`crate::io::off::format_f32_shortest`]). OBJ has no
//! alpha and no per-face colours; see [`ObjWriteOptions`]. A mesh with
//! texture coordinates gets three private `vt` lines per textured face and
//! `f a/t …` corners; [`write_obj_with_material`] adds `mtllib` / `usemtl`
//! (the MTL and PNG are written beside it by `io::any::save_mesh`).

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use crate::io::off::{push_f32_shortest, write_lines_par};
use crate::io::source::werr;
use crate::model::Mesh;
use crate::{Error, Result};

/// Reads an OBJ file (`-` = stdin) with its texture (materials resolved
/// next to the file, see [`parse_obj_in`]). See the module documentation.
pub fn read_obj(path: &Path) -> Result<Mesh> {
    let input = crate::io::read_input(path)?;
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() && !input.is_stdin() => p,
        _ => Path::new("."),
    };
    parse_obj_in(&input.name, &input, base)
}

/// [`parse_obj`], then the texture: `mtllib` files are looked up in `base`
/// (the OBJ's folder) and the first material used by a face (in face order)
/// whose `map_Kd` names an image becomes [`Mesh::texture`] (a PNG, path
/// relative to the MTL's folder; when no face names a material and the
/// libraries hold exactly one textured material, that one). Faces under a
/// material with no image or another image get NaN texture coordinates.
///
/// A missing or unreadable MTL or image is not an error: the mesh loads
/// with its texture coordinates and without a texture (`render` says so),
/// so geometry commands keep working on an OBJ copied without its
/// material files. JPEG textures are not decoded (convert them to PNG).
pub fn parse_obj_in(name: &str, bytes: &[u8], base: &Path) -> Result<Mesh> {
    let (mut mesh, mats) = parse_obj_materials(name, bytes)?;
    if mesh.uvs.is_some() {
        attach_texture(&mut mesh, &mats, base);
    }
    Ok(mesh)
}

/// One `newmtl` of an MTL file: its `map_Kd` image path and every texture
/// map (statement, path), paths resolved against the MTL's folder.
struct MtlEntry {
    name: String,
    map_kd: Option<std::path::PathBuf>,
    maps: Vec<(String, std::path::PathBuf)>,
}

/// The MTL file an `mtllib` statement names: the whole argument when such a
/// file exists (names may hold spaces), else each word that does.
fn mtl_files(lib: &str, base: &Path) -> Vec<std::path::PathBuf> {
    let whole = base.join(lib.replace('\\', "/"));
    if whole.is_file() {
        return vec![whole];
    }
    lib.split_whitespace()
        .map(|w| base.join(w.replace('\\', "/")))
        .filter(|p| p.is_file())
        .collect()
}

/// Whether an MTL statement names a texture map (`map_Kd`, `map_Bump`,
/// `bump`, `disp`, `decal`, `refl`, `norm`, …).
fn is_map_statement(kw: &str) -> bool {
    let k = kw.to_ascii_lowercase();
    k.starts_with("map_") || matches!(k.as_str(), "bump" | "disp" | "decal" | "refl" | "norm")
}

/// Parses MTL text: material names and their texture maps. Options before
/// the file name (`-s 1 1 1`, `-clamp on`, `-bm 0.5`, …) are skipped.
fn parse_mtl(text: &str, dir: &Path) -> Vec<MtlEntry> {
    let mut out: Vec<MtlEntry> = Vec::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or_default().trim();
        let (kw, rest) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
        if kw == "newmtl" {
            out.push(MtlEntry {
                name: rest.trim().to_string(),
                map_kd: None,
                maps: Vec::new(),
            });
        } else if is_map_statement(kw) {
            let words: Vec<&str> = rest.split_whitespace().collect();
            let mut i = 0;
            while i + 1 < words.len() && words[i].starts_with('-') {
                i += 1;
                // an option's arguments: numbers and on/off
                while i + 1 < words.len()
                    && (words[i].parse::<f64>().is_ok() || matches!(words[i], "on" | "off"))
                {
                    i += 1;
                }
            }
            let file = words[i.min(words.len())..].join(" ");
            if let (Some(m), false) = (out.last_mut(), file.is_empty()) {
                let path = dir.join(file.replace('\\', "/"));
                if kw == "map_Kd" || kw == "map_kd" {
                    m.map_kd = Some(path.clone());
                }
                m.maps.push((kw.to_string(), path));
            }
        }
    }
    out
}

/// The materials and texture files of an OBJ, for `info`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjInventory {
    /// Each `mtllib` argument with the MTL file it resolved to (`None`:
    /// not found).
    pub mtllibs: Vec<(String, Option<std::path::PathBuf>)>,
    /// Materials used by faces (in order of first `usemtl`), then those the
    /// MTL files define and no face uses.
    pub materials: Vec<crate::io::materials::MaterialInfo>,
    /// Every texture file the MTL files name, and whether it exists.
    pub textures: Vec<crate::io::materials::TextureFile>,
}

/// Parses an OBJ as [`parse_obj_in`] does and lists its materials: the
/// `mtllib` files looked up in `base`, each material with the faces that
/// use it and its texture maps, and each texture file with whether it
/// exists. A missing MTL or image is reported, not an error.
pub fn parse_obj_inventory(name: &str, bytes: &[u8], base: &Path) -> Result<(Mesh, ObjInventory)> {
    use crate::io::materials::{MaterialInfo, MaterialTexture, note_file};
    let (mut mesh, mats) = parse_obj_materials(name, bytes)?;
    if mesh.uvs.is_some() {
        attach_texture(&mut mesh, &mats, base);
    }
    let mut inv = ObjInventory::default();
    let mut entries: Vec<MtlEntry> = Vec::new();
    for lib in &mats.libs {
        let files = mtl_files(lib, base);
        if files.is_empty() {
            inv.mtllibs.push((lib.clone(), None));
        }
        for f in files {
            if let Ok(text) = crate::io::source::read_file(&f) {
                let dir = f.parent().unwrap_or(Path::new("."));
                entries.extend(parse_mtl(&String::from_utf8_lossy(&text), dir));
            }
            inv.mtllibs.push((lib.clone(), Some(f)));
        }
    }
    let mut used = vec![0usize; mats.names.len()];
    for &m in &mats.face_material {
        if let Some(u) = used.get_mut(m as usize) {
            *u += 1;
        }
    }
    let mut describe = |name: &str, used_by: usize, entry: Option<&MtlEntry>| MaterialInfo {
        name: name.to_string(),
        alpha_mode: None,
        used_by,
        defined: entry.is_some(),
        textures: entry
            .map(|e| {
                e.maps
                    .iter()
                    .map(|(slot, p)| MaterialTexture {
                        slot: slot.clone(),
                        file: note_file(&mut inv.textures, p.display().to_string(), p.is_file()),
                    })
                    .collect()
            })
            .unwrap_or_default(),
    };
    let mut materials = Vec::new();
    for (i, n) in mats.names.iter().enumerate() {
        let entry = entries.iter().find(|e| e.name == *n);
        materials.push(describe(n, used[i], entry));
    }
    for e in &entries {
        if !mats.names.contains(&e.name) && !materials.iter().any(|m| m.name == e.name) {
            materials.push(describe(&e.name, 0, Some(e)));
        }
    }
    inv.materials = materials;
    Ok((mesh, inv))
}

/// Reads a texture image: an 8- or 16-bit PNG (grey, grey+alpha, RGB or
/// RGBA; alpha dropped, 16 bits reduced to 8), row 0 at the top.
pub fn read_texture(path: &Path) -> Result<crate::model::Texture> {
    let t = png::Transformations::EXPAND | png::Transformations::STRIP_16;
    let (info, buf) = crate::io::image::decode_png(path, t)?;
    let (w, h) = (info.width as usize, info.height as usize);
    let ch = info.color_type.samples();
    let pixels = buf[..w * h * ch]
        .chunks_exact(ch)
        .map(|p| {
            if ch >= 3 {
                [p[0], p[1], p[2]]
            } else {
                [p[0]; 3]
            }
        })
        .collect();
    Ok(crate::model::Texture {
        name: path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        width: w,
        height: h,
        pixels,
    })
}

/// Finds and reads the mesh's texture (see [`parse_obj_in`]).
fn attach_texture(mesh: &mut Mesh, mats: &ObjMaterials, base: &Path) {
    let mut entries: Vec<MtlEntry> = Vec::new();
    for lib in &mats.libs {
        for f in mtl_files(lib, base) {
            if let Ok(text) = crate::io::source::read_file(&f) {
                let dir = f.parent().unwrap_or(Path::new("."));
                entries.extend(parse_mtl(&String::from_utf8_lossy(&text), dir));
            }
        }
    }
    let image_of = |m: u32| -> Option<&std::path::PathBuf> {
        let name = mats.names.get(m as usize)?;
        entries.iter().find(|e| e.name == *name)?.map_kd.as_ref()
    };
    let textured: Vec<&std::path::PathBuf> =
        entries.iter().filter_map(|e| e.map_kd.as_ref()).collect();
    let no_materials = mats.face_material.iter().all(|&m| m == NONE);
    let chosen = if no_materials {
        (textured.len() == 1).then(|| textured[0].clone())
    } else {
        mats.face_material
            .iter()
            .find_map(|&m| image_of(m))
            .cloned()
    };
    let Some(path) = chosen else {
        return;
    };
    let Ok(texture) = read_texture(&path) else {
        return;
    };
    if !no_materials && let Some(uvs) = mesh.uvs.as_mut() {
        for (uv, &m) in uvs.iter_mut().zip(&mats.face_material) {
            if image_of(m) != Some(&path) {
                *uv = [[f32::NAN; 2]; 3];
            }
        }
    }
    mesh.texture = Some(Box::new(texture));
}

/// Parses the bytes of an OBJ file; `name` is used in error messages.
/// Texture coordinates are kept ([`Mesh::uvs`]); materials are not looked
/// up (see [`parse_obj_in`]).
pub fn parse_obj(name: &str, bytes: &[u8]) -> Result<Mesh> {
    parse_obj_materials(name, bytes).map(|(m, _)| m)
}

fn parse_obj_materials(name: &str, bytes: &[u8]) -> Result<(Mesh, ObjMaterials)> {
    let mut r = ObjReader::default();
    let mut line_no = 0usize;
    let mut pos = 0usize;
    let mut joined: Vec<u8> = Vec::new();
    while pos < bytes.len() {
        // Gather one logical line (physical lines joined by a trailing `\`).
        line_no += 1;
        let start_line = line_no;
        joined.clear();
        loop {
            let rest = &bytes[pos..];
            let end = rest.iter().position(|&b| b == b'\n');
            let mut raw = match end {
                Some(e) => &rest[..e],
                None => rest,
            };
            pos += raw.len() + usize::from(end.is_some());
            if let Some(r) = raw.strip_suffix(b"\r") {
                raw = r;
            }
            match raw.strip_suffix(b"\\") {
                Some(head) if pos < bytes.len() => {
                    joined.extend_from_slice(head);
                    joined.push(b' ');
                    line_no += 1;
                }
                _ => {
                    joined.extend_from_slice(raw);
                    break;
                }
            }
        }
        let content = match joined.iter().position(|&b| b == b'#') {
            Some(c) => &joined[..c],
            None => &joined[..],
        };
        r.statement(content)
            .map_err(|msg| Error::format(name, format!("line {start_line}: {msg}")))?;
    }
    r.finish().map_err(|msg| Error::format(name, msg))
}

/// Accumulated state of the OBJ reader.
#[derive(Default)]
struct ObjReader {
    vertices: Vec<[f32; 3]>,
    colors: Option<Vec<[u8; 4]>>,
    file_normals: Vec<[f32; 3]>,
    texcoords: Vec<[f32; 2]>,
    faces: Vec<[u32; 3]>,
    /// `vt` index of each face corner (`NONE` where the corner names none).
    face_vt: Vec<[u32; 3]>,
    /// Material of each face: index into `materials`, `NONE` before any `usemtl`.
    face_material: Vec<u32>,
    /// Material names in order of first `usemtl`.
    materials: Vec<String>,
    current_material: Option<u32>,
    /// `mtllib` arguments as written.
    mtllibs: Vec<String>,
    /// Normal index assigned to each vertex (`u32::MAX` = none yet), grown
    /// lazily as faces use normals.
    vertex_normal: Vec<u32>,
    /// Copies of vertices made for a second normal: (vertex, normal) -> copy.
    splits: HashMap<(u32, u32), u32>,
    /// Original vertex of each appended copy.
    split_of: Vec<u32>,
    any_corner_normal: bool,
}

const NONE: u32 = u32::MAX;
/// Provisional indices of vertex copies start here (file vertices stay below).
const SPLIT_BASE: u32 = 1 << 31;

impl ObjReader {
    fn statement(&mut self, line: &[u8]) -> std::result::Result<(), String> {
        let mut toks = line
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        let Some(kw) = toks.next() else {
            return Ok(());
        };
        match kw {
            b"v" => {
                let mut vals = [0f32; 7];
                let mut n = 0;
                for t in toks {
                    if n == 7 {
                        return Err("expected `v x y z [r g b]`, found more than 6 numbers".into());
                    }
                    vals[n] = parse_f32(t, "a vertex coordinate or colour")?;
                    n += 1;
                }
                match n {
                    3 | 4 => {
                        if let Some(c) = self.colors.as_mut() {
                            c.push([255; 4]);
                        }
                    }
                    6 => {
                        let c = [vals[3], vals[4], vals[5]].map(unit_to_u8);
                        let i = self.vertices.len();
                        self.colors
                            .get_or_insert_with(|| vec![[255; 4]; i])
                            .push([c[0], c[1], c[2], 255]);
                    }
                    _ => {
                        return Err(format!(
                            "expected `v x y z [w]` or `v x y z r g b`, found {n} numbers"
                        ));
                    }
                }
                if self.vertices.len() >= SPLIT_BASE as usize {
                    return Err("too many vertices for 32-bit indices".into());
                }
                self.vertices.push([vals[0], vals[1], vals[2]]);
            }
            b"vn" => {
                let mut n = [0f32; 3];
                for (k, v) in n.iter_mut().enumerate() {
                    let t = toks
                        .next()
                        .ok_or_else(|| format!("expected `vn x y z`, found {k} numbers"))?;
                    *v = parse_f32(t, "a normal component")?;
                }
                self.file_normals.push(n);
            }
            b"vt" => {
                let mut uv = [0f32; 2];
                let mut n = 0;
                for t in toks {
                    let x = parse_f32(t, "a texture coordinate")?;
                    if n < 2 {
                        uv[n] = x;
                    } else if n > 2 {
                        return Err("expected `vt u [v [w]]`, found more than 3 numbers".into());
                    }
                    n += 1;
                }
                if n == 0 {
                    return Err("expected `vt u [v [w]]`, found no numbers".into());
                }
                self.texcoords.push(uv);
            }
            b"f" => {
                let mut corners: Vec<(u32, u32)> = Vec::with_capacity(4);
                for (k, t) in toks.enumerate() {
                    corners.push(
                        self.corner(t)
                            .map_err(|m| format!("face corner {k}: {m}"))?,
                    );
                }
                for k in 2..corners.len().max(2) {
                    let (a, b, c) = (corners[0], corners[k - 1], corners[k]);
                    self.faces.push([a.0, b.0, c.0]);
                    self.face_vt.push([a.1, b.1, c.1]);
                    self.face_material
                        .push(self.current_material.unwrap_or(NONE));
                }
            }
            b"usemtl" => {
                let name = rest_of(line, kw.len());
                self.current_material =
                    Some(match self.materials.iter().position(|m| *m == name) {
                        Some(i) => i as u32,
                        None => {
                            self.materials.push(name);
                            (self.materials.len() - 1) as u32
                        }
                    });
            }
            b"mtllib" => {
                let name = rest_of(line, kw.len());
                if !name.is_empty() {
                    self.mtllibs.push(name);
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// Resolves one `v[/vt[/vn]]` corner to a mesh vertex and its `vt`
    /// index (`NONE` when it names none).
    fn corner(&mut self, t: &[u8]) -> std::result::Result<(u32, u32), String> {
        let mut vt_index = NONE;
        let v = self.corner_vertex(t, &mut vt_index)?;
        Ok((v, vt_index))
    }

    fn corner_vertex(&mut self, t: &[u8], vt_index: &mut u32) -> std::result::Result<u32, String> {
        let mut parts = t.split(|&b| b == b'/');
        let v = parts.next().unwrap_or_default();
        let vt = parts.next();
        let vn = parts.next();
        if parts.next().is_some() {
            return Err(format!(
                "expected `v`, `v/vt`, `v//vn` or `v/vt/vn`, found '{}'",
                String::from_utf8_lossy(t)
            ));
        }
        let v = resolve(v, self.vertices.len(), "vertex")?;
        if let Some(vt) = vt.filter(|s| !s.is_empty()) {
            *vt_index = resolve(vt, self.texcoords.len(), "texture coordinate")?;
        }
        let Some(vn) = vn.filter(|s| !s.is_empty()) else {
            return Ok(v);
        };
        let vn = resolve(vn, self.file_normals.len(), "normal")?;
        self.any_corner_normal = true;
        if self.vertex_normal.len() <= v as usize {
            self.vertex_normal.resize(self.vertices.len(), NONE);
        }
        let cur = self.vertex_normal[v as usize];
        if cur == NONE {
            self.vertex_normal[v as usize] = vn;
            return Ok(v);
        }
        let same = |a: u32, b: u32| {
            a == b
                || self.file_normals[a as usize].map(f32::to_bits)
                    == self.file_normals[b as usize].map(f32::to_bits)
        };
        if same(cur, vn) {
            return Ok(v);
        }
        if let Some(&copy) = self.splits.get(&(v, vn)) {
            return Ok(copy);
        }
        // A second, different normal for this vertex: a copy, appended after
        // all vertices at the end (faces hold a provisional index until then,
        // since more `v` lines may follow).
        if self.split_of.len() >= SPLIT_BASE as usize {
            return Err("too many vertices for 32-bit indices".into());
        }
        let copy = SPLIT_BASE + self.split_of.len() as u32;
        self.splits.insert((v, vn), copy);
        self.split_of.push(v);
        Ok(copy)
    }

    fn finish(mut self) -> std::result::Result<(Mesh, ObjMaterials), String> {
        let n_orig = self.vertices.len();
        if n_orig + self.split_of.len() > NONE as usize {
            return Err(
                "too many vertices (with copies for extra normals) for 32-bit indices".into(),
            );
        }
        let has_normals = !self.file_normals.is_empty()
            && (self.any_corner_normal || self.file_normals.len() == n_orig);
        let normals = has_normals.then(|| {
            self.vertex_normal.resize(n_orig, NONE);
            let positional = self.file_normals.len() == n_orig;
            let mut normals: Vec<[f32; 3]> = (0..n_orig)
                .map(|i| match self.vertex_normal[i] {
                    NONE if positional => self.file_normals[i],
                    NONE => [0.0; 3],
                    k => self.file_normals[k as usize],
                })
                .collect();
            let mut copies: Vec<(u32, u32)> =
                self.splits.iter().map(|(&(_, n), &c)| (c, n)).collect();
            copies.sort_unstable();
            normals.extend(copies.iter().map(|&(_, n)| self.file_normals[n as usize]));
            normals
        });
        if !self.split_of.is_empty() {
            for f in &mut self.faces {
                for i in f.iter_mut() {
                    if *i >= SPLIT_BASE {
                        *i = (n_orig + (*i - SPLIT_BASE) as usize) as u32;
                    }
                }
            }
        }
        for &v in &self.split_of {
            self.vertices.push(self.vertices[v as usize]);
            if let Some(c) = self.colors.as_mut() {
                c.push(c[v as usize]);
            }
        }
        let uvs = self.face_vt.iter().flatten().any(|&t| t != NONE).then(|| {
            self.face_vt
                .iter()
                .map(|f| {
                    f.map(|t| match t {
                        NONE => [f32::NAN; 2],
                        t => self.texcoords[t as usize],
                    })
                })
                .collect()
        });
        let mesh = Mesh {
            vertices: self.vertices,
            faces: self.faces,
            normals,
            vertex_colors: self.colors,
            uvs,
            ..Default::default()
        };
        let materials = ObjMaterials {
            libs: self.mtllibs,
            names: self.materials,
            face_material: self.face_material,
        };
        Ok((mesh, materials))
    }
}

/// What an OBJ says about materials: `mtllib` arguments, `usemtl` names in
/// order of first use, and each face's material (index into `names`,
/// `NONE` before any `usemtl`).
struct ObjMaterials {
    libs: Vec<String>,
    names: Vec<String>,
    face_material: Vec<u32>,
}

/// The text after a statement's keyword, trimmed (names may hold spaces).
fn rest_of(line: &[u8], kw_len: usize) -> String {
    let start = line
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(0)
        + kw_len;
    String::from_utf8_lossy(line.get(start..).unwrap_or_default())
        .trim()
        .to_string()
}

/// Resolves a 1-based or negative (relative) OBJ index against `count`
/// elements defined so far.
fn resolve(t: &[u8], count: usize, what: &str) -> std::result::Result<u32, String> {
    let s = std::str::from_utf8(t).ok();
    let i: i64 = s.and_then(|s| s.parse().ok()).ok_or_else(|| {
        format!(
            "expected a {what} index (a non-zero integer), found '{}'",
            String::from_utf8_lossy(t)
        )
    })?;
    let idx = if i > 0 {
        i - 1
    } else if i < 0 {
        count as i64 + i
    } else {
        return Err(format!(
            "{what} index 0 is invalid (OBJ indices start at 1)"
        ));
    };
    if idx < 0 || idx >= count as i64 {
        return Err(format!(
            "{what} index {i} is out of range ({count} defined so far)"
        ));
    }
    Ok(idx as u32)
}

fn parse_f32(t: &[u8], what: &str) -> std::result::Result<f32, String> {
    std::str::from_utf8(t)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("expected {what}, found '{}'", String::from_utf8_lossy(t)))
}

/// A colour component in 0–1 to 0–255 (clamped, rounded; NaN gives 0).
fn unit_to_u8(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Options of [`write_obj`]. Both default to true.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ObjWriteOptions {
    /// Write `vn` lines and `f a//a …` corners when the mesh has normals.
    pub normals: bool,
    /// Write colours on `v` lines (`r g b` as floats 0–1, alpha dropped).
    /// When the mesh has vertex colours they are used; when it has only face
    /// colours, vertices are un-shared (three per face, in face order, with
    /// normals copied) and each face's colour goes to its three corners.
    pub colors: bool,
}

impl Default for ObjWriteOptions {
    fn default() -> Self {
        ObjWriteOptions {
            normals: true,
            colors: true,
        }
    }
}

/// Whether [`write_obj`] un-shares the vertices of `mesh` (three per face,
/// [`crate::io::gltf::face_colors_to_corners`]): colours are written and the
/// mesh has face colours but no vertex colours.
pub fn unshares_vertices(mesh: &Mesh, opts: &ObjWriteOptions) -> bool {
    opts.colors && mesh.vertex_colors.is_none() && mesh.face_colors.is_some()
}

/// Writes `mesh` as OBJ (see the module documentation and
/// [`ObjWriteOptions`]). Scalars and extras are not written. Non-finite
/// coordinates are written as they are (`inf`, `-inf`, `NaN`); this reader
/// accepts them, most others do not.
///
/// Errors: the mesh fails [`Mesh::validate`], or writing fails.
pub fn write_obj(w: &mut dyn Write, mesh: &Mesh, opts: &ObjWriteOptions) -> Result<()> {
    mesh.validate()
        .map_err(|e| Error::invalid(format!("cannot write OBJ: {e}")))?;
    if unshares_vertices(mesh, opts) {
        let soup = crate::io::gltf::face_colors_to_corners(mesh);
        return write_obj_validated(w, &soup, opts);
    }
    write_obj_validated(w, mesh, opts)
}

/// [`write_obj`] with a material: `mtllib MTL_FILE` and `usemtl MATERIAL`
/// before the faces (the MTL and the texture image are separate files,
/// written by [`write_mtl`] and [`crate::io::image::write_png8`]; see
/// `io::any::save_mesh`, which writes all three).
pub fn write_obj_with_material(
    w: &mut dyn Write,
    mesh: &Mesh,
    opts: &ObjWriteOptions,
    mtl_file: &str,
    material: &str,
) -> Result<()> {
    mesh.validate()
        .map_err(|e| Error::invalid(format!("cannot write OBJ: {e}")))?;
    let unshared;
    let mesh = if unshares_vertices(mesh, opts) {
        unshared = crate::io::gltf::face_colors_to_corners(mesh);
        &unshared
    } else {
        mesh
    };
    write_obj_inner(w, mesh, opts, Some((mtl_file, material)))
}

/// Writes an MTL file with one material whose diffuse map is `texture_file`
/// (white diffuse colour, no specular, so viewers show the texture as it is).
pub fn write_mtl(w: &mut dyn Write, material: &str, texture_file: &str) -> Result<()> {
    write!(
        w,
        "# splatkit\nnewmtl {material}\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nNs 0\nillum 1\nmap_Kd {texture_file}\n"
    )
    .map_err(werr)
}

fn write_obj_validated(w: &mut dyn Write, mesh: &Mesh, opts: &ObjWriteOptions) -> Result<()> {
    write_obj_inner(w, mesh, opts, None)
}

fn write_obj_inner(
    w: &mut dyn Write,
    mesh: &Mesh,
    opts: &ObjWriteOptions,
    material: Option<(&str, &str)>,
) -> Result<()> {
    use std::fmt::Write as _;
    let colors = mesh.vertex_colors.as_ref().filter(|_| opts.colors);
    let normals = mesh.normals.as_ref().filter(|_| opts.normals);
    writeln!(
        w,
        "# {} vertices, {} triangles (splatkit)",
        mesh.vertices.len(),
        mesh.faces.len()
    )
    .map_err(werr)?;
    if let Some((mtl, _)) = material {
        writeln!(w, "mtllib {mtl}").map_err(werr)?;
    }
    write_lines_par(w, &mesh.vertices, |line, i, v| {
        line.push('v');
        for &x in v {
            line.push(' ');
            push_f32_shortest(line, x);
        }
        if let Some(c) = colors {
            for &x in &c[i][..3] {
                line.push(' ');
                push_f32_shortest(line, f32::from(x) / 255.0);
            }
        }
        line.push('\n');
    })?;
    if let Some(ns) = normals {
        write_lines_par(w, ns, |line, _, n| {
            line.push_str("vn");
            for &x in n {
                line.push(' ');
                push_f32_shortest(line, x);
            }
            line.push('\n');
        })?;
    }
    // Texture coordinates: three private `vt` per textured face (faces
    // whose coordinates are not finite get none), numbered in face order.
    let mut vt_base = Vec::new();
    if let Some(uvs) = &mesh.uvs {
        let textured: Vec<[[f32; 2]; 3]> = uvs
            .iter()
            .filter(|f| f.iter().flatten().all(|x| x.is_finite()))
            .copied()
            .collect();
        write_lines_par(w, &textured, |line, _, f| {
            for uv in f {
                line.push_str("vt");
                for &x in uv {
                    line.push(' ');
                    push_f32_shortest(line, x);
                }
                line.push('\n');
            }
        })?;
        let mut next = 1u64;
        vt_base = uvs
            .iter()
            .map(|f| {
                if f.iter().flatten().all(|x| x.is_finite()) {
                    next += 3;
                    next - 3
                } else {
                    0
                }
            })
            .collect();
    }
    if let Some((_, name)) = material {
        writeln!(w, "usemtl {name}").map_err(werr)?;
    }
    let with_normals = normals.is_some();
    write_lines_par(w, &mesh.faces, |line, i, f| {
        let [a, b, c] = f.map(|i| u64::from(i) + 1);
        let t = vt_base.get(i).copied().unwrap_or(0);
        // Writing into a String cannot fail.
        let _ = match (with_normals, t) {
            (true, 0) => writeln!(line, "f {a}//{a} {b}//{b} {c}//{c}"),
            (false, 0) => writeln!(line, "f {a} {b} {c}"),
            (true, t) => writeln!(line, "f {a}/{t}/{a} {b}/{}/{b} {c}/{}/{c}", t + 1, t + 2),
            (false, t) => writeln!(line, "f {a}/{t} {b}/{} {c}/{}", t + 1, t + 2),
        };
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Mesh> {
        parse_obj("t.obj", s.as_bytes())
    }

    #[test]
    fn keeps_vertex_order_and_unused_vertices() {
        // Faces reference vertices out of order, vertex 1 is unused, and
        // faces sit in two groups sharing vertex 3: all vertices stay where
        // the file put them.
        let m = parse(
            "# comment\r\nmtllib x.mtl\r\nv 0 0 0\r\nv 9 9 9\r\nv 1 0 0\r\nv 0 1 0 1.0\r\n\
             g a\r\nusemtl red\r\nf 4 3 1\r\ng b\r\ns 1\r\nf -1 -2 -4 # relative\r\nl 1 2\r\np 2\r\n",
        )
        .unwrap();
        assert_eq!(
            m.vertices,
            vec![
                [0.0, 0.0, 0.0],
                [9.0, 9.0, 9.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0]
            ]
        );
        assert_eq!(m.faces, vec![[3, 2, 0], [3, 2, 0]]);
        assert_eq!(m.normals, None);
        assert_eq!(m.vertex_colors, None);
    }

    #[test]
    fn polygons_colours_texcoords_and_continuation() {
        let m = parse(
            "v 0 0 0 1 0 0\nv 1 0 0 0 0.5 1\nv 1 1 0\nv 0 1 0 \\\n 0.2 0.2 0.2\nvt 0 0\nvt 1 1\n\
             f 1/1 2/2 3/1 4/2\nf 1/1/ 3/2/ 4//\n",
        )
        .unwrap();
        assert_eq!(m.vertices[3], [0.0, 1.0, 0.0]);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
        // 0.5 * 255 = 127.5 rounds to 128; 0.2 * 255 = 51; vertex 2 had no
        // colour and gets opaque white.
        assert_eq!(
            m.vertex_colors,
            Some(vec![
                [255, 0, 0, 255],
                [0, 128, 255, 255],
                [255, 255, 255, 255],
                [51, 51, 51, 255],
            ])
        );
    }

    #[test]
    fn normals_per_vertex_split_when_they_differ() {
        let m = parse(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nvn 0 0 1\nvn 1 0 0\n\
             f 1//1 2//1 3//1\nf 1//2 3//3 4//3\nv 5 5 5\n",
        )
        .unwrap();
        // Vertex 1 (index 0) uses normals 1 and 2, which are equal: no split.
        // Vertex 3 (index 2) uses normals 1 and 3, which differ: a copy is
        // appended after all file vertices (including the late `v 5 5 5`).
        assert_eq!(m.vertices.len(), 6);
        assert_eq!(m.vertices[5], [0.0, 1.0, 0.0]);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 5, 3]]);
        assert_eq!(
            m.normals,
            Some(vec![
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
                [1.0, 0.0, 0.0],
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
            ])
        );
        // Without faces, normals pair with vertices by position when the
        // counts match.
        let m = parse("v 0 0 0\nv 1 1 1\nvn 0 1 0\nvn 1 0 0\n").unwrap();
        assert_eq!(m.normals, Some(vec![[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]));
    }

    fn assert_err(text: &str, needles: &[&str]) {
        let e = parse(text).unwrap_err().to_string();
        assert!(e.starts_with("t.obj: "), "{e}");
        for n in needles {
            assert!(e.contains(n), "'{e}' lacks '{n}'");
        }
    }

    #[test]
    fn malformed_inputs() {
        assert_err("v 0 0\n", &["line 1", "found 2 numbers"]);
        assert_err("v 0 0 0\nv 0 x 0\n", &["line 2", "found 'x'"]);
        assert_err(
            "v 0 0 0\nf 1 1 2\n",
            &["line 2", "corner 2", "out of range"],
        );
        assert_err("v 0 0 0\n\nf 0 1 1\n", &["line 3", "index 0 is invalid"]);
        assert_err("v 0 0 0\nf 1 1 -2\n", &["line 2", "-2 is out of range"]);
        assert_err("v 0 0 0\nf 1//1 1 1\n", &["normal index 1 is out of range"]);
        assert_err("v 0 0 0\nf 1/2 1 1\n", &["texture coordinate index 2"]);
        assert_err("v 0 0 0\nf 1/1/1/1 1 1\n", &["expected `v`"]);
        assert_err("vn 0 0\n", &["line 1", "found 2 numbers"]);
        assert_err("v 0 0 0 \\\n1 2 3 4\n", &["line 1", "found 7"]);
    }

    #[test]
    fn truncation_never_panics() {
        let text = "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 3 2 1\n";
        let full = parse(text).unwrap();
        assert_eq!(full.faces.len(), 2);
        for cut in 0..text.len() {
            // Prefixes of an OBJ file are often valid OBJ files themselves;
            // what matters is a clean result either way.
            match parse(&text[..cut]) {
                Ok(m) => assert!(m.validate().is_ok()),
                Err(e) => assert!(e.to_string().starts_with("t.obj: line "), "{e}"),
            }
        }
    }

    #[test]
    fn writer_layout() {
        let m = Mesh {
            vertices: vec![[0.1, -2.0, 1e-7], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            faces: vec![[0, 1, 2]],
            normals: Some(vec![[0.0, 0.0, 1.0]; 3]),
            vertex_colors: Some(vec![[255, 0, 51, 7]; 3]),
            ..Default::default()
        };
        let mut out = Vec::new();
        write_obj(&mut out, &m, &ObjWriteOptions::default()).unwrap();
        let s = String::from_utf8(out).unwrap();
        let body: Vec<&str> = s.lines().skip(1).collect();
        assert_eq!(
            body,
            [
                "v 0.1 -2 1e-7 1 0 0.2",
                "v 1 0 0 1 0 0.2",
                "v 0 1 0 1 0 0.2",
                "vn 0 0 1",
                "vn 0 0 1",
                "vn 0 0 1",
                "f 1//1 2//2 3//3",
            ]
        );
        let back = parse(&s).unwrap();
        assert_eq!(back.vertices, m.vertices);
        assert_eq!(back.normals, m.normals);
        // OBJ has no alpha.
        assert_eq!(back.vertex_colors, Some(vec![[255, 0, 51, 255]; 3]));
    }

    #[test]
    fn face_colours_are_unshared() {
        let m = Mesh {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
            faces: vec![[0, 1, 2], [2, 1, 3]],
            face_colors: Some(vec![[10, 20, 30, 255], [40, 50, 60, 255]]),
            ..Default::default()
        };
        let mut out = Vec::new();
        write_obj(&mut out, &m, &ObjWriteOptions::default()).unwrap();
        let back = parse(std::str::from_utf8(&out).unwrap()).unwrap();
        assert_eq!(back.faces, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(back.vertices[3], [0.0, 1.0, 0.0]);
        assert_eq!(back.vertex_colors.as_ref().unwrap()[4], [40, 50, 60, 255]);
        assert_eq!(back.vertex_colors.as_ref().unwrap()[2], [10, 20, 30, 255]);
    }

    /// A 2×1 PNG: red on the left, blue on the right.
    fn write_test_png(path: &Path) {
        let mut f = std::fs::File::create(path).unwrap();
        crate::io::image::write_png8(&mut f, "t.png", 2, 1, 3, &[255, 0, 0, 0, 0, 255]).unwrap();
    }

    #[test]
    fn texture_coordinates_materials_and_map_kd() {
        let dir = tempfile::tempdir().unwrap();
        write_test_png(&dir.path().join("my tex.png"));
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl plain\nKd 1 0 0\nnewmtl skin\nKd 1 1 1\nmap_Kd -s 1 1 1 -clamp on my tex.png\n",
        )
        .unwrap();
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                   vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1 0\n\
                   usemtl plain\nf 1/1 2/2 3/3\nusemtl skin\nf 1/1 2/2 3/3 4/4\n";
        let m = parse_obj_in("t.obj", obj.as_bytes(), dir.path()).unwrap();
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 1, 2], [0, 2, 3]]);
        let uvs = m.uvs.as_ref().unwrap();
        // the first face's material has no image: no texture there
        assert!(uvs[0][0][0].is_nan());
        assert_eq!(uvs[1], [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]);
        assert_eq!(uvs[2], [[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        let t = m.texture.as_ref().unwrap();
        assert_eq!((t.width, t.height, t.name.as_str()), (2, 1, "my tex.png"));
        assert_eq!(t.pixels, vec![[255, 0, 0], [0, 0, 255]]);
        // without a folder to look in: coordinates kept, no texture
        let m = parse(obj).unwrap();
        assert!(m.texture.is_none());
        assert_eq!(m.uvs.as_ref().unwrap()[1][2], [1.0, 1.0]);
        // a missing MTL is not an error
        let m = parse_obj_in(
            "t.obj",
            obj.replace("m.mtl", "gone.mtl").as_bytes(),
            dir.path(),
        )
        .unwrap();
        assert!(m.texture.is_none() && m.uvs.is_some());
        assert_err("vt\n", &["line 1", "no numbers"]);
        assert_err("vt 0 0 0 0\n", &["line 1", "more than 3"]);
    }

    /// The inventory: `mtllib` resolved or not found, materials in order of
    /// use with their face counts and maps (options skipped), a material
    /// used but defined nowhere, one defined but unused, and texture files
    /// with whether they exist.
    #[test]
    fn inventory_lists_libraries_materials_and_texture_files() {
        let dir = tempfile::tempdir().unwrap();
        write_test_png(&dir.path().join("my tex.png"));
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl plain\nKd 1 0 0\nnewmtl skin\nmap_Kd -s 1 1 1 -clamp on my tex.png\n\
             bump -bm 0.5 bumps.png\nnewmtl spare\nmap_Ks my tex.png\n",
        )
        .unwrap();
        let obj = "mtllib m.mtl\nmtllib lost.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                   vt 0 0\nvt 1 0\nvt 1 1\nusemtl skin\nf 1/1 2/2 3/3 4/3\n\
                   usemtl plain\nf 1 2 3\nusemtl ghost\nf 1 3 4\n";
        let (m, inv) = parse_obj_inventory("t.obj", obj.as_bytes(), dir.path()).unwrap();
        assert_eq!(m.faces.len(), 4);
        assert!(m.texture.is_some());
        assert_eq!(
            inv.mtllibs,
            [
                ("m.mtl".to_string(), Some(dir.path().join("m.mtl"))),
                ("lost.mtl".to_string(), None)
            ]
        );
        let names: Vec<(&str, usize, bool)> = inv
            .materials
            .iter()
            .map(|m| (m.name.as_str(), m.used_by, m.defined))
            .collect();
        assert_eq!(
            names,
            [
                ("skin", 2, true),
                ("plain", 1, true),
                ("ghost", 1, false),
                ("spare", 0, true)
            ]
        );
        let tex = dir.path().join("my tex.png").display().to_string();
        let bumps = dir.path().join("bumps.png").display().to_string();
        let skin = &inv.materials[0].textures;
        assert_eq!(
            (skin[0].slot.as_str(), skin[0].file.as_str()),
            ("map_Kd", tex.as_str())
        );
        assert_eq!(
            (skin[1].slot.as_str(), skin[1].file.as_str()),
            ("bump", bumps.as_str())
        );
        assert_eq!(inv.materials[3].textures[0].slot, "map_Ks");
        let files: Vec<(&str, bool)> = inv
            .textures
            .iter()
            .map(|t| (t.file.as_str(), t.exists))
            .collect();
        assert_eq!(files, [(tex.as_str(), true), (bumps.as_str(), false)]);
    }

    #[test]
    fn textured_obj_round_trip_writes_three_files() {
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("in.png");
        write_test_png(&png);
        let tex = read_texture(&png).unwrap();
        let m = Mesh {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
            faces: vec![[0, 1, 2], [2, 1, 3]],
            normals: Some(vec![[0.0, 0.0, 1.0]; 4]),
            uvs: Some(vec![
                [[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]],
                [[f32::NAN; 2]; 3],
            ]),
            texture: Some(Box::new(tex.clone())),
            ..Default::default()
        };
        let out = dir.path().join("out.obj");
        crate::io::any::save_mesh(
            &out,
            &m,
            crate::io::detect::FileFormat::Obj,
            &Default::default(),
        )
        .unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(text.contains("mtllib out.mtl\n"), "{text}");
        assert!(
            text.contains("f 1/1/1 2/2/2 3/3/3\nf 3//3 2//2 4//4\n"),
            "{text}"
        );
        let mtl = std::fs::read_to_string(dir.path().join("out.mtl")).unwrap();
        assert!(mtl.contains("map_Kd out.png"), "{mtl}");
        let back = read_obj(&out).unwrap();
        assert_eq!(back.texture.as_ref().unwrap().pixels, tex.pixels);
        assert_eq!(back.uvs.as_ref().unwrap()[0], m.uvs.as_ref().unwrap()[0]);
        assert!(back.uvs.as_ref().unwrap()[1][0][0].is_nan());
        assert_eq!(back.faces, m.faces);
    }
}
