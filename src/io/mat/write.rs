//! The MAT-file writer: little-endian Level 5, optionally zlib-compressed.

use std::io::Write;

use super::*;
use crate::io::source::werr;
use crate::{Error, Result};

/// Writes `arrays` as a little-endian Level 5 MAT-file, each variable wrapped
/// in an `miCOMPRESSED` (zlib) element when `compress` is set.
///
/// Storage: `double` as `miDOUBLE`, `single` as `miSINGLE`, each integer class
/// in its own type (`int8` as `miINT8`, …), logical arrays as `miUINT8` with
/// the logical flag. Files are readable by MATLAB and `scipy.io.loadmat`.
///
/// Errors ([`Error::Invalid`], naming the variable): a name that is not a
/// MATLAB identifier (letter, then letters, digits, `_`; at most 63), rank < 2,
/// a dimension above `i32::MAX`, a value count that differs from the product
/// of the dimensions, a value not exactly representable in the class (e.g.
/// 1.5 or 300 for `uint8`), a logical flag on a class other than `uint8`, a
/// skipped, complex or non-numeric variable, or a variable larger than the
/// 4 GiB a v5 element can hold. Write failures are [`Error::Io`] via
/// [`werr`].
pub fn write_mat(w: &mut dyn Write, arrays: &[MatArray], compress: bool) -> Result<()> {
    let mut header = [b' '; HEADER_LEN];
    let text = b"MATLAB 5.0 MAT-file, Platform: splatkit, Created by: splatkit (Rust)";
    header[..text.len()].copy_from_slice(text);
    header[116..124].fill(0);
    header[124..126].copy_from_slice(&0x0100u16.to_le_bytes());
    header[126..128].copy_from_slice(b"IM");
    w.write_all(&header).map_err(werr)?;
    for a in arrays {
        let element = encode_matrix(a)?;
        if compress {
            let mut z = flate2::write::ZlibEncoder::new(
                Vec::with_capacity(element.len() / 4 + 64),
                flate2::Compression::default(),
            );
            z.write_all(&element).map_err(werr)?;
            let z = z.finish().map_err(werr)?;
            let len = u32::try_from(z.len()).map_err(|_| too_large(&a.name))?;
            w.write_all(&MI_COMPRESSED.to_le_bytes()).map_err(werr)?;
            w.write_all(&len.to_le_bytes()).map_err(werr)?;
            w.write_all(&z).map_err(werr)?;
        } else {
            w.write_all(&element).map_err(werr)?;
        }
    }
    Ok(())
}

fn too_large(name: &str) -> Error {
    Error::invalid(format!(
        "MAT-file variable '{name}' is larger than the 4 GiB a Level 5 element can hold"
    ))
}

/// Appends a sub-element (tag, data, zero padding to 8 bytes).
fn push_element(out: &mut Vec<u8>, ty: u32, data: &[u8]) {
    out.extend_from_slice(&ty.to_le_bytes());
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out.extend_from_slice(data);
    out.resize(out.len() + data.len().div_ceil(8) * 8 - data.len(), 0);
}

/// The storage type and little-endian bytes of the real part of `a`.
fn encode_values(a: &MatArray) -> Result<(u32, Vec<u8>)> {
    let bad = |k: usize, v: f64| {
        Error::invalid(format!(
            "MAT-file variable '{}': value {k} ({v}) is not representable as {}",
            a.name,
            a.class.name()
        ))
    };
    let vals = match &a.data {
        MatData::U8(v) if a.class == MatClass::Uint8 => return Ok((MI_UINT8, v.clone())),
        MatData::U8(_) => {
            return Err(Error::invalid(format!(
                "MAT-file variable '{}': byte data with class {}; byte data must be class uint8",
                a.name,
                a.class.name()
            )));
        }
        MatData::Skipped => {
            return Err(Error::invalid(format!(
                "MAT-file variable '{}' is {} and was not decoded; it cannot be written",
                a.name,
                a.describe()
            )));
        }
        MatData::F64(v) => v,
    };
    macro_rules! ints {
        ($t:ty, $ty:expr) => {{
            let mut out = Vec::with_capacity(vals.len() * size_of::<$t>());
            for (k, &v) in vals.iter().enumerate() {
                // MIN is 0 or a power of two and MAX + 1 a power of two, so
                // both bounds are exact in f64 (MAX itself rounds up to
                // MAX + 1 for 64-bit types, and adding 1 then changes nothing).
                let lo = <$t>::MIN as f64;
                let hi = <$t>::MAX as f64 + 1.0;
                if v.fract() != 0.0 || !(v >= lo && v < hi) {
                    return Err(bad(k, v));
                }
                out.extend_from_slice(&(v as $t).to_le_bytes());
            }
            Ok(($ty, out))
        }};
    }
    match a.class {
        MatClass::Double => Ok((
            MI_DOUBLE,
            vals.iter().flat_map(|v| v.to_le_bytes()).collect(),
        )),
        MatClass::Single => {
            let mut out = Vec::with_capacity(vals.len() * 4);
            for (k, &v) in vals.iter().enumerate() {
                let f = v as f32;
                if f64::from(f) != v && !v.is_nan() {
                    return Err(bad(k, v));
                }
                out.extend_from_slice(&f.to_le_bytes());
            }
            Ok((MI_SINGLE, out))
        }
        MatClass::Int8 => ints!(i8, MI_INT8),
        MatClass::Uint8 => ints!(u8, MI_UINT8),
        MatClass::Int16 => ints!(i16, MI_INT16),
        MatClass::Uint16 => ints!(u16, MI_UINT16),
        MatClass::Int32 => ints!(i32, MI_INT32),
        MatClass::Uint32 => ints!(u32, MI_UINT32),
        MatClass::Int64 => ints!(i64, MI_INT64),
        MatClass::Uint64 => ints!(u64, MI_UINT64),
        other => Err(Error::invalid(format!(
            "MAT-file variable '{}' has class {}; only numeric arrays can be written",
            a.name,
            other.name()
        ))),
    }
}

