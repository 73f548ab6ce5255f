//! Wavefront OBJ meshes (geometry only: positions, normals, vertex colours,
//! faces; materials and texture coordinates are ignored).
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
//! - `vn` lines give normals; `vt` lines are counted (so face indices can be
//!   checked) and otherwise ignored.
//! - `f` corners are `v`, `v/vt`, `v//vn` or `v/vt/vn`, 1-based, or negative
//!   (relative to the vertices / normals defined so far). Polygons are
//!   fan-triangulated (`a b c`, `a c d`, …); faces with fewer than 3 corners
//!   give nothing. `l`, `p`, groups, objects, smoothing groups, materials and
//!   every other statement are ignored; all groups go into one mesh.
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
//! alpha and no per-face colours; see [`ObjWriteOptions`].

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use crate::io::off::{push_f32_shortest, write_lines_par};
use crate::io::source::werr;
use crate::model::Mesh;
use crate::{Error, Result};

/// Reads an OBJ file (`-` = stdin). See the module documentation.
pub fn read_obj(path: &Path) -> Result<Mesh> {
    let input = crate::io::read_input(path)?;
    parse_obj(&input.name, &input)
}

/// Parses the bytes of an OBJ file; `name` is used in error messages.
pub fn parse_obj(name: &str, bytes: &[u8]) -> Result<Mesh> {
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
    n_texcoords: usize,
    faces: Vec<[u32; 3]>,
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
            b"vt" => self.n_texcoords += 1,
            b"f" => {
                let mut corners: Vec<u32> = Vec::with_capacity(4);
                for (k, t) in toks.enumerate() {
                    corners.push(
                        self.corner(t)
                            .map_err(|m| format!("face corner {k}: {m}"))?,
                    );
                }
                for k in 2..corners.len().max(2) {
                    self.faces.push([corners[0], corners[k - 1], corners[k]]);
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// Resolves one `v[/vt[/vn]]` corner to a mesh vertex.
    fn corner(&mut self, t: &[u8]) -> std::result::Result<u32, String> {
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
            resolve(vt, self.n_texcoords, "texture coordinate")?;
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

    fn finish(mut self) -> std::result::Result<Mesh, String> {
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
        Ok(Mesh {
            vertices: self.vertices,
            faces: self.faces,
            normals,
            vertex_colors: self.colors,
            ..Default::default()
        })
    }
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

/// Writes `mesh` as OBJ (see the module documentation and
/// [`ObjWriteOptions`]). Scalars and extras are not written. Non-finite
/// coordinates are written as they are (`inf`, `-inf`, `NaN`); this reader
/// accepts them, most others do not.
///
/// Errors: the mesh fails [`Mesh::validate`], or writing fails.
pub fn write_obj(w: &mut dyn Write, mesh: &Mesh, opts: &ObjWriteOptions) -> Result<()> {
    mesh.validate()
        .map_err(|e| Error::invalid(format!("cannot write OBJ: {e}")))?;
    if opts.colors && mesh.vertex_colors.is_none() && mesh.face_colors.is_some() {
        let soup = crate::io::gltf::face_colors_to_corners(mesh);
        return write_obj_validated(w, &soup, opts);
    }
    write_obj_validated(w, mesh, opts)
}

fn write_obj_validated(w: &mut dyn Write, mesh: &Mesh, opts: &ObjWriteOptions) -> Result<()> {
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
    let with_normals = normals.is_some();
    write_lines_par(w, &mesh.faces, |line, _, f| {
        let [a, b, c] = f.map(|i| u64::from(i) + 1);
        // Writing into a String cannot fail.
        let _ = if with_normals {
            writeln!(line, "f {a}//{a} {b}//{b} {c}//{c}")
        } else {
            writeln!(line, "f {a} {b} {c}")
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
}
