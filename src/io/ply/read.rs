//! PLY body decoding into typed columns.
//!
//! Binary bodies are first *located* (each element's byte range; O(1) for
//! fixed-stride elements, one scan for elements with lists) and then decoded.
//! Fixed-stride elements are decoded in blocks of rows that fit in cache,
//! one column at a time, which is what makes a 248 MB 3DGS file load at
//! memory speed. Every declared count is checked against the bytes present
//! before anything is allocated for it.

use super::header::{ElementDef, Format, Header, PropertyKind};
use super::scalar::{Scalar, read_count};
use crate::model::{Column, Element, Property, ScalarData, ScalarType};
use crate::{Error, Result, dispatch_scalar};

/// Rows per decode block: big enough to amortise dispatch, small enough that a
/// block of 3DGS rows (248 B each) stays in L2.
const BLOCK_ROWS: usize = 2048;

/// A whole PLY file in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Ply {
    pub format: Format,
    pub comments: Vec<String>,
    pub obj_info: Vec<String>,
    pub elements: Vec<Element>,
}

impl Ply {
    /// The element called `name`.
    pub fn element(&self, name: &str) -> Option<&Element> {
        self.elements.iter().find(|e| e.name == name)
    }

    /// Removes and returns the element called `name`.
    pub fn take_element(&mut self, name: &str) -> Option<Element> {
        let i = self.elements.iter().position(|e| e.name == name)?;
        Some(self.elements.remove(i))
    }
}

/// Where one element's rows lie in a binary body.
#[derive(Clone, Copy, Debug)]
pub struct RawElement<'a> {
    /// The element's bytes (all rows).
    pub bytes: &'a [u8],
    /// Absolute file offset of `bytes[0]`.
    pub offset: usize,
    /// Row size when every property is a scalar.
    pub stride: Option<usize>,
}

/// A parsed header over the file's bytes.
pub struct PlyReader<'a> {
    pub name: String,
    pub header: Header,
    bytes: &'a [u8],
}

impl<'a> PlyReader<'a> {
    /// Parses the header of `bytes`; `name` is used in every error.
    pub fn new(name: &str, bytes: &'a [u8]) -> Result<Self> {
        let header = Header::parse(name, bytes)?;
        Ok(PlyReader {
            name: name.to_string(),
            header,
            bytes,
        })
    }

    fn err(&self, msg: String) -> Error {
        Error::format(&self.name, msg)
    }

    fn big_endian(&self) -> bool {
        self.header.format == Format::BinaryBigEndian
    }

    /// Locates every element of a binary body. Returns the ranges and the
    /// number of bytes after the last element (data not declared by the header).
    pub fn locate(&self) -> Result<(Vec<RawElement<'a>>, usize)> {
        debug_assert!(self.header.format != Format::Ascii);
        let big = self.big_endian();
        let mut pos = self.header.body_offset;
        let mut out = Vec::with_capacity(self.header.elements.len());
        for el in &self.header.elements {
            let remaining = self.bytes.len() - pos;
            let min_row = el.min_binary_row() as u64;
            if el.count.saturating_mul(min_row) > remaining as u64 {
                return Err(self.err(format!(
                    "element '{}' declares {} rows of at least {} bytes ({} bytes) but only {} bytes remain after byte offset {} (file truncated or count wrong)",
                    el.name,
                    el.count,
                    min_row,
                    el.count.saturating_mul(min_row),
                    remaining,
                    pos
                )));
            }
            let count = el.count as usize;
            let start = pos;
            if let Some(stride) = el.fixed_stride() {
                pos += count * stride;
                out.push(RawElement {
                    bytes: &self.bytes[start..pos],
                    offset: start,
                    stride: Some(stride),
                });
                continue;
            }
            for row in 0..count {
                for p in &el.properties {
                    match p.kind {
                        PropertyKind::Scalar(t) => {
                            if pos + t.size() > self.bytes.len() {
                                return Err(self.truncated(el, row, &p.name, pos));
                            }
                            pos += t.size();
                        }
                        PropertyKind::List { count: ct, item } => {
                            if pos + ct.size() > self.bytes.len() {
                                return Err(self.truncated(el, row, &p.name, pos));
                            }
                            let n = read_count(ct, &self.bytes[pos..], big);
                            if n < 0 {
                                return Err(self.err(format!(
                                    "element '{}' row {row}: list '{}' has negative length {n} at byte offset {pos}",
                                    el.name, p.name
                                )));
                            }
                            let len = (n as usize).saturating_mul(item.size());
                            let after = pos + ct.size();
                            if len > self.bytes.len() - after {
                                return Err(self.err(format!(
                                    "element '{}' row {row}: list '{}' of length {n} at byte offset {pos} runs past the end of the file ({} bytes)",
                                    el.name,
                                    p.name,
                                    self.bytes.len()
                                )));
                            }
                            pos = after + len;
                        }
                    }
                }
            }
            out.push(RawElement {
                bytes: &self.bytes[start..pos],
                offset: start,
                stride: None,
            });
        }
        Ok((out, self.bytes.len() - pos))
    }

