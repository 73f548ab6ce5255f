//! The OFF reader: a line-aware tokenizer over the file's bytes.

use std::path::Path;

use crate::model::Mesh;
use crate::{Error, Result};

/// Reads an OFF-family file (`-` = stdin). See the module documentation.
pub fn read_off(path: &Path) -> Result<Mesh> {
    let input = crate::io::read_input(path)?;
    parse_off(&input.name, &input)
}

/// Parses the bytes of an OFF-family file; `name` is used in error messages.
pub fn parse_off(name: &str, bytes: &[u8]) -> Result<Mesh> {
    Parser::new(name, bytes).parse()
}

/// A line-aware token reader over the file's bytes.
struct Parser<'a> {
    name: &'a str,
    bytes: &'a [u8],
    /// Byte offset of the next unread line.
    pos: usize,
    /// 1-based number of the line whose tokens are in `toks`.
    line: usize,
    /// Line number of the next unread line.
    next_line_no: usize,
    /// Tokens of the current line, and how many of them were consumed.
    toks: Vec<&'a [u8]>,
    used: usize,
}

/// What the header keyword announces.
#[derive(Clone, Copy, Default)]
struct Flags {
    texture: bool,
    color: bool,
    normal: bool,
}

impl<'a> Parser<'a> {
    fn new(name: &'a str, bytes: &'a [u8]) -> Self {
        Parser {
            name,
            bytes,
            pos: 0,
            line: 0,
            next_line_no: 1,
            toks: Vec::new(),
            used: 0,
        }
    }

    fn err(&self, msg: impl std::fmt::Display) -> Error {
        Error::format(self.name, format!("line {}: {msg}", self.line))
    }

    fn eof_err(&self, expected: impl std::fmt::Display) -> Error {
        Error::format(
            self.name,
            format!(
                "unexpected end of file after line {}: expected {expected}",
                self.line
            ),
        )
    }

    /// Loads the next line that has tokens; false at end of file.
    fn next_line(&mut self) -> bool {
        while self.pos < self.bytes.len() {
            let rest = &self.bytes[self.pos..];
            let end = rest.iter().position(|&b| b == b'\n');
            let raw = match end {
                Some(e) => &rest[..e],
                None => rest,
            };
            self.pos += raw.len() + usize::from(end.is_some());
            self.line = self.next_line_no;
            self.next_line_no += 1;
            let content = match raw.iter().position(|&b| b == b'#') {
                Some(c) => &raw[..c],
                None => raw,
            };
            self.toks.clear();
            self.used = 0;
            self.toks.extend(
                content
                    .split(|b| b.is_ascii_whitespace())
                    .filter(|t| !t.is_empty()),
            );
            if !self.toks.is_empty() {
                return true;
            }
        }
        false
    }

    /// Tokens left on the current line.
    fn left_on_line(&self) -> usize {
        self.toks.len() - self.used
    }