/// The complete miMATRIX element (tag included) for `a`.
fn encode_matrix(a: &MatArray) -> Result<Vec<u8>> {
    let name = &a.name;
    let ok_name = name.len() <= 63
        && name.bytes().next().is_some_and(|c| c.is_ascii_alphabetic())
        && name.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_');
    if !ok_name {
        return Err(Error::invalid(format!(
            "MAT-file variable name '{name}' is not a MATLAB identifier \
             (a letter, then letters, digits or '_', at most 63 characters)"
        )));
    }
    if a.complex {
        return Err(Error::invalid(format!(
            "MAT-file variable '{name}': complex arrays cannot be written"
        )));
    }
    if a.logical && a.class != MatClass::Uint8 {
        return Err(Error::invalid(format!(
            "MAT-file variable '{name}': the logical flag needs class uint8, not {}",
            a.class.name()
        )));
    }
    if a.dims.len() < 2 {
        return Err(Error::invalid(format!(
            "MAT-file variable '{name}': {} dimensions, MATLAB arrays have at least 2",
            a.dims.len()
        )));
    }
    let mut dims = Vec::with_capacity(4 * a.dims.len());
    for &d in &a.dims {
        let d = i32::try_from(d).map_err(|_| {
            Error::invalid(format!(
                "MAT-file variable '{name}': dimension {d} exceeds the Level 5 limit of {}",
                i32::MAX
            ))
        })?;
        dims.extend_from_slice(&d.to_le_bytes());
    }
    let count = a.dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
    if a.is_numeric() && count != Some(a.len()) {
        return Err(Error::invalid(format!(
            "MAT-file variable '{name}': dimensions {:?} need {} values, the data hold {}",
            a.dims,
            count.map_or("too many".to_string(), |c| c.to_string()),
            a.len()
        )));
    }
    let (ty, values) = encode_values(a)?;

    let mut body = Vec::with_capacity(64 + values.len());
    let mut flags = [0u8; 8];
    let word = u32::from(a.class.id()) | if a.logical { FLAG_LOGICAL } else { 0 };
    flags[..4].copy_from_slice(&word.to_le_bytes());
    push_element(&mut body, MI_UINT32, &flags);
    push_element(&mut body, MI_INT32, &dims);
    if (1..=4).contains(&name.len()) {
        // Small data element: byte count in the upper half of the first word.
        let word = ((name.len() as u32) << 16) | MI_INT8;
        body.extend_from_slice(&word.to_le_bytes());
        let mut data = [0u8; 4];
        data[..name.len()].copy_from_slice(name.as_bytes());
        body.extend_from_slice(&data);
    } else {
        push_element(&mut body, MI_INT8, name.as_bytes());
    }
    if u32::try_from(values.len()).is_err() {
        return Err(too_large(name));
    }
    push_element(&mut body, ty, &values);

    let body_len = u32::try_from(body.len()).map_err(|_| too_large(name))?;
    let mut out = Vec::with_capacity(8 + body.len());
    out.extend_from_slice(&MI_MATRIX.to_le_bytes());
    out.extend_from_slice(&body_len.to_le_bytes());
    out.extend_from_slice(&body);
    Ok(out)
}
