//! PLY header parsing.
//!
//! Accepted beyond the strict PLY 1.0 grammar, because real files do it:
//! `\r\n` line ends; `{ … }` inline comments after a property (Stanford
//! `zipper` output); `property NAME TYPE` with name and type swapped (the
//! `material` element of `bun_zipper.ply`); the sized type names
//! (`float32`, `uint8`, …); blank lines.

use crate::model::ScalarType;
use crate::{Error, Result};

/// Largest header we accept; real headers are a few KB.
const MAX_HEADER_BYTES: usize = 1 << 20;

/// Body encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

impl Format {
    /// The name used in the `format` line.
    pub fn name(self) -> &'static str {
        match self {
            Format::Ascii => "ascii",
            Format::BinaryLittleEndian => "binary_little_endian",
            Format::BinaryBigEndian => "binary_big_endian",
        }
    }

    /// Parses a `format` line keyword.
    pub fn parse(s: &str) -> Option<Format> {
        match s {
            "ascii" => Some(Format::Ascii),
            "binary_little_endian" => Some(Format::BinaryLittleEndian),
            "binary_big_endian" => Some(Format::BinaryBigEndian),
            _ => None,
        }
    }
}

/// A property's type: one scalar, or a list with a count type and item type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PropertyKind {
    Scalar(ScalarType),
    List { count: ScalarType, item: ScalarType },
}

/// A property as declared in the header.
#[derive(Clone, Debug, PartialEq)]
pub struct PropertyDef {
    pub name: String,
    pub kind: PropertyKind,
}

/// An element as declared in the header.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementDef {
    pub name: String,
    /// Declared row count (validated against the body before any allocation).
    pub count: u64,
    pub properties: Vec<PropertyDef>,
}

impl ElementDef {
    /// Row size in bytes when every property is a scalar (fixed stride).
    pub fn fixed_stride(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                PropertyKind::Scalar(t) => Some(t.size()),
                PropertyKind::List { .. } => None,
            })
            .sum()
    }

    /// The fewest bytes one binary row can take (lists count as empty).
    pub fn min_binary_row(&self) -> usize {
        self.properties
            .iter()
            .map(|p| match p.kind {
                PropertyKind::Scalar(t) => t.size(),
                PropertyKind::List { count, .. } => count.size(),
            })
            .sum()
    }

    /// Index of the property called `name`.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.properties.iter().position(|p| p.name == name)
    }
}

/// A parsed header.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    pub format: Format,
    /// Version string of the `format` line (normally `1.0`).
    pub version: String,
    pub comments: Vec<String>,
    pub obj_info: Vec<String>,
    pub elements: Vec<ElementDef>,
    /// Byte offset of the first body byte.
    pub body_offset: usize,
}

impl Header {
    /// The element called `name`.
    pub fn element(&self, name: &str) -> Option<&ElementDef> {
        self.elements.iter().find(|e| e.name == name)
    }