    /// The next token, moving to later lines as needed.
    fn token(&mut self, expected: &dyn std::fmt::Display) -> Result<&'a [u8]> {
        while self.used == self.toks.len() {
            if !self.next_line() {
                return Err(self.eof_err(expected));
            }
        }
        let t = self.toks[self.used];
        self.used += 1;
        Ok(t)
    }

    fn f32_token(&mut self, expected: &dyn std::fmt::Display) -> Result<f32> {
        let t = self.token(expected)?;
        parse_num::<f32>(t).ok_or_else(|| {
            self.err(format_args!(
                "expected {expected} (a number), found '{}'",
                String::from_utf8_lossy(t)
            ))
        })
    }

    fn usize_token(&mut self, expected: &dyn std::fmt::Display) -> Result<usize> {
        let t = self.token(expected)?;
        parse_num::<usize>(t).ok_or_else(|| {
            self.err(format_args!(
                "expected {expected} (a non-negative integer), found '{}'",
                String::from_utf8_lossy(t)
            ))
        })
    }

    /// Parses `n` colour tokens (3 or 4) from the current line.
    fn color(&mut self, n: usize, what: &dyn std::fmt::Display) -> Result<[u8; 4]> {
        let toks = &self.toks[self.used..self.used + n];
        self.used += n;
        let mut c = [255u8; 4];
        let ints: Option<Vec<u32>> = toks.iter().map(|t| parse_num::<u32>(t)).collect();
        if let Some(ints) = ints {
            for (k, &v) in ints.iter().enumerate() {
                c[k] = u8::try_from(v).map_err(|_| {
                    self.err(format_args!(
                        "{what}: integer colour component {v} is outside 0..=255"
                    ))
                })?;
            }
        } else {
            for (k, t) in toks.iter().enumerate() {
                let v = parse_num::<f32>(t).filter(|v| v.is_finite()).ok_or_else(|| {
                    self.err(format_args!(
                        "{what}: expected a colour component (integer 0-255 or float 0-1), found '{}'",
                        String::from_utf8_lossy(t)
                    ))
                })?;
                c[k] = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
            }
        }
        Ok(c)
    }

    fn parse(mut self) -> Result<Mesh> {
        if !self.next_line() {
            return Err(Error::format(
                self.name,
                "empty file: expected an OFF header",
            ));
        }
        let first = self.toks[0];
        let flags = if parse_num::<usize>(first).is_some() {
            Flags::default()
        } else {
            self.used = 1;
            parse_keyword(first).ok_or_else(|| {
                self.err(format_args!(
                    "expected an OFF header keyword ([ST][C][N]OFF), found '{}'",
                    String::from_utf8_lossy(first)
                ))
            })?
        };
        let nv = self.usize_token(&"the vertex count in the header")?;
        let nf = self.usize_token(&"the face count in the header")?;
        // The edge count is optional and ignored; skip it when it is on the
        // same line as the face count.
        if self.left_on_line() > 0 {
            self.usize_token(&"the edge count in the header")?;
        }
        if self.left_on_line() > 0 {
            return Err(self.err("expected the counts `V F E` alone on the header line"));
        }
        // A vertex needs at least 3 one-byte tokens and their separators
        // ("0 0 0\n"), a face record at least a count and a separator.
        let left = (self.bytes.len() - self.pos) as u128 + 1;
        let need = 6 * nv as u128 + 2 * nf as u128;
        if need > left {
            return Err(self.err(format_args!(
                "the header declares {nv} vertices and {nf} faces, which need at least {need} bytes, but only {} remain",
                left - 1
            )));
        }

        let mut vertices = Vec::with_capacity(nv);
        let mut normals = flags.normal.then(|| Vec::with_capacity(nv));
        let mut vcolors: Option<Vec<[u8; 4]>> = None;
        let base = if flags.normal { 6 } else { 3 };
        let st = if flags.texture { 2 } else { 0 };
        for i in 0..nv {
            let what = VertexWhat(i, nv, flags.normal);
            let mut vals = [0f32; 6];
            for v in vals.iter_mut().take(base) {
                *v = self.f32_token(&what)?;
            }
            vertices.push([vals[0], vals[1], vals[2]]);
            if let Some(n) = normals.as_mut() {
                n.push([vals[3], vals[4], vals[5]]);
            }
            if flags.color {
                let extra = self.left_on_line().saturating_sub(st);
                if extra == 3 || extra == 4 {
                    let c = self.color(extra, &what)?;
                    vcolors.get_or_insert_with(|| vec![[255; 4]; i]).push(c);
                } else if extra == 0 {
                    if let Some(vc) = vcolors.as_mut() {
                        vc.push([255; 4]);
                    }
                } else {
                    return Err(self.err(format_args!(
                        "{what}: expected 0, 3 or 4 colour components after the coordinates, found {extra} tokens"
                    )));
                }
            }
            for _ in 0..st {
                self.f32_token(&format_args!("{what}: texture coordinate"))?;
            }
        }

        let mut faces: Vec<[u32; 3]> = Vec::with_capacity(nf);
        let mut fcolors: Option<Vec<[u8; 4]>> = None;
        for i in 0..nf {
            let what = FaceWhat(i, nf);
            let n = self.usize_token(&format_args!("{what}: the vertex count"))?;
            // Each index needs at least two bytes; checking first keeps a
            // corrupt count from allocating.
            if n > (self.bytes.len() - self.pos) / 2 + self.left_on_line() {
                return Err(self.err(format_args!(
                    "{what}: a polygon of {n} vertices does not fit in the rest of the file"
                )));
            }
            let mut idx = Vec::with_capacity(n);
            for k in 0..n {
                let v = self.usize_token(&format_args!("{what}: vertex index {k}"))?;
                if v >= nv {
                    return Err(self.err(format_args!(
                        "{what}: vertex index {v} is out of range (the file has {nv} vertices)"
                    )));
                }
                idx.push(v as u32);
            }
            let extra = self.left_on_line();
            let color = match extra {
                0 => None,
                // A colour-map index: Geomview's default map is not defined
                // here, so it is ignored.
                1 => {
                    self.used += 1;
                    None
                }
                3 | 4 => Some(self.color(extra, &what)?),
                _ => {
                    return Err(self.err(format_args!(
                        "{what}: expected 0, 1, 3 or 4 colour tokens after the {n} indices, found {extra}"
                    )));
                }
            };
            let before = faces.len();
            for k in 2..n.max(2) {
                faces.push([idx[0], idx[k - 1], idx[k]]);
            }
            let added = faces.len() - before;
            match color {
                Some(c) => {
                    let fc = fcolors.get_or_insert_with(|| vec![[255; 4]; before]);
                    fc.extend(std::iter::repeat_n(c, added));
                }
                None => {
                    if let Some(fc) = fcolors.as_mut() {
                        fc.extend(std::iter::repeat_n([255; 4], added));
                    }
                }
            }
        }
        let mesh = Mesh {
            vertices,
            faces,
            normals,
            vertex_colors: vcolors,
            face_colors: fcolors,
            ..Default::default()
        };
        debug_assert!(mesh.validate().is_ok());
        Ok(mesh)
    }
}

/// Parses `[ST][C][N]OFF`.
fn parse_keyword(t: &[u8]) -> Option<Flags> {
    let mut f = Flags::default();
    let mut rest = t;
    if let Some(r) = rest.strip_prefix(b"ST") {
        f.texture = true;
        rest = r;
    }
    if let Some(r) = rest.strip_prefix(b"C") {
        f.color = true;
        rest = r;
    }
    if let Some(r) = rest.strip_prefix(b"N") {
        f.normal = true;
        rest = r;
    }
    (rest == b"OFF").then_some(f)
}

fn parse_num<T: std::str::FromStr>(t: &[u8]) -> Option<T> {
    std::str::from_utf8(t).ok()?.parse().ok()
}

/// "vertex i of n (x y z)" for messages.
struct VertexWhat(usize, usize, bool);
impl std::fmt::Display for VertexWhat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let fields = if self.2 { "x y z nx ny nz" } else { "x y z" };
        write!(f, "vertex {} of {} ({fields})", self.0, self.1)
    }
}

/// "face i of n" for messages.
struct FaceWhat(usize, usize);
impl std::fmt::Display for FaceWhat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "face {} of {}", self.0, self.1)
    }
}
