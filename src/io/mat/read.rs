//! The MAT-file reader: header, data elements, compressed elements and the
//! numeric arrays inside them, every declared size checked first.

use std::fmt::Display;
use std::io::Read;
use std::path::Path;

use super::*;
use crate::{Error, Result};

/// Reads a MAT-file (`-` = stdin). See the module documentation.
pub fn read_mat(path: &Path) -> Result<Vec<MatArray>> {
    let input = crate::io::read_input(path)?;
    parse_mat(&input.name, &input)
}

/// Parses the bytes of a Level 5 MAT-file; `name` is used in error messages.
/// Returns the variables in file order (see the module documentation).
pub fn parse_mat(name: &str, bytes: &[u8]) -> Result<Vec<MatArray>> {
    if bytes.len() < HEADER_LEN {
        return Err(Error::format(
            name,
            format!(
                "file is {} bytes, shorter than the 128-byte MAT-file header",
                bytes.len()
            ),
        ));
    }
    let order = match &bytes[126..128] {
        b"IM" => Order::Le,
        b"MI" => Order::Be,
        other => {
            return Err(Error::format(
                name,
                format!(
                    "byte 126: endian indicator is {:?}, expected \"IM\" or \"MI\" \
                     (not a MATLAB Level 5 MAT-file; v4 files have no header)",
                    String::from_utf8_lossy(other)
                ),
            ));
        }
    };
    let version = order.u16([bytes[124], bytes[125]]);
    if version != 0x0100 {
        let hint = if version == 0x0200 {
            " (a v7.3 HDF5 MAT-file; re-save it with `save -v7`)"
        } else {
            ""
        };
        return Err(Error::format(
            name,
            format!("byte 124: MAT-file version 0x{version:04x}, expected 0x0100{hint}"),
        ));
    }
    let file = Buf {
        file: name,
        order,
        bytes,
        zlib_at: None,
    };
    let mut out = Vec::new();
    let mut pos = HEADER_LEN;
    while pos < bytes.len() {
        let tag = file.tag(pos, bytes.len(), None)?;
        match tag.ty {
            MI_MATRIX => {
                if let Some(a) = file.matrix(tag.data, tag.data + tag.len)? {
                    out.push(a);
                }
                // As scipy: the next element starts right after the declared
                // bytes (MATLAB's miMATRIX lengths are multiples of 8 already).
                pos = tag.data + tag.len;
            }
            MI_COMPRESSED => {
                let inflated = inflate(name, order, &bytes[tag.data..tag.data + tag.len], pos)?;
                let inner = Buf {
                    file: name,
                    order,
                    bytes: &inflated,
                    zlib_at: Some(pos),
                };
                if let Some(a) = inner.matrix(8, inflated.len())? {
                    out.push(a);
                }
                pos = tag.data + tag.len;
            }
            ty => {
                return Err(file.err(
                    pos,
                    None,
                    format!(
                        "data element of type {ty} ({}), expected miMATRIX (14) or miCOMPRESSED (15)",
                        type_name(ty)
                    ),
                ));
            }
        }
    }
    Ok(out)
}

fn type_name(ty: u32) -> &'static str {
    match ty {
        1 => "miINT8",
        2 => "miUINT8",
        3 => "miINT16",
        4 => "miUINT16",
        5 => "miINT32",
        6 => "miUINT32",
        7 => "miSINGLE",
        9 => "miDOUBLE",
        12 => "miINT64",
        13 => "miUINT64",
        14 => "miMATRIX",
        15 => "miCOMPRESSED",
        16 => "miUTF8",
        17 => "miUTF16",
        18 => "miUTF32",
        _ => "unknown type",
    }
}

