//! The OFF writer and its options.

use std::io::Write;

use super::float_text::{push_f32_shortest, python_float_repr_into};
use crate::io::source::werr;
use crate::model::Mesh;
use crate::{Error, Result};

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
    /// [`format_f32_shortest`](super::format_f32_shortest)).
    #[default]
    Shortest,
    /// The `f32` widened to `f64` and printed as Python's `repr(float)` does
    /// (see [`python_float_repr`](super::python_float_repr)), as `create_off.py` writes it.
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
