//! Geomview OFF meshes and their variants (`OFF`, `COFF`, `NOFF`, `CNOFF`,
//! `STOFF`, …), including the per-face colour layout that Triangle Splatting's
//! `create_off.py` writes.
//!
//! # Reading
//! The reader is free-format where the format allows it: `#` starts a comment
//! that runs to the end of the line, blank lines are skipped, line ends may be
//! LF or CRLF, and the header counts or a record may be spread over several
//! lines. The header keyword is `[ST][C][N]OFF` (the 4D `4OFF` and `nOFF`
//! variants are refused); a file that starts directly with its counts is read
//! as plain `OFF`. The counts are `V F [E]`; `E` is ignored.
//!
//! Vertex records are `x y z [nx ny nz] [r g b [a]] [s t]`: normals when the
//! keyword has `N`, texture coordinates (skipped) with `ST`. Colours are
//! recognised when the keyword has `C` and are optional per vertex, because
//! Triangle Splatting writes `COFF` files whose vertices carry no colour (its
//! colours are on the faces). Colours are either all integers 0–255 or floats
//! 0–1 (scaled by 255 and rounded); a missing alpha is 255. A vertex without a
//! colour in a file where other vertices have one gets opaque white.
//!
//! Face records are `n i1 … in [r g b [a]]`, one per line: polygons are
//! fan-triangulated (`i1 i2 i3`, `i1 i3 i4`, …) and every triangle inherits the
//! polygon's colour. The colour is whatever follows the indices on the same
//! line: nothing, a single colour-map index (ignored: there is no colour map),
//! or 3–4 components as for vertices. Faces with fewer than 3 vertices yield no
//! triangle. Anything after the last face is ignored.
//!
//! Errors name the file and line and say what was expected. Declared counts
//! are checked against the bytes left in the file before anything is allocated
//! from them.
//!
//! # Writing
//! See [`OffWriteOptions`]; [`OffWriteOptions::triangle_splatting`] gives the
//! byte layout of `create_off.py`.

use std::io::Write;
use std::path::Path;

use crate::io::source::werr;
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

/// The header keyword the writer puts on line 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OffHeader {
    /// `OFF`.
    #[default]
    Off,
    /// `COFF` (Geomview: per-vertex colours; Triangle Splatting also uses it
    /// for files whose colours are on the faces).
    Coff,
}

/// How the writer prints vertex coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FloatStyle {
    /// The shortest text that parses back to the same `f32` (see
    /// [`format_f32_shortest`]).
    #[default]
    Shortest,
    /// The `f32` widened to `f64` and printed as Python's `repr(float)` does
    /// (see [`python_float_repr`]), as `create_off.py` writes it.
    PythonRepr,
}

/// Options of [`write_off`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct OffWriteOptions {
    /// Header keyword.
    pub header: OffHeader,
    /// Append `r g b a` (integers 0–255) to every vertex line. The mesh must
    /// have vertex colours.
    pub vertex_colors: bool,
    /// Append `r g b a` (integers 0–255) to every face line. The mesh must
    /// have face colours.
    pub face_colors: bool,
    /// With `face_colors`: write each face's alpha; otherwise alpha is 255.
    pub face_alpha: bool,
    /// Vertex coordinate formatting.
    pub float_style: FloatStyle,
}

impl OffWriteOptions {
    /// The layout of Triangle Splatting's `create_off.py`: `COFF`, `V F 0`,
    /// vertex lines `x y z` in Python `repr`, face lines `3 i j k r g b 255`.
    pub fn triangle_splatting() -> Self {
        OffWriteOptions {
            header: OffHeader::Coff,
            vertex_colors: false,
            face_colors: true,
            face_alpha: false,
            float_style: FloatStyle::PythonRepr,
        }
    }

    /// Options that write every colour `mesh` has (with alpha): header `COFF`
    /// when it has vertex colours, else `OFF`; shortest floats.
    pub fn for_mesh(mesh: &Mesh) -> Self {
        OffWriteOptions {
            header: if mesh.vertex_colors.is_some() {
                OffHeader::Coff
            } else {
                OffHeader::Off
            },
            vertex_colors: mesh.vertex_colors.is_some(),
            face_colors: mesh.face_colors.is_some(),
            face_alpha: true,
            float_style: FloatStyle::Shortest,
        }
    }
}