/// Bytes per value of a numeric storage type, `None` for other types.
fn numeric_size(ty: u32) -> Option<usize> {
    match ty {
        MI_INT8 | MI_UINT8 => Some(1),
        MI_INT16 | MI_UINT16 => Some(2),
        MI_INT32 | MI_UINT32 | MI_SINGLE => Some(4),
        MI_DOUBLE | MI_INT64 | MI_UINT64 => Some(8),
        _ => None,
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Order {
    Le,
    Be,
}

impl Order {
    fn u16(self, b: [u8; 2]) -> u16 {
        match self {
            Order::Le => u16::from_le_bytes(b),
            Order::Be => u16::from_be_bytes(b),
        }
    }

    fn u32(self, b: [u8; 4]) -> u32 {
        match self {
            Order::Le => u32::from_le_bytes(b),
            Order::Be => u32::from_be_bytes(b),
        }
    }
}

/// A data element's tag, positions relative to the buffer.
#[derive(Clone, Copy, Debug)]
struct Tag {
    /// Where the tag starts.
    at: usize,
    ty: u32,
    /// Declared byte count (already checked against the enclosing bytes).
    len: usize,
    /// Where the data start.
    data: usize,
    /// Where the next sibling sub-element starts (after 8-byte padding,
    /// clamped to the enclosing end).
    next: usize,
}

/// A buffer being parsed: the file itself or one inflated compressed element.
struct Buf<'a> {
    file: &'a str,
    order: Order,
    bytes: &'a [u8],
    /// `Some(file offset of the miCOMPRESSED tag)` for an inflated stream.
    zlib_at: Option<usize>,
}

impl Buf<'_> {
    fn err(&self, off: usize, var: Option<&str>, msg: impl Display) -> Error {
        let loc = match self.zlib_at {
            None => format!("byte {off}"),
            Some(at) => format!("byte {off} of the compressed element at byte {at}"),
        };
        let var = match var {
            Some(v) => format!("variable '{v}': "),
            None => String::new(),
        };
        Error::format(self.file, format!("{loc}: {var}{msg}"))
    }

    fn u32_at(&self, pos: usize) -> u32 {
        let b = &self.bytes[pos..pos + 4];
        self.order.u32([b[0], b[1], b[2], b[3]])
    }

    /// Reads the tag at `pos` of an element that must end by `end`.
    fn tag(&self, pos: usize, end: usize, var: Option<&str>) -> Result<Tag> {
        let left = end.saturating_sub(pos);
        if left < 8 {
            return Err(self.err(
                pos,
                var,
                format!("truncated data element tag: {left} bytes left, a tag needs 8"),
            ));
        }
        let word = self.u32_at(pos);
        if word >> 16 != 0 {
            let len = (word >> 16) as usize;
            if len > 4 {
                return Err(self.err(
                    pos,
                    var,
                    format!(
                        "small data element of type {} declares {len} bytes, at most 4 fit",
                        word & 0xffff
                    ),
                ));
            }
            return Ok(Tag {
                at: pos,
                ty: word & 0xffff,
                len,
                data: pos + 4,
                next: pos + 8,
            });
        }
        let len = self.u32_at(pos + 4) as usize;
        let data = pos + 8;
        if len > end - data {
            return Err(self.err(
                pos,
                var,
                format!(
                    "data element of type {word} ({}) declares {len} bytes but only {} remain",
                    type_name(word),
                    end - data
                ),
            ));
        }
        let padded = data + len.div_ceil(8) * 8;
        Ok(Tag {
            at: pos,
            ty: word,
            len,
            data,
            next: padded.min(end),
        })
    }

    /// Parses the body `[start, end)` of an miMATRIX element. `None` for an
    /// empty element (an empty cell slot).
    fn matrix(&self, start: usize, end: usize) -> Result<Option<MatArray>> {
        if start == end {
            return Ok(None);
        }
        let flags_tag = self.tag(start, end, None)?;
        if flags_tag.ty != MI_UINT32 || flags_tag.len != 8 {
            return Err(self.err(
                start,
                None,
                format!(
                    "array flags sub-element is type {} ({}) with {} bytes, expected miUINT32 with 8",
                    flags_tag.ty,
                    type_name(flags_tag.ty),
                    flags_tag.len
                ),
            ));
        }
        let flags = self.u32_at(flags_tag.data);
        let class = MatClass::from_id((flags & 0xff) as u8);
        let complex = flags & FLAG_COMPLEX != 0;
        let logical = flags & FLAG_LOGICAL != 0;

        // Opaque objects have no dimensions sub-element: the name follows.
        let (dims_tag, name_tag) = if class == MatClass::Opaque {
            (None, self.tag(flags_tag.next, end, None)?)
        } else {
            let d = self.tag(flags_tag.next, end, None)?;
            (Some(d), self.tag(d.next, end, None)?)
        };
        if !matches!(name_tag.ty, MI_INT8 | MI_UINT8 | MI_UTF8) {
            return Err(self.err(
                name_tag.at,
                None,
                format!(
                    "array name sub-element is type {} ({}), expected miINT8",
                    name_tag.ty,
                    type_name(name_tag.ty)
                ),
            ));
        }
        let name =
            String::from_utf8_lossy(&self.bytes[name_tag.data..name_tag.data + name_tag.len])
                .into_owned();
        let var = Some(name.as_str());

        let mut dims = Vec::new();
        if let Some(d) = dims_tag {
            if d.ty != MI_INT32 || d.len % 4 != 0 {
                return Err(self.err(
                    d.at,
                    var,
                    format!(
                        "dimensions sub-element is type {} ({}) with {} bytes, expected miINT32 values",
                        d.ty,
                        type_name(d.ty),
                        d.len
                    ),
                ));
            }
            for k in 0..d.len / 4 {
                let v = self.u32_at(d.data + 4 * k) as i32;
                let Ok(v) = usize::try_from(v) else {
                    return Err(self.err(d.data + 4 * k, var, format!("negative dimension {v}")));
                };
                dims.push(v);
            }
        }

        if !class.is_numeric() || complex {
            return Ok(Some(MatArray {
                name,
                dims,
                class,
                logical,
                complex,
                data: MatData::Skipped,
            }));
        }
        if dims.len() < 2 {
            return Err(self.err(
                name_tag.next,
                var,
                format!("{} dimensions, MATLAB arrays have at least 2", dims.len()),
            ));
        }
        let count = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
        let dims_text = dims
            .iter()
            .map(|d| d.to_string())
            .collect::<Vec<_>>()
            .join("×");
        let Some(count) = count else {
            return Err(self.err(
                name_tag.next,
                var,
                format!("dimensions {dims_text} overflow the element count"),
            ));
        };

        let real = self.tag(name_tag.next, end, var)?;
        let real_at = real.at;
        let Some(size) = numeric_size(real.ty) else {
            return Err(self.err(
                real_at,
                var,
                format!(
                    "real part stored as type {} ({}), expected a numeric type",
                    real.ty,
                    type_name(real.ty)
                ),
            ));
        };
        if real.len % size != 0 || real.len / size != count {
            return Err(self.err(
                real_at,
                var,
                format!(
                    "dimensions {dims_text} declare {count} values but the real part holds {} bytes of {} ({size} bytes each)",
                    real.len,
                    type_name(real.ty)
                ),
            ));
        }
        let raw = &self.bytes[real.data..real.data + real.len];
        let data = if class == MatClass::Uint8 {
            match decode_u8(self.order, real.ty, raw) {
                Ok(v) => MatData::U8(v),
                Err(k) => {
                    return Err(self.err(
                        real.data + k * size,
                        var,
                        format!(
                            "value {k} of a uint8 array is not an integer in 0..=255 \
                             (stored as {})",
                            type_name(real.ty)
                        ),
                    ));
                }
            }
        } else {
            MatData::F64(decode_f64(self.order, real.ty, raw))
        };
        Ok(Some(MatArray {
            name,
            dims,
            class,
            logical,
            complex,
            data,
        }))
    }
}

