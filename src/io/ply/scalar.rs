//! Encoding and decoding of PLY scalars (binary either endianness, ASCII).

use crate::model::{ScalarData, ScalarType};

/// A Rust type that stores one PLY scalar type.
pub trait Scalar: Copy + Default + PartialEq + std::fmt::Debug + 'static {
    /// The PLY type.
    const TYPE: ScalarType;
    /// Size in bytes.
    const SIZE: usize;
    /// Decodes from exactly `SIZE` bytes.
    fn from_bytes(b: &[u8], big_endian: bool) -> Self;
    /// Appends the encoding.
    fn put(self, out: &mut Vec<u8>, big_endian: bool);
    /// Parses an ASCII token (integers must be in range and integral).
    fn parse_ascii(s: &str) -> Option<Self>;
    /// Appends the ASCII form (floats: shortest text that reads back exactly).
    fn fmt_ascii(self, out: &mut String);
    /// Wraps a vector of this type.
    fn wrap(v: Vec<Self>) -> ScalarData;
    /// Borrows the vector of this type out of a column, if the types match.
    fn unwrap(d: &ScalarData) -> Option<&[Self]>;
    /// Mutable access to the vector of this type, if the types match.
    fn unwrap_mut(d: &mut ScalarData) -> Option<&mut Vec<Self>>;
    /// Converts to f64 (exact).
    fn to_f64(self) -> f64;
}