/// Writes `mesh` as OFF: line 1 the header keyword, line 2 `V F 0`, then one
/// line per vertex and one `3 i j k` line per face (0-based indices), with
/// colours as `opts` asks. Normals, scalars and extras are not written.
/// Non-finite coordinates are written as they are (`inf`, `-inf`, `NaN` with
/// [`FloatStyle::Shortest`]; `inf`, `-inf`, `nan` with
/// [`FloatStyle::PythonRepr`]); most other readers reject them.
///
/// Errors: the mesh fails [`Mesh::validate`], a colour kind is requested that
/// the mesh lacks, or writing fails.
pub fn write_off(w: &mut dyn Write, mesh: &Mesh, opts: &OffWriteOptions) -> Result<()> {
    mesh.validate()
        .map_err(|e| Error::invalid(format!("cannot write OFF: {e}")))?;
    let vcol = match (opts.vertex_colors, &mesh.vertex_colors) {
        (false, _) => None,
        (true, Some(c)) => Some(c),
        (true, None) => {
            return Err(Error::invalid(
                "cannot write OFF vertex colours: the mesh has none",
            ));
        }
    };
    let fcol = match (opts.face_colors, &mesh.face_colors) {
        (false, _) => None,
        (true, Some(c)) => Some(c),
        (true, None) => {
            return Err(Error::invalid(
                "cannot write OFF face colours: the mesh has none",
            ));
        }
    };
    let keyword = match opts.header {
        OffHeader::Off => "OFF",
        OffHeader::Coff => "COFF",
    };
    writeln!(w, "{keyword}").map_err(werr)?;
    writeln!(w, "{} {} 0", mesh.vertices.len(), mesh.faces.len()).map_err(werr)?;
    use std::fmt::Write as _;
    write_lines_par(w, &mesh.vertices, |line, i, v| {
        for (k, &x) in v.iter().enumerate() {
            if k > 0 {
                line.push(' ');
            }
            match opts.float_style {
                FloatStyle::Shortest => push_f32_shortest(line, x),
                FloatStyle::PythonRepr => python_float_repr_into(f64::from(x), line),
            }
        }
        if let Some(c) = vcol {
            let c = c[i];
            // Writing into a String cannot fail.
            let _ = write!(line, " {} {} {} {}", c[0], c[1], c[2], c[3]);
        }
        line.push('\n');
    })?;
    write_lines_par(w, &mesh.faces, |line, i, f| {
        let _ = write!(line, "3 {} {} {}", f[0], f[1], f[2]);
        if let Some(c) = fcol {
            let c = c[i];
            let a = if opts.face_alpha { c[3] } else { 255 };
            let _ = write!(line, " {} {} {} {a}", c[0], c[1], c[2]);
        }
        line.push('\n');
    })?;
    Ok(())
}

/// Formats `items` in parallel (blocks of lines, in order) with `f(out,
/// index, item)`, which appends one or more complete lines to `out`, and
/// writes them to `w` in order. Memory stays bounded: a batch of blocks is
/// written before the next is formatted.
pub(crate) fn write_lines_par<T: Sync>(
    w: &mut dyn Write,
    items: &[T],
    f: impl Fn(&mut String, usize, &T) + Sync,
) -> Result<()> {
    use rayon::prelude::*;
    const BLOCK: usize = 16 * 1024;
    const BATCH: usize = 64 * BLOCK;
    for (b, batch) in items.chunks(BATCH).enumerate() {
        let texts: Vec<String> = batch
            .par_chunks(BLOCK)
            .enumerate()
            .map(|(c, block)| {
                let mut s = String::with_capacity(block.len() * 40);
                let first = b * BATCH + c * BLOCK;
                for (k, item) in block.iter().enumerate() {
                    f(&mut s, first + k, item);
                }
                s
            })
            .collect();
        for t in &texts {
            w.write_all(t.as_bytes()).map_err(werr)?;
        }
    }
    Ok(())
}