/// Inflates the zlib stream of the miCOMPRESSED element at file offset `at`:
/// returns the contained element (tag included). The output grows only as
/// bytes arrive, so a stream that declares more than it holds costs nothing.
fn inflate(file: &str, order: Order, z: &[u8], at: usize) -> Result<Vec<u8>> {
    let fail = |msg: String| {
        Error::format(
            file,
            format!("byte {at}: compressed element ({} bytes): {msg}", z.len()),
        )
    };
    let mut dec = flate2::read::ZlibDecoder::new(z);
    let mut head = [0u8; 8];
    dec.read_exact(&mut head).map_err(|e| {
        fail(format!(
            "cannot inflate the 8-byte tag of the element inside: {e}"
        ))
    })?;
    let ty = order.u32([head[0], head[1], head[2], head[3]]);
    if ty != MI_MATRIX {
        return Err(fail(format!(
            "holds a data element of type {ty} ({}), expected miMATRIX (14)",
            type_name(ty)
        )));
    }
    let len = order.u32([head[4], head[5], head[6], head[7]]) as usize;
    // A modest first allocation; read_to_end doubles as data arrive.
    let mut out = Vec::with_capacity((8 + len).min(16 * z.len() + 4096));
    out.extend_from_slice(&head);
    let got = (&mut dec)
        .take(len as u64)
        .read_to_end(&mut out)
        .map_err(|e| fail(format!("corrupt zlib data: {e}")))?;
    if got < len {
        return Err(fail(format!(
            "zlib stream ends after {} inflated bytes, its element declares {}",
            8 + got,
            8 + len
        )));
    }
    // Drain to the end of the stream so that its Adler-32 checksum is
    // verified (MATLAB streams end with the element; stop after 1 MiB of
    // unexpected trailing data rather than inflate without bound).
    std::io::copy(&mut dec.take(1 << 20), &mut std::io::sink())
        .map_err(|e| fail(format!("corrupt zlib data after the element: {e}")))?;
    Ok(out)
}

