//! PLY writing (ASCII, binary little- and big-endian).
//!
//! Fixed-stride elements are encoded in blocks of rows, one column at a time,
//! into a buffer that is then written in one call: the mirror image of the
//! reader's fast path. Type names in the header are the classic PLY 1.0
//! names (`float`, `uchar`, `int`), which every PLY reader accepts.

use std::io::Write;

use super::header::{ElementDef, Format, PropertyDef, PropertyKind, write_header};
use super::read::Ply;
use super::scalar::{Scalar, max_count, put_count};
use crate::io::source::werr;
use crate::model::{Column, Element, ScalarData};
use crate::{Error, Result, dispatch_scalar, with_scalars};

const BLOCK_ROWS: usize = 2048;

/// The header declaration of an in-memory element.
pub fn element_def(e: &Element) -> ElementDef {
    ElementDef {
        name: e.name.clone(),
        count: e.count as u64,
        properties: e
            .properties
            .iter()
            .map(|p| PropertyDef {
                name: p.name.clone(),
                kind: match &p.data {
                    Column::Scalar(d) => PropertyKind::Scalar(d.scalar_type()),
                    Column::List {
                        count_type, values, ..
                    } => PropertyKind::List {
                        count: *count_type,
                        item: values.scalar_type(),
                    },
                },
            })
            .collect(),
    }
}

/// Checks that every property has `count` rows, list offsets are sane and
/// every list fits its count type.
pub fn validate(ply: &Ply) -> Result<()> {
    for e in &ply.elements {
        let mut seen = std::collections::HashSet::new();
        for p in &e.properties {
            if !seen.insert(p.name.as_str()) {
                return Err(Error::invalid(format!(
                    "PLY element '{}' has two properties called '{}'",
                    e.name, p.name
                )));
            }
            if p.name.is_empty() || p.name.contains(char::is_whitespace) {
                return Err(Error::invalid(format!(
                    "PLY element '{}': property name '{}' is empty or contains spaces",
                    e.name, p.name
                )));
            }
            if p.data.rows() != e.count {
                return Err(Error::invalid(format!(
                    "PLY element '{}' property '{}' has {} rows, expected {}",
                    e.name,
                    p.name,
                    p.data.rows(),
                    e.count
                )));
            }
            if let Column::List {
                count_type,
                offsets,
                values,
            } = &p.data
            {
                if offsets.first() != Some(&0) || offsets.last() != Some(&values.len()) {
                    return Err(Error::invalid(format!(
                        "PLY element '{}' list '{}' has inconsistent offsets",
                        e.name, p.name
                    )));
                }
                let max = max_count(*count_type);
                if let Some(w) = offsets
                    .windows(2)
                    .position(|w| w[1] < w[0] || (w[1] - w[0]) as u64 > max)
                {
                    return Err(Error::invalid(format!(
                        "PLY element '{}' row {w}: list '{}' is longer than its count type {} allows ({max})",
                        e.name,
                        p.name,
                        count_type.name()
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Writes `ply` in `format` (ignoring `ply.format`).
pub fn write_ply(w: &mut dyn Write, ply: &Ply, format: Format) -> Result<()> {
    validate(ply)?;
    let defs: Vec<ElementDef> = ply.elements.iter().map(element_def).collect();
    let mut buf = Vec::with_capacity(1 << 16);
    write_header(&mut buf, format, &ply.comments, &ply.obj_info, &defs);
    w.write_all(&buf).map_err(werr)?;
    for e in &ply.elements {
        write_element(w, e, format)?;
    }
    Ok(())
}

/// Writes the body rows of one element.
pub fn write_element(w: &mut dyn Write, e: &Element, format: Format) -> Result<()> {
    let big = format == Format::BinaryBigEndian;
    let fixed = e
        .properties
        .iter()
        .all(|p| matches!(p.data, Column::Scalar(_)));
    let mut buf: Vec<u8> = Vec::with_capacity(1 << 20);
    if format == Format::Ascii {
        let mut s = String::with_capacity(1 << 16);
        for row in 0..e.count {
            for (j, p) in e.properties.iter().enumerate() {
                if j > 0 {
                    s.push(' ');
                }
                match &p.data {
                    Column::Scalar(d) => fmt_value(d, row, &mut s),
                    Column::List {
                        offsets, values, ..
                    } => {
                        let (a, b) = (offsets[row], offsets[row + 1]);
                        s.push_str(&(b - a).to_string());
                        for k in a..b {
                            s.push(' ');
                            fmt_value(values, k, &mut s);
                        }
                    }
                }
            }
            s.push('\n');
            if s.len() > (1 << 16) {
                w.write_all(s.as_bytes()).map_err(werr)?;
                s.clear();
            }
        }
        return w.write_all(s.as_bytes()).map_err(werr);
    }
    if fixed {
        let cols: Vec<&ScalarData> = e
            .properties
            .iter()
            .filter_map(|p| p.data.as_scalar())
            .collect();
        let stride: usize = cols.iter().map(|c| c.scalar_type().size()).sum();
        if stride == 0 {
            return Ok(());
        }
        let mut offs = Vec::with_capacity(cols.len());
        let mut o = 0;
        for c in &cols {
            offs.push(o);
            o += c.scalar_type().size();
        }
        let mut start = 0;
        while start < e.count {
            let n = BLOCK_ROWS.min(e.count - start);
            buf.clear();
            buf.resize(n * stride, 0);
            for (c, &off) in cols.iter().zip(&offs) {
                encode_column(c, start, n, &mut buf, stride, off, big);
            }
            w.write_all(&buf).map_err(werr)?;
            start += n;
        }
        return Ok(());
    }
    for row in 0..e.count {
        for p in &e.properties {
            match &p.data {
                Column::Scalar(d) => put_value(d, row, &mut buf, big),
                Column::List {
                    count_type,
                    offsets,
                    values,
                } => {
                    let (a, b) = (offsets[row], offsets[row + 1]);
                    put_count(*count_type, b - a, &mut buf, big);
                    for k in a..b {
                        put_value(values, k, &mut buf, big);
                    }
                }
            }
        }
        if buf.len() > (1 << 20) {
            w.write_all(&buf).map_err(werr)?;
            buf.clear();
        }
    }
    w.write_all(&buf).map_err(werr)
}

fn encode_column(
    c: &ScalarData,
    start: usize,
    n: usize,
    buf: &mut [u8],
    stride: usize,
    off: usize,
    big: bool,
) {
    fn go<T: Scalar>(
        c: &ScalarData,
        start: usize,
        n: usize,
        buf: &mut [u8],
        stride: usize,
        off: usize,
        big: bool,
    ) {
        let v = &T::unwrap(c).expect("type")[start..start + n];
        let mut tmp = Vec::with_capacity(8);
        for (row, x) in buf.chunks_exact_mut(stride).zip(v) {
            tmp.clear();
            x.put(&mut tmp, big);
            row[off..off + T::SIZE].copy_from_slice(&tmp);
        }
    }
    let t = c.scalar_type();
    dispatch_scalar!(t, go(c, start, n, buf, stride, off, big))
}

fn put_value(d: &ScalarData, i: usize, out: &mut Vec<u8>, big: bool) {
    with_scalars!(d, v => v[i].put(out, big))
}

fn fmt_value(d: &ScalarData, i: usize, out: &mut String) {
    with_scalars!(d, v => v[i].fmt_ascii(out))
}