    fn truncated(&self, el: &ElementDef, row: usize, prop: &str, pos: usize) -> Error {
        self.err(format!(
            "element '{}' row {row} property '{prop}': file ends at byte {} (truncated)",
            el.name,
            self.bytes.len().max(pos)
        ))
    }

    /// Decodes the properties `props` (indices into the element's
    /// declaration; all of them when `None`) of element `index` located at `raw`.
    pub fn decode_binary(
        &self,
        index: usize,
        raw: &RawElement<'a>,
        props: Option<&[usize]>,
    ) -> Result<Element> {
        let def = &self.header.elements[index];
        let all: Vec<usize> = (0..def.properties.len()).collect();
        let props = props.unwrap_or(&all);
        let count = def.count as usize;
        let big = self.big_endian();
        let mut element = Element::new(def.name.clone(), count);
        if let Some(stride) = raw.stride {
            let offsets = prop_offsets(def);
            let mut cols: Vec<ScalarData> = props
                .iter()
                .map(|&p| match def.properties[p].kind {
                    PropertyKind::Scalar(t) => ScalarData::with_capacity(t, count),
                    PropertyKind::List { .. } => unreachable!("fixed stride has no lists"),
                })
                .collect();
            // A zero-stride element (no properties) has rows but no bytes.
            for block in raw.bytes.chunks((stride * BLOCK_ROWS).max(1)) {
                for (col, &p) in cols.iter_mut().zip(props) {
                    decode_column(col, block, stride, offsets[p], big);
                }
            }
            for (col, &p) in cols.into_iter().zip(props) {
                element.push(def.properties[p].name.clone(), Column::Scalar(col));
            }
            return Ok(element);
        }
        // Rows with lists: one pass, row by row (already bounds-checked by locate).
        let mut cols = empty_columns(def, count);
        let b = raw.bytes;
        let mut pos = 0usize;
        for _ in 0..count {
            for (p, col) in def.properties.iter().zip(cols.iter_mut()) {
                match (p.kind, col) {
                    (PropertyKind::Scalar(t), Column::Scalar(d)) => {
                        push_one(d, &b[pos..], big);
                        pos += t.size();
                    }
                    (
                        PropertyKind::List { count: ct, item },
                        Column::List {
                            offsets, values, ..
                        },
                    ) => {
                        let n = read_count(ct, &b[pos..], big) as usize;
                        pos += ct.size();
                        let len = n * item.size();
                        push_many(values, &b[pos..pos + len], item.size(), big);
                        pos += len;
                        offsets.push(values.len());
                    }
                    _ => unreachable!("column kinds follow the declaration"),
                }
            }
        }
        let keep: Vec<bool> = (0..def.properties.len())
            .map(|i| props.contains(&i))
            .collect();
        for ((p, col), k) in def.properties.iter().zip(cols).zip(keep) {
            if k {
                element.push(p.name.clone(), col);
            }
        }
        Ok(element)
    }