/// The shortest decimal digits that parse back to exactly `x` (Rust's
/// shortest round-trip algorithm), printed positionally (`{}`: `0.1`, `100`,
/// `-2.5`) when 1e-5 ≤ |x| < 1e16 or x = 0, else in exponent form (`{:e}`:
/// `1e-7`, `3.4028235e38`) so that no number is longer than 17
/// characters. Non-finite values print as `inf`, `-inf`, `NaN`.
pub fn format_f32_shortest(x: f32) -> String {
    let mut s = String::with_capacity(16);
    push_f32_shortest(&mut s, x);
    s
}

/// [`format_f32_shortest`] appending to `out`.
pub fn push_f32_shortest(out: &mut String, x: f32) {
    use std::fmt::Write as _;
    let a = x.abs();
    // Writing into a String cannot fail.
    let _ = if x == 0.0 || !x.is_finite() || (1e-5..1e16).contains(&a) {
        write!(out, "{x}")
    } else {
        write!(out, "{x:e}")
    };
}

/// Formats `x` exactly as Python 3's `repr(float)` does: the shortest digits
/// that round-trip, positional when the decimal exponent `e` (of
/// `d.ddd × 10^e`) satisfies −4 ≤ e < 16, always with a fractional part
/// (`1.0`, `-0.0`, `100.0`, `0.0001`); otherwise exponent form with the
/// exponent signed and at least two digits (`1e-05`, `1.5e+16`,
/// `1.2345678901234568e+17`). Non-finite values print as `inf`, `-inf`, `nan`.
pub fn python_float_repr(x: f64) -> String {
    let mut out = String::with_capacity(24);
    python_float_repr_into(x, &mut out);
    out
}

/// [`python_float_repr`] appending to `out` (no allocation when `out` has
/// room).
pub fn python_float_repr_into(x: f64, out: &mut String) {
    use std::fmt::Write as _;
    if x.is_nan() {
        out.push_str("nan");
        return;
    }
    if x.is_infinite() {
        out.push_str(if x > 0.0 { "inf" } else { "-inf" });
        return;
    }
    // `{:e}` gives the shortest round-trip digits as `[-]d[.ddd]e[-]N`.
    let start = out.len();
    // Writing into a String cannot fail.
    let _ = write!(out, "{x:e}");
    let (mut digits, mut n, mut exp) = split_sci(&out[start..]);
    // When two strings of that length round-trip because `x` lies exactly
    // halfway between them, Python (David Gay's dtoa) takes the even one
    // and Rust may take the other: redo those with the correctly rounded
    // (ties-to-even) value at that many significant digits.
    if is_decimal_tie(x, n) {
        out.truncate(start);
        let _ = write!(out, "{x:.*e}", n - 1);
        (digits, n, exp) = split_sci(&out[start..]);
        while n > 1 && digits[n - 1] == b'0' {
            n -= 1;
        }
    }
    out.truncate(start);
    let digits = &digits[..n];
    // The digits are ASCII, so this never falls back.
    let digits = std::str::from_utf8(digits).unwrap_or("0");
    if x.is_sign_negative() {
        out.push('-');
    }
    if (-4..16).contains(&exp) {
        if exp >= 0 {
            let int_len = exp as usize + 1;
            if n <= int_len {
                out.push_str(digits);
                out.extend(std::iter::repeat_n('0', int_len - n));
                out.push_str(".0");
            } else {
                out.push_str(&digits[..int_len]);
                out.push('.');
                out.push_str(&digits[int_len..]);
            }
        } else {
            out.push_str("0.");
            out.extend(std::iter::repeat_n('0', (-exp - 1) as usize));
            out.push_str(digits);
        }
    } else {
        out.push_str(&digits[..1]);
        if n > 1 {
            out.push('.');
            out.push_str(&digits[1..]);
        }
        let _ = write!(
            out,
            "e{}{:02}",
            if exp < 0 { '-' } else { '+' },
            exp.unsigned_abs()
        );
    }
}

/// Splits Rust's `[-]d[.ddd]e[-]N` into (digits, digit count, exponent).
fn split_sci(s: &str) -> ([u8; 40], usize, i32) {
    let s = s.strip_prefix('-').unwrap_or(s);
    let (mant, exp) = s.split_once('e').unwrap_or((s, "0"));
    let mut digits = [b'0'; 40];
    let mut n = 0;
    for b in mant.bytes().filter(u8::is_ascii_digit) {
        if n < digits.len() {
            digits[n] = b;
            n += 1;
        }
    }
    (digits, n.max(1), exp.parse().unwrap_or(0))
}