macro_rules! int_scalar {
    ($t:ty, $v:ident, $n:expr) => {
        impl Scalar for $t {
            const TYPE: ScalarType = ScalarType::$v;
            const SIZE: usize = $n;
            #[inline(always)]
            fn from_bytes(b: &[u8], big_endian: bool) -> Self {
                let a: [u8; $n] = b[..$n].try_into().unwrap();
                if big_endian {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }
            #[inline(always)]
            fn put(self, out: &mut Vec<u8>, big_endian: bool) {
                if big_endian {
                    out.extend_from_slice(&self.to_be_bytes())
                } else {
                    out.extend_from_slice(&self.to_le_bytes())
                }
            }
            fn parse_ascii(s: &str) -> Option<Self> {
                s.parse::<$t>().ok().or_else(|| {
                    // Some writers print integers as floats ("3.0"); accept
                    // them only when integral and in range.
                    let f: f64 = s.parse().ok()?;
                    (f.fract() == 0.0 && f >= <$t>::MIN as f64 && f <= <$t>::MAX as f64)
                        .then_some(f as $t)
                })
            }
            fn fmt_ascii(self, out: &mut String) {
                use std::fmt::Write;
                let _ = write!(out, "{}", self);
            }
            fn wrap(v: Vec<Self>) -> ScalarData {
                ScalarData::$v(v)
            }
            fn unwrap(d: &ScalarData) -> Option<&[Self]> {
                match d {
                    ScalarData::$v(v) => Some(v),
                    _ => None,
                }
            }
            fn unwrap_mut(d: &mut ScalarData) -> Option<&mut Vec<Self>> {
                match d {
                    ScalarData::$v(v) => Some(v),
                    _ => None,
                }
            }
            fn to_f64(self) -> f64 {
                self as f64
            }
        }
    };
}

macro_rules! float_scalar {
    ($t:ty, $v:ident, $n:expr) => {
        impl Scalar for $t {
            const TYPE: ScalarType = ScalarType::$v;
            const SIZE: usize = $n;
            #[inline(always)]
            fn from_bytes(b: &[u8], big_endian: bool) -> Self {
                let a: [u8; $n] = b[..$n].try_into().unwrap();
                if big_endian {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }
            #[inline(always)]
            fn put(self, out: &mut Vec<u8>, big_endian: bool) {
                if big_endian {
                    out.extend_from_slice(&self.to_be_bytes())
                } else {
                    out.extend_from_slice(&self.to_le_bytes())
                }
            }
            fn parse_ascii(s: &str) -> Option<Self> {
                s.parse::<$t>().ok()
            }
            fn fmt_ascii(self, out: &mut String) {
                use std::fmt::Write;
                // `{:?}` is the shortest representation that parses back to the
                // same value (exponent form for very large/small magnitudes).
                let _ = write!(out, "{:?}", self);
            }
            fn wrap(v: Vec<Self>) -> ScalarData {
                ScalarData::$v(v)
            }
            fn unwrap(d: &ScalarData) -> Option<&[Self]> {
                match d {
                    ScalarData::$v(v) => Some(v),
                    _ => None,
                }
            }
            fn unwrap_mut(d: &mut ScalarData) -> Option<&mut Vec<Self>> {
                match d {
                    ScalarData::$v(v) => Some(v),
                    _ => None,
                }
            }
            fn to_f64(self) -> f64 {
                self as f64
            }
        }
    };
}

int_scalar!(i8, I8, 1);
int_scalar!(u8, U8, 1);
int_scalar!(i16, I16, 2);
int_scalar!(u16, U16, 2);
int_scalar!(i32, I32, 4);
int_scalar!(u32, U32, 4);
float_scalar!(f32, F32, 4);
float_scalar!(f64, F64, 8);

/// Calls `$f::<T>($args)` with `T` the Rust type of PLY type `$ty`.
#[macro_export]
#[doc(hidden)]
macro_rules! dispatch_scalar {
    ($ty:expr, $f:ident ( $($args:expr),* )) => {
        match $ty {
            $crate::model::ScalarType::I8 => $f::<i8>($($args),*),
            $crate::model::ScalarType::U8 => $f::<u8>($($args),*),
            $crate::model::ScalarType::I16 => $f::<i16>($($args),*),
            $crate::model::ScalarType::U16 => $f::<u16>($($args),*),
            $crate::model::ScalarType::I32 => $f::<i32>($($args),*),
            $crate::model::ScalarType::U32 => $f::<u32>($($args),*),
            $crate::model::ScalarType::F32 => $f::<f32>($($args),*),
            $crate::model::ScalarType::F64 => $f::<f64>($($args),*),
        }
    };
}

/// Reads a list length of type `t` at `b` as a signed integer (so a negative
/// count is caught rather than wrapped).
pub fn read_count(t: ScalarType, b: &[u8], big_endian: bool) -> i64 {
    match t {
        ScalarType::I8 => i8::from_bytes(b, big_endian) as i64,
        ScalarType::U8 => u8::from_bytes(b, big_endian) as i64,
        ScalarType::I16 => i16::from_bytes(b, big_endian) as i64,
        ScalarType::U16 => u16::from_bytes(b, big_endian) as i64,
        ScalarType::I32 => i32::from_bytes(b, big_endian) as i64,
        ScalarType::U32 => u32::from_bytes(b, big_endian) as i64,
        // Float counts are rejected by the header parser.
        ScalarType::F32 | ScalarType::F64 => -1,
    }
}

/// Largest list length a count type can hold.
pub fn max_count(t: ScalarType) -> u64 {
    match t {
        ScalarType::I8 => i8::MAX as u64,
        ScalarType::U8 => u8::MAX as u64,
        ScalarType::I16 => i16::MAX as u64,
        ScalarType::U16 => u16::MAX as u64,
        ScalarType::I32 => i32::MAX as u64,
        ScalarType::U32 => u32::MAX as u64,
        ScalarType::F32 | ScalarType::F64 => 0,
    }
}

/// Appends a list length in count type `t`.
pub fn put_count(t: ScalarType, n: usize, out: &mut Vec<u8>, big_endian: bool) {
    match t {
        ScalarType::I8 => (n as i8).put(out, big_endian),
        ScalarType::U8 => (n as u8).put(out, big_endian),
        ScalarType::I16 => (n as i16).put(out, big_endian),
        ScalarType::U16 => (n as u16).put(out, big_endian),
        ScalarType::I32 => (n as i32).put(out, big_endian),
        ScalarType::U32 => (n as u32).put(out, big_endian),
        ScalarType::F32 | ScalarType::F64 => unreachable!("float list counts are rejected"),
    }
}