macro_rules! decode_as {
    ($raw:expr, $order:expr, $t:ty, $n:expr) => {
        $raw.chunks_exact($n)
            .map(|c| {
                let b: [u8; $n] = c.try_into().expect("chunks_exact gives $n bytes");
                (match $order {
                    Order::Le => <$t>::from_le_bytes(b),
                    Order::Be => <$t>::from_be_bytes(b),
                }) as f64
            })
            .collect()
    };
}

/// Decodes values of storage type `ty` (a numeric type) to `f64`.
fn decode_f64(order: Order, ty: u32, raw: &[u8]) -> Vec<f64> {
    match ty {
        MI_INT8 => raw.iter().map(|&b| f64::from(b as i8)).collect(),
        MI_UINT8 => raw.iter().map(|&b| f64::from(b)).collect(),
        MI_INT16 => decode_as!(raw, order, i16, 2),
        MI_UINT16 => decode_as!(raw, order, u16, 2),
        MI_INT32 => decode_as!(raw, order, i32, 4),
        MI_UINT32 => decode_as!(raw, order, u32, 4),
        MI_SINGLE => decode_as!(raw, order, f32, 4),
        MI_DOUBLE => decode_as!(raw, order, f64, 8),
        MI_INT64 => decode_as!(raw, order, i64, 8),
        MI_UINT64 => decode_as!(raw, order, u64, 8),
        _ => unreachable!("decode_f64 is only called for numeric storage types"),
    }
}

/// Decodes values of storage type `ty` to bytes; `Err(k)` when value `k` is
/// not an integer in 0..=255.
fn decode_u8(order: Order, ty: u32, raw: &[u8]) -> Result<Vec<u8>, usize> {
    if ty == MI_UINT8 {
        return Ok(raw.to_vec());
    }
    decode_f64(order, ty, raw)
        .into_iter()
        .enumerate()
        .map(|(k, v)| {
            if v.fract() == 0.0 && (0.0..=255.0).contains(&v) {
                Ok(v as u8)
            } else {
                Err(k)
            }
        })
        .collect()
}