    /// Parses the header at the start of `bytes`; `name` is used in errors.
    pub fn parse(name: &str, bytes: &[u8]) -> Result<Header> {
        let err =
            |line: usize, msg: String| Error::format(name, format!("header line {line}: {msg}"));
        if !bytes.starts_with(b"ply") || !matches!(bytes.get(3), Some(b'\n' | b'\r')) {
            return Err(Error::format(
                name,
                "not a PLY file: it does not start with the line 'ply'",
            ));
        }
        let mut pos = 0usize;
        let mut line_no = 0usize;
        let mut format = None;
        let mut version = String::new();
        let mut comments = Vec::new();
        let mut obj_info = Vec::new();
        let mut elements: Vec<ElementDef> = Vec::new();
        loop {
            if pos >= bytes.len() {
                return Err(Error::format(
                    name,
                    format!(
                        "header ends after {line_no} lines without 'end_header' (file truncated?)"
                    ),
                ));
            }
            if pos > MAX_HEADER_BYTES {
                return Err(Error::format(
                    name,
                    format!("no 'end_header' in the first {MAX_HEADER_BYTES} bytes"),
                ));
            }
            let end = bytes[pos..]
                .iter()
                .position(|&b| b == b'\n')
                .map(|i| pos + i)
                .unwrap_or(bytes.len());
            line_no += 1;
            let raw = &bytes[pos..end];
            let line = std::str::from_utf8(raw)
                .map_err(|_| err(line_no, "header is not valid text".into()))?;
            let line = line.strip_suffix('\r').unwrap_or(line);
            pos = end + 1;
            if line_no == 1 {
                continue; // "ply"
            }
            let (kw, rest) = match line.trim_start().split_once(char::is_whitespace) {
                Some((k, r)) => (k, r),
                None => (line.trim(), ""),
            };
            match kw {
                "" => {}
                "format" => {
                    let mut t = rest.split_whitespace();
                    let f = t.next().unwrap_or("");
                    format = Some(Format::parse(f).ok_or_else(|| {
                        err(
                            line_no,
                            format!("unknown format '{f}' (expected ascii, binary_little_endian or binary_big_endian)"),
                        )
                    })?);
                    version = t.next().unwrap_or("1.0").to_string();
                }
                "comment" => comments.push(rest.to_string()),
                "obj_info" => obj_info.push(rest.to_string()),
                "element" => {
                    let mut t = rest.split_whitespace();
                    let (Some(en), Some(c)) = (t.next(), t.next()) else {
                        return Err(err(line_no, "expected 'element NAME COUNT'".into()));
                    };
                    let count: u64 = c.parse().map_err(|_| {
                        err(line_no, format!("element '{en}' has a bad count '{c}'"))
                    })?;
                    if elements.iter().any(|e| e.name == en) {
                        return Err(err(line_no, format!("element '{en}' is declared twice")));
                    }
                    elements.push(ElementDef {
                        name: en.to_string(),
                        count,
                        properties: Vec::new(),
                    });
                }
                "property" => {
                    let Some(el) = elements.last_mut() else {
                        return Err(err(line_no, "property before any element".into()));
                    };
                    // Drop `{ … }` inline comments.
                    let text = rest.split('{').next().unwrap_or("");
                    let t: Vec<&str> = text.split_whitespace().collect();
                    let prop = parse_property(&t).map_err(|m| err(line_no, m))?;
                    if el.properties.iter().any(|p| p.name == prop.name) {
                        return Err(err(
                            line_no,
                            format!(
                                "property '{}' of element '{}' is declared twice",
                                prop.name, el.name
                            ),
                        ));
                    }
                    el.properties.push(prop);
                }
                "end_header" => {
                    let format = format
                        .ok_or_else(|| err(line_no, "no 'format' line before end_header".into()))?;
                    return Ok(Header {
                        format,
                        version,
                        comments,
                        obj_info,
                        elements,
                        body_offset: pos.min(bytes.len()),
                    });
                }
                other => {
                    return Err(err(line_no, format!("unknown header keyword '{other}'")));
                }
            }
        }
    }
}

fn parse_property(t: &[&str]) -> std::result::Result<PropertyDef, String> {
    match t {
        ["list", c, i, n] => {
            let count =
                ScalarType::parse(c).ok_or_else(|| format!("unknown list count type '{c}'"))?;
            let item =
                ScalarType::parse(i).ok_or_else(|| format!("unknown list item type '{i}'"))?;
            if count.is_float() {
                return Err(format!(
                    "list count type '{c}' of '{n}' must be an integer type"
                ));
            }
            Ok(PropertyDef {
                name: n.to_string(),
                kind: PropertyKind::List { count, item },
            })
        }
        [a, b] => {
            if let Some(ty) = ScalarType::parse(a) {
                Ok(PropertyDef {
                    name: b.to_string(),
                    kind: PropertyKind::Scalar(ty),
                })
            } else if let Some(ty) = ScalarType::parse(b) {
                // `property NAME TYPE`, as in bun_zipper.ply's material element.
                Ok(PropertyDef {
                    name: a.to_string(),
                    kind: PropertyKind::Scalar(ty),
                })
            } else {
                Err(format!("unknown property type '{a}'"))
            }
        }
        _ => Err(format!(
            "expected 'property TYPE NAME' or 'property list COUNT_TYPE ITEM_TYPE NAME', got 'property {}'",
            t.join(" ")
        )),
    }
}

/// Writes a header for `elements` (names, counts, kinds) in classic type names.
pub fn write_header(
    out: &mut Vec<u8>,
    format: Format,
    comments: &[String],
    obj_info: &[String],
    elements: &[ElementDef],
) {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "ply\nformat {} 1.0", format.name());
    for c in comments {
        let _ = writeln!(s, "comment {}", one_line(c));
    }
    for c in obj_info {
        let _ = writeln!(s, "obj_info {}", one_line(c));
    }
    for e in elements {
        let _ = writeln!(s, "element {} {}", e.name, e.count);
        for p in &e.properties {
            match p.kind {
                PropertyKind::Scalar(t) => {
                    let _ = writeln!(s, "property {} {}", t.name(), p.name);
                }
                PropertyKind::List { count, item } => {
                    let _ = writeln!(
                        s,
                        "property list {} {} {}",
                        count.name(),
                        item.name(),
                        p.name
                    );
                }
            }
        }
    }
    s.push_str("end_header\n");
    out.extend_from_slice(s.as_bytes());
}

fn one_line(s: &str) -> String {
    s.replace(['\n', '\r'], " ")
}
