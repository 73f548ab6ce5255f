//! PLY: the interchange format of every command.
//!
//! - [`header`]: header grammar (tolerant of real-world quirks);
//! - [`read`]: body decoding into typed columns ([`Ply`]), with a located,
//!   zero-copy view of binary elements ([`PlyReader::locate`]) for fast paths;
//! - [`write`]: ASCII and binary writers;
//! - [`gaussians`], [`surfels`], [`mesh`], [`points`], [`soup`]: the file contracts that map
//!   PLY elements to the [`crate::model`] types (docs/formats.md).
//!
//! Unknown elements and properties survive read-modify-write through
//! [`crate::model::Extras`].

pub mod bound;
mod common;
pub mod gaussians;
pub mod header;
pub mod mesh;
pub mod points;
pub mod read;
pub mod scalar;
pub mod soup;
pub mod surfels;
pub mod write;

pub use header::{Format, Header};
pub use read::{Ply, PlyReader};
pub use write::write_ply;

use std::path::Path;

use crate::Result;

/// Reads a whole PLY (`-` = stdin) into columns.
pub fn read_ply(path: &Path) -> Result<Ply> {
    let input = crate::io::read_input(path)?;
    parse_ply(&input.name, &input)
}

/// Parses PLY bytes; `name` is used in errors. Bytes after the declared data
/// are ignored.
pub fn parse_ply(name: &str, bytes: &[u8]) -> Result<Ply> {
    Ok(PlyReader::new(name, bytes)?.read()?.0)
}

pub use crate::model::finite::first_non_finite;
#[cfg(test)]
mod tests;