    /// Reads the whole file into columns; also returns the number of bytes
    /// after the declared data (ignored, but `info` reports them).
    pub fn read(&self) -> Result<(Ply, usize)> {
        let (elements, trailing) = match self.header.format {
            Format::Ascii => self.read_ascii()?,
            _ => {
                let (raws, trailing) = self.locate()?;
                let mut els = Vec::with_capacity(raws.len());
                for (i, raw) in raws.iter().enumerate() {
                    els.push(self.decode_binary(i, raw, None)?);
                }
                (els, trailing)
            }
        };
        Ok((
            Ply {
                format: self.header.format,
                comments: self.header.comments.clone(),
                obj_info: self.header.obj_info.clone(),
                elements,
            },
            trailing,
        ))
    }

    fn read_ascii(&self) -> Result<(Vec<Element>, usize)> {
        let mut tok = Tokens {
            bytes: self.bytes,
            pos: self.header.body_offset,
        };
        let mut out = Vec::with_capacity(self.header.elements.len());
        for def in &self.header.elements {
            let remaining = (self.bytes.len() - tok.pos) as u64;
            // Every ASCII value takes at least 2 bytes (a digit and a separator,
            // the last one may lack it): a cheap guard against absurd counts.
            let min_row = def.properties.len() as u64;
            if def.count.saturating_mul(min_row) > remaining.saturating_add(1) / 2 + 1
                && min_row > 0
            {
                return Err(self.err(format!(
                    "element '{}' declares {} rows of {} values but only {} bytes of text remain (file truncated or count wrong)",
                    def.name, def.count, min_row, remaining
                )));
            }
            let count = def.count as usize;
            let mut cols = empty_columns(def, count);
            if min_row > 0 {
                for row in 0..count {
                    for (p, col) in def.properties.iter().zip(cols.iter_mut()) {
                        let ctx = |what: &str, at: usize| {
                            self.err(format!(
                                "element '{}' row {row} property '{}': {what} (line {}, byte offset {at})",
                                def.name,
                                p.name,
                                line_of(self.bytes, at)
                            ))
                        };
                        match (p.kind, col) {
                            (PropertyKind::Scalar(t), Column::Scalar(d)) => {
                                let (s, at) = tok.next().ok_or_else(|| {
                                    ctx("file ends (truncated)", self.bytes.len())
                                })?;
                                if !parse_push(d, s) {
                                    return Err(ctx(
                                        &format!("'{s}' is not a valid {}", t.name()),
                                        at,
                                    ));
                                }
                            }
                            (
                                PropertyKind::List { count: ct, item },
                                Column::List {
                                    offsets, values, ..
                                },
                            ) => {
                                let (s, at) = tok.next().ok_or_else(|| {
                                    ctx("file ends (truncated)", self.bytes.len())
                                })?;
                                let n: i64 = s
                                    .parse()
                                    .ok()
                                    .filter(|n| {
                                        *n >= 0 && (*n as u64) <= super::scalar::max_count(ct)
                                    })
                                    .ok_or_else(|| {
                                        ctx(&format!("'{s}' is not a valid list length"), at)
                                    })?;
                                for _ in 0..n {
                                    let (s, at) = tok.next().ok_or_else(|| {
                                        ctx("file ends inside a list (truncated)", self.bytes.len())
                                    })?;
                                    if !parse_push(values, s) {
                                        return Err(ctx(
                                            &format!("'{s}' is not a valid {}", item.name()),
                                            at,
                                        ));
                                    }
                                }
                                offsets.push(values.len());
                            }
                            _ => unreachable!("column kinds follow the declaration"),
                        }
                    }
                }
            }
            let mut el = Element::new(def.name.clone(), count);
            el.properties = def
                .properties
                .iter()
                .zip(cols)
                .map(|(p, data)| Property {
                    name: p.name.clone(),
                    data,
                })
                .collect();
            out.push(el);
        }
        // Whatever non-space text follows is data the header did not declare.
        let rest = &self.bytes[tok.pos..];
        let trailing = match rest.iter().position(|b| !b.is_ascii_whitespace()) {
            Some(i) => rest.len() - i,
            None => 0,
        };
        Ok((out, trailing))
    }
}

