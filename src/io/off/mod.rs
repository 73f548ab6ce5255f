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

mod float_text;
mod read;
#[cfg(test)]
mod tests;
mod write;

pub use float_text::{
    format_f32_shortest, push_f32_shortest, python_float_repr, python_float_repr_into,
};
pub use read::{parse_off, read_off};
pub(crate) use write::write_lines_par;
pub use write::{FloatStyle, OffHeader, OffWriteOptions, write_off};