/// True when the exact decimal expansion of `x` (finite, non-zero) has
/// exactly `n + 1` significant digits, the last a 5: `x` is then halfway
/// between two `n`-digit decimals. Every finite double is `m · 2^q` (`m`
/// odd), whose expansion is the integer `m · 5^-q` shifted (q < 0) or
/// `m · 2^q` (q ≥ 0).
fn is_decimal_tie(x: f64, n: usize) -> bool {
    let bits = x.abs().to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let frac = bits & ((1 << 52) - 1);
    let (m, q) = if biased == 0 {
        (frac, -1074)
    } else {
        (frac | (1 << 52), biased - 1075)
    };
    if m == 0 {
        return false;
    }
    let tz = m.trailing_zeros();
    let (m, q) = (m >> tz, q + tz as i32);
    let v = if q < 0 {
        // Beyond 5^55 the product exceeds u128: over 38 significant digits,
        // never a tie at n ≤ 17.
        let k = (-q) as u32;
        if k > 55 {
            return false;
        }
        match u128::from(m).checked_mul(5u128.pow(k)) {
            Some(v) => v,
            None => return false,
        }
    } else if q < 75 {
        let mut v = u128::from(m) << q;
        while v % 10 == 0 {
            v /= 10;
        }
        v
    } else {
        // Too large for u128; rare enough to always take the exact path.
        return true;
    };
    // n + 1 significant digits: 10^n ≤ v < 10^(n+1), and the last is a 5.
    n < 38 && v >= 10u128.pow(n as u32) && (n == 37 || v < 10u128.pow(n as u32 + 1)) && v % 10 == 5
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

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Mesh> {
        parse_off("t.off", s.as_bytes())
    }

    fn write_string(mesh: &Mesh, opts: &OffWriteOptions) -> String {
        let mut out = Vec::new();
        write_off(&mut out, mesh, opts).unwrap();
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn python_repr_matches_cpython() {
        // Expected strings printed by CPython 3.11 `repr(float)`; the f32
        // cases by `repr(struct.unpack('f', struct.pack('f', x))[0])`.
        let cases: &[(f64, &str)] = &[
            (0.1f32 as f64, "0.10000000149011612"),
            (0.2f32 as f64, "0.20000000298023224"),
            (0.3f32 as f64, "0.30000001192092896"),
            (1e-5, "1e-05"),
            (1e-5f32 as f64, "9.999999747378752e-06"),
            (1e16f32 as f64, "1.0000000272564224e+16"),
            (1e15f32 as f64, "999999986991104.0"),
            (9.5e15f32 as f64, "9499999507316736.0"),
            (1.2e16f32 as f64, "1.2000000112328704e+16"),
            (1e-4f32 as f64, "9.999999747378752e-05"),
            (7e-4f32 as f64, "0.000699999975040555"),
            (12345.678f32 as f64, "12345.677734375"),
            // Exactly halfway between two 16-digit strings that both round-trip:
            // Python takes the even one, Rust's shortest `{:e}` the other.
            // (the value is exactly 966.76934814453125).
            (f64::from_bits(4651715008936280064), "966.7693481445312"),
            (5e-324, "5e-324"),
            (123456789012345678.0, "1.2345678901234568e+17"),
            (1.0, "1.0"),
            (3.0, "3.0"),
            (100.0, "100.0"),
            (65504.0, "65504.0"),
            (-1.25, "-1.25"),
            (0.0001, "0.0001"),
            (-2.5e-7, "-2.5e-07"),
            (-2.5e-7f32 as f64, "-2.499999993688107e-07"),
            (1e16, "1e+16"),
            (0.0, "0.0"),
            (-0.0, "-0.0"),
            (f32::MAX as f64, "3.4028234663852886e+38"),
            (f32::from_bits(1) as f64, "1.401298464324817e-45"),
            (f64::INFINITY, "inf"),
            (f64::NEG_INFINITY, "-inf"),
            (f64::NAN, "nan"),
        ];
        for &(x, want) in cases {
            assert_eq!(python_float_repr(x), want, "repr of {x:e}");
        }
    }

    #[test]
    fn shortest_round_trips() {
        for x in [
            0.1f32,
            -0.0,
            1e-7,
            f32::MAX,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            123456.79,
            -1.2345678e-5,
            -9.999999e15,
            9.99e15,
            1e16,
        ] {
            let s = format_f32_shortest(x);
            assert_eq!(s.parse::<f32>().unwrap().to_bits(), x.to_bits(), "{s}");
            // 16 digits plus a sign at most (positional just below 1e16).
            assert!(s.len() <= 17, "{s} is long");
        }
    }

    #[test]
    fn triangle_splatting_golden() {
        // Two independent triangles (V = 6), face colours with alpha values
        // that compatibility mode must replace by 255. The expected text is
        // written from the create_off.py description, not from the writer:
        // `COFF`, `V F 0`, Python repr of the f32 values widened to f64,
        // `3 i j k r g b 255`.
        let mesh = Mesh {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.1, 0.2, 0.3],
                [-2.5, 1e-5, 1e16],
                [100.0, -0.0, 7e-4],
            ],
            faces: vec![[0, 1, 2], [3, 4, 5]],
            face_colors: Some(vec![[255, 0, 0, 10], [12, 34, 56, 200]]),
            ..Default::default()
        };
        let golden = "COFF\n\
                      6 2 0\n\
                      0.0 0.0 0.0\n\
                      1.0 0.0 0.0\n\
                      0.0 1.0 0.0\n\
                      0.10000000149011612 0.20000000298023224 0.30000001192092896\n\
                      -2.5 9.999999747378752e-06 1.0000000272564224e+16\n\
                      100.0 -0.0 0.000699999975040555\n\
                      3 0 1 2 255 0 0 255\n\
                      3 3 4 5 12 34 56 255\n";
        let opts = OffWriteOptions::triangle_splatting();
        assert_eq!(write_string(&mesh, &opts), golden);
        // And it reads back to the same mesh (alpha 255 as written).
        let back = parse(golden).unwrap();
        assert_eq!(back.vertices.len(), 6);
        for (a, b) in back.vertices.iter().zip(&mesh.vertices) {
            for k in 0..3 {
                assert_eq!(a[k].to_bits(), b[k].to_bits());
            }
        }
        assert_eq!(back.faces, mesh.faces);
        assert_eq!(
            back.face_colors,
            Some(vec![[255, 0, 0, 255], [12, 34, 56, 255]])
        );
        assert_eq!(back.vertex_colors, None);
        // With face_alpha the alpha is kept.
        let with_alpha = write_string(
            &mesh,
            &OffWriteOptions {
                face_alpha: true,
                ..opts
            },
        );
        assert!(with_alpha.ends_with("3 0 1 2 255 0 0 10\n3 3 4 5 12 34 56 200\n"));
    }

    #[test]
    fn tricky_input() {
        let text = "# a comment before the header\r\n\
                    \r\n\
                    COFF # trailing comment\r\n\
                    5\r\n\
                    3 12\r\n\
                    0 0 0   255 0 0\r\n\
                    1 0 0 0.5 0.5 1.0 0.25\r\n\
                    # comment between vertices\r\n\
                    1 1\r\n\
                    0\r\n\
                    0 1 0\r\n\
                    2 2 2 1 2 3 4\r\n\
                    4 0 1 2 3 10 20 30\r\n\
                    3 0 1 4 0.0 1.0 0.5 0.5\r\n\
                    3 2 3 4\r\n";
        let m = parse(text).unwrap();
        assert_eq!(m.vertices.len(), 5);
        assert_eq!(m.vertices[2], [1.0, 1.0, 0.0]);
        // Quad fan-triangulated, then a triangle, then an uncoloured one.
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3], [0, 1, 4], [2, 3, 4]]);
        assert_eq!(
            m.face_colors,
            Some(vec![
                [10, 20, 30, 255],
                [10, 20, 30, 255],
                // Float colours scale by 255 and round: 0.5 -> 127.5 -> 128.
                [0, 255, 128, 128],
                [255, 255, 255, 255],
            ])
        );
        assert_eq!(
            m.vertex_colors,
            Some(vec![
                [255, 0, 0, 255],
                [128, 128, 255, 64],
                [255, 255, 255, 255],
                [255, 255, 255, 255],
                [1, 2, 3, 4],
            ])
        );
    }

    #[test]
    fn headerless_noff_and_counts_on_keyword_line() {
        let m = parse("3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
        assert_eq!(m.faces, vec![[0, 1, 2]]);
        let m = parse("NOFF 3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 2 1 0\n").unwrap();
        assert_eq!(m.normals, Some(vec![[0.0, 0.0, 1.0]; 3]));
        assert_eq!(m.faces, vec![[2, 1, 0]]);
        let m = parse("CNOFF\n1 0 0\n1 2 3 0 0 1 9 8 7 6\n").unwrap();
        assert_eq!(m.vertex_colors, Some(vec![[9, 8, 7, 6]]));
    }

    fn assert_err(text: &str, needles: &[&str]) {
        let e = parse(text).unwrap_err().to_string();
        assert!(e.starts_with("t.off: "), "{e}");
        for n in needles {
            assert!(e.contains(n), "'{e}' lacks '{n}'");
        }
    }

    #[test]
    fn malformed_inputs() {
        assert_err("", &["empty file"]);
        assert_err("PLY\n", &["line 1", "header keyword"]);
        assert_err("4OFF\n", &["line 1", "header keyword"]);
        assert_err(
            "OFF\n1000000000000 1000000000000 0\n0 0 0\n",
            &["line 2", "declares 1000000000000 vertices"],
        );
        assert_err(
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
            &["line 6", "face 0 of 1", "index 3 is out of range"],
        );
        assert_err(
            "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n",
            &["line 4", "vertex 1 of 3", "found 'x'"],
        );
        assert_err(
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n",
            &["line 6", "non-negative integer"],
        );
        assert_err(
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 300 0 0\n",
            &["line 6", "outside 0..=255"],
        );
        assert_err(
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1 1\n",
            &["line 6", "found 2"],
        );
        assert_err(
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n",
            &["line 6", "does not fit"],
        );
    }

    #[test]
    fn truncation_at_every_byte_is_an_error() {
        let text = "COFF\n4 2 0\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0\n1.5 -2 3e2\n3 0 1 2 1 2 3\n3 1 2 3\n";
        parse(text).unwrap();
        // Cutting inside the data must never panic and must fail, except at
        // cuts that leave a complete file (the final newline, or a last face
        // line cut after a complete index list).
        for cut in 0..text.len() {
            let head = &text[..cut];
            match parse(head) {
                Ok(m) => {
                    assert!(
                        head.starts_with(&text[..text.len() - 2]),
                        "cut {cut} parsed"
                    );
                    assert_eq!(m.faces.len(), 2);
                }
                Err(e) => {
                    let s = e.to_string();
                    assert!(s.starts_with("t.off: "), "{s}");
                    assert!(s.contains("line") || s.contains("empty file"), "{s}");
                }
            }
        }
    }

    #[test]
    fn writer_checks_its_inputs() {
        let mut m = Mesh::new(vec![[0.0; 3]; 3], vec![[0, 1, 3]]);
        let mut out = Vec::new();
        assert!(write_off(&mut out, &m, &OffWriteOptions::default()).is_err());
        m.faces[0][2] = 2;
        let opts = OffWriteOptions {
            vertex_colors: true,
            ..Default::default()
        };
        assert!(write_off(&mut out, &m, &opts).is_err());
        assert!(write_off(&mut out, &m, &OffWriteOptions::triangle_splatting()).is_err());
    }

    #[test]
    fn non_finite_coordinates_are_written_as_is() {
        let m = Mesh::new(vec![[f32::INFINITY, f32::NEG_INFINITY, f32::NAN]], vec![]);
        let s = write_string(&m, &OffWriteOptions::default());
        assert_eq!(s, "OFF\n1 0 0\ninf -inf NaN\n");
        let back = parse(&s).unwrap();
        assert!(back.vertices[0][2].is_nan() && back.vertices[0][0] == f32::INFINITY);
        let s = write_string(
            &m,
            &OffWriteOptions {
                float_style: FloatStyle::PythonRepr,
                ..Default::default()
            },
        );
        assert_eq!(s, "OFF\n1 0 0\ninf -inf nan\n");
    }
}