/// Empty columns for `count` rows of `def`, with room reserved (callers have
/// already checked `count` against the bytes present).
fn empty_columns(def: &ElementDef, count: usize) -> Vec<Column> {
    def.properties
        .iter()
        .map(|p| match p.kind {
            PropertyKind::Scalar(t) => Column::Scalar(ScalarData::with_capacity(t, count)),
            PropertyKind::List { count: ct, item } => {
                let mut offsets = Vec::with_capacity(count + 1);
                offsets.push(0);
                Column::List {
                    count_type: ct,
                    offsets,
                    values: ScalarData::with_capacity(item, count * 3),
                }
            }
        })
        .collect()
}

/// Byte offset of each property inside a fixed-stride row (`usize::MAX` for lists).
pub fn prop_offsets(def: &ElementDef) -> Vec<usize> {
    let mut off = 0;
    def.properties
        .iter()
        .map(|p| match p.kind {
            PropertyKind::Scalar(t) => {
                let o = off;
                off += t.size();
                o
            }
            PropertyKind::List { .. } => usize::MAX,
        })
        .collect()
}

fn decode_column(col: &mut ScalarData, block: &[u8], stride: usize, off: usize, big: bool) {
    fn go<T: Scalar>(col: &mut ScalarData, block: &[u8], stride: usize, off: usize, big: bool) {
        let v = T::unwrap_mut(col).expect("column type matches declaration");
        v.extend(
            block
                .chunks_exact(stride)
                .map(|row| T::from_bytes(&row[off..off + T::SIZE], big)),
        );
    }
    let t = col.scalar_type();
    dispatch_scalar!(t, go(col, block, stride, off, big))
}

fn push_one(col: &mut ScalarData, b: &[u8], big: bool) {
    fn go<T: Scalar>(col: &mut ScalarData, b: &[u8], big: bool) {
        T::unwrap_mut(col)
            .expect("type")
            .push(T::from_bytes(b, big));
    }
    let t = col.scalar_type();
    dispatch_scalar!(t, go(col, b, big))
}

fn push_many(col: &mut ScalarData, b: &[u8], size: usize, big: bool) {
    fn go<T: Scalar>(col: &mut ScalarData, b: &[u8], size: usize, big: bool) {
        T::unwrap_mut(col)
            .expect("type")
            .extend(b.chunks_exact(size).map(|c| T::from_bytes(c, big)));
    }
    let t = col.scalar_type();
    dispatch_scalar!(t, go(col, b, size, big))
}

fn parse_push(col: &mut ScalarData, s: &str) -> bool {
    fn go<T: Scalar>(col: &mut ScalarData, s: &str) -> bool {
        match T::parse_ascii(s) {
            Some(v) => {
                T::unwrap_mut(col).expect("type").push(v);
                true
            }
            None => false,
        }
    }
    let t: ScalarType = col.scalar_type();
    dispatch_scalar!(t, go(col, s))
}

/// 1-based line number of byte offset `at`.
pub fn line_of(bytes: &[u8], at: usize) -> usize {
    bytes[..at.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

struct Tokens<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Tokens<'a> {
    /// Next whitespace-separated token and its byte offset.
    fn next(&mut self) -> Option<(&'a str, usize)> {
        let b = self.bytes;
        let mut i = self.pos;
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        if i >= b.len() {
            self.pos = i;
            return None;
        }
        let start = i;
        while i < b.len() && !b[i].is_ascii_whitespace() {
            i += 1;
        }
        self.pos = i;
        // Non-UTF-8 bytes cannot be a number: hand back a marker that fails to parse.
        Some((
            std::str::from_utf8(&b[start..i]).unwrap_or("<non-text bytes>"),
            start,
        ))
    }
}
