//! PyTorch checkpoints (`torch.save` zip archives, torch ≥ 1.6) read and
//! written without Python, and the Triangle Splatting model file
//! `point_cloud_state_dict.pt` converted to and from [`TriangleSoup`].
//!
//! Reading: the zip container is opened (stored records are used in place),
//! `data.pkl` runs through a small pickle virtual machine that never executes
//! anything (it recognises `torch._utils._rebuild_tensor_v2`,
//! `_rebuild_parameter`, `collections.OrderedDict`, the storage classes and
//! dtypes; everything else becomes an opaque value), and tensors are copied out
//! of their `data/<key>` storage records honouring storage offset, sizes and
//! strides. Every declared size is checked against the bytes present before
//! anything is allocated; every malformed input is an [`Error`] naming the
//! file and where (byte offset in `data.pkl`, zip record, or dict key).
//!
//! Supported element types: f16, bf16, f32, f64 (read as f32 where the model
//! wants f32) and the integer types; byte order from the `byteorder` record.
//! The legacy pre-1.6 formats (raw pickle stream, tar) are recognised and
//! rejected with a message.

mod pickle;
mod zip;

use std::borrow::Cow;
use std::io::Write;
use std::path::Path;

pub use pickle::DType;
use pickle::{PickleWriter, Value};

use crate::io::read_input;
use crate::io::source::werr;
use crate::model::attributes::Property;
use crate::model::{Column, ScalarData, TriangleSoup};
use crate::{Error, Result};

/// Shape and location of one tensor of a checkpoint (its values are read on
/// demand with [`TorchCheckpoint::tensor_f32`] / [`TorchCheckpoint::tensor_i64`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TensorInfo {
    /// Element type of the storage.
    pub dtype: DType,
    /// Sizes, outermost first (PyTorch order).
    pub shape: Vec<usize>,
    /// First element, in elements from the start of the storage.
    offset: u64,
    /// Strides in elements, one per dimension.
    stride: Vec<u64>,
    /// Record name under `data/`.
    storage_key: String,
    /// Elements the persistent id declares for the storage.
    storage_numel: u64,
}

impl TensorInfo {
    /// Number of elements (product of the shape).
    pub fn numel(&self) -> usize {
        self.shape.iter().product()
    }
}

/// One value of a checkpoint's top-level dict.
#[derive(Clone, Debug, PartialEq)]
pub enum PtValue {
    /// A tensor or `nn.Parameter`.
    Tensor(TensorInfo),
    /// A Python int that fits in i64.
    Int(i64),
    /// A Python float.
    Float(f64),
    /// A Python bool.
    Bool(bool),
    /// A Python str.
    Str(String),
    /// `None`.
    None,
    /// Anything else (lists, nested dicts, unknown objects), described.
    Other(String),
}

/// A parsed `torch.save` file whose top-level object is a dict (plain or
/// `OrderedDict`), borrowing the file's bytes.
pub struct TorchCheckpoint<'a> {
    name: String,
    archive: zip::TorchArchive<'a>,
    entries: Vec<(String, PtValue)>,
}

impl std::fmt::Debug for TorchCheckpoint<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TorchCheckpoint")
            .field("name", &self.name)
            .field("entries", &self.entries)
            .finish()
    }
}

fn to_pt_value(v: &Value) -> Result<PtValue, String> {
    Ok(match v {
        Value::Tensor(t) => {
            let mut shape = Vec::with_capacity(t.size.len());
            for &s in &t.size {
                shape.push(usize::try_from(s).map_err(|_| format!("tensor size {s} too large"))?);
            }
            PtValue::Tensor(TensorInfo {
                dtype: t.storage.dtype,
                shape,
                offset: t.offset,
                stride: t.stride.clone(),
                storage_key: t.storage.key.clone(),
                storage_numel: t.storage.numel,
            })
        }
        Value::Int(i) => PtValue::Int(*i),
        Value::Float(f) => PtValue::Float(*f),
        Value::Bool(b) => PtValue::Bool(*b),
        Value::Str(s) => PtValue::Str(s.to_string()),
        Value::None => PtValue::None,
        other => PtValue::Other(other.kind()),
    })
}

/// The largest `data.pkl` inflated: the pickle holds only names, shapes
/// and storage keys (a few KB for a Triangle Splatting model).
const MAX_PICKLE_BYTES: u64 = 64 << 20;

impl<'a> TorchCheckpoint<'a> {
    /// Parses the archive in `bytes`; `name` is used in error messages.
    pub fn parse(name: &str, bytes: &'a [u8]) -> Result<Self> {
        let archive = zip::TorchArchive::open(bytes).map_err(|m| Error::format(name, m))?;
        let pkl = archive
            .record_capped("data.pkl", MAX_PICKLE_BYTES)
            .map_err(|m| Error::format(name, m))?
            .ok_or_else(|| {
                Error::format(
                    name,
                    format!("zip archive has no record {}data.pkl", archive.prefix),
                )
            })?;
        let root = pickle::unpickle(&pkl).map_err(|e| {
            Error::format(
                name,
                format!("{}data.pkl byte {}: {}", archive.prefix, e.offset, e.msg),
            )
        })?;
        let Value::Dict(map) = &root else {
            return Err(Error::format(
                name,
                format!(
                    "{}data.pkl holds {}, expected a dict of tensors",
                    archive.prefix,
                    root.kind()
                ),
            ));
        };
        let mut entries = Vec::with_capacity(map.items.len());
        for (k, v) in &map.items {
            let Value::Str(k) = k else { continue };
            let v = to_pt_value(v).map_err(|m| Error::format(name, format!("key {k:?}: {m}")))?;
            entries.push((k.to_string(), v));
        }
        Ok(TorchCheckpoint {
            name: name.to_string(),
            archive,
            entries,
        })
    }

    /// The file name used in errors.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The top-level entries with string keys, in file order.
    pub fn entries(&self) -> &[(String, PtValue)] {
        &self.entries
    }

    /// The value of `key`, if present.
    pub fn get(&self, key: &str) -> Option<&PtValue> {
        self.entries.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }

    fn err(&self, key: &str, msg: impl std::fmt::Display) -> Error {
        Error::format(&self.name, format!("key {key:?}: {msg}"))
    }

    /// The tensor `key`; an error names the key when it is absent or not a tensor.
    pub fn tensor(&self, key: &str) -> Result<&TensorInfo> {
        match self.get(key) {
            Some(PtValue::Tensor(t)) => Ok(t),
            Some(other) => Err(self.err(key, format!("expected a tensor, found {other:?}"))),
            None => Err(Error::format(
                &self.name,
                format!("missing key {key:?} (keys present: {})", self.key_list()),
            )),
        }
    }

    /// The first keys of the file, for messages.
    fn key_list(&self) -> String {
        const SHOWN: usize = 12;
        let mut keys: Vec<&str> = self
            .entries
            .iter()
            .take(SHOWN)
            .map(|(k, _)| k.as_str())
            .collect();
        if self.entries.len() > SHOWN {
            keys.push("...");
        }
        keys.join(", ")
    }

    /// Checks the view against its storage record and returns the record's
    /// bytes. The view must fit inside the storage, and its element count may
    /// not exceed the storage's (so no read allocates more than the file holds).
    fn storage(&self, key: &str, t: &TensorInfo) -> Result<Cow<'a, [u8]>> {
        let es = t.dtype.size() as u64;
        let rec = format!("data/{}", t.storage_key);
        let declared = t
            .storage_numel
            .checked_mul(es)
            .ok_or_else(|| self.err(key, "storage size overflows"))?;
        // A compressed record is inflated only up to what the storage needs.
        let bytes = self
            .archive
            .record_capped(&rec, declared)
            .map_err(|m| self.err(key, m))?
            .ok_or_else(|| self.err(key, format!("zip archive has no record {rec}")))?;
        if declared > bytes.len() as u64 {
            return Err(self.err(
                key,
                format!(
                    "storage {rec} declares {} {} values ({declared} bytes) but the record holds {} bytes",
                    t.storage_numel,
                    t.dtype.torch_name(),
                    bytes.len()
                ),
            ));
        }
        let numel = t
            .shape
            .iter()
            .try_fold(1u64, |a, &s| a.checked_mul(s as u64))
            .ok_or_else(|| self.err(key, "shape product overflows"))?;
        if numel == 0 {
            return Ok(bytes);
        }
        if numel > t.storage_numel {
            return Err(self.err(
                key,
                format!(
                    "shape {:?} has {numel} elements, more than its storage's {}",
                    t.shape, t.storage_numel
                ),
            ));
        }
        let mut last = t.offset;
        for (&s, &st) in t.shape.iter().zip(&t.stride) {
            last = (s as u64 - 1)
                .checked_mul(st)
                .and_then(|x| x.checked_add(last))
                .ok_or_else(|| self.err(key, "stride extent overflows"))?;
        }
        if last >= t.storage_numel {
            return Err(self.err(
                key,
                format!(
                    "view (offset {}, shape {:?}, stride {:?}) reaches element {last}, past the storage's {} elements",
                    t.offset, t.shape, t.stride, t.storage_numel
                ),
            ));
        }
        Ok(bytes)
    }

    /// The values of `t` in row-major order, each decoded from its
    /// little-endian bytes by `conv`. `native` says that those bytes are
    /// already `T`'s representation (no conversion), which lets contiguous
    /// views on little-endian hosts be copied in one go.
    fn gather<T: bytemuck::Pod, F: Fn(&[u8]) -> T>(
        &self,
        key: &str,
        t: &TensorInfo,
        native: bool,
        conv: F,
    ) -> Result<Vec<T>> {
        let bytes = self.storage(key, t)?;
        let es = t.dtype.size();
        let numel = t.numel();
        let mut out = Vec::with_capacity(numel);
        if numel == 0 {
            return Ok(out);
        }
        let big = self.archive.big_endian && es > 1;
        let decode = |b: &[u8]| -> T {
            if big {
                let mut le = [0u8; 8];
                le[..es].copy_from_slice(b);
                le[..es].reverse();
                conv(&le[..es])
            } else {
                conv(b)
            }
        };
        // Contiguous views (the usual case) are one slice.
        let mut contiguous = true;
        let mut expect = 1u64;
        for (&s, &st) in t.shape.iter().zip(&t.stride).rev() {
            if s != 1 && st != expect {
                contiguous = false;
            }
            expect *= s as u64;
        }
        let base = t.offset as usize * es;
        if contiguous {
            let src = &bytes[base..base + numel * es];
            if native && !big && cfg!(target_endian = "little") && es == size_of::<T>() {
                // Byte copy into a fresh, aligned Vec<T>.
                return Ok(bytemuck::pod_collect_to_vec(src));
            }
            out.extend(src.chunks_exact(es).map(decode));
            return Ok(out);
        }
        let rank = t.shape.len();
        let mut idx = vec![0usize; rank];
        let stride: Vec<usize> = t.stride.iter().map(|&s| s as usize).collect();
        let mut pos = t.offset as usize;
        for _ in 0..numel {
            let at = pos * es;
            out.push(decode(&bytes[at..at + es]));
            // Odometer increment, innermost dimension first. Wrapping
            // arithmetic: only the final carry may leave the checked range
            // (it is never read), and a size-1 dimension may have any stride.
            for d in (0..rank).rev() {
                idx[d] += 1;
                pos = pos.wrapping_add(stride[d]);
                if idx[d] < t.shape[d] {
                    break;
                }
                pos = pos.wrapping_sub(stride[d].wrapping_mul(t.shape[d]));
                idx[d] = 0;
            }
        }
        Ok(out)
    }

    /// The values of the floating-point tensor `key` as f32, row-major
    /// (f16 / bf16 exactly, f64 rounded), with its shape.
    pub fn tensor_f32(&self, key: &str) -> Result<(Vec<usize>, Vec<f32>)> {
        let t = self.tensor(key)?;
        let v = match t.dtype {
            DType::F32 => self.gather(key, t, true, |b| {
                f32::from_le_bytes([b[0], b[1], b[2], b[3]])
            })?,
            DType::F16 => self.gather(key, t, false, |b| {
                half::f16::from_bits(u16::from_le_bytes([b[0], b[1]])).to_f32()
            })?,
            DType::BF16 => self.gather(key, t, false, |b| {
                half::bf16::from_bits(u16::from_le_bytes([b[0], b[1]])).to_f32()
            })?,
            DType::F64 => self.gather(key, t, false, |b| {
                f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]) as f32
            })?,
            other => {
                return Err(self.err(
                    key,
                    format!(
                        "expected a floating-point tensor, found {}",
                        other.torch_name()
                    ),
                ));
            }
        };
        Ok((t.shape.clone(), v))
    }

    /// The values of the integer (or bool) tensor `key` as i64, row-major,
    /// with its shape.
    pub fn tensor_i64(&self, key: &str) -> Result<(Vec<usize>, Vec<i64>)> {
        let t = self.tensor(key)?;
        let v = match t.dtype {
            DType::U8 | DType::Bool => self.gather(key, t, false, |b| b[0] as i64)?,
            DType::I8 => self.gather(key, t, false, |b| b[0] as i8 as i64)?,
            DType::I16 => {
                self.gather(key, t, false, |b| i16::from_le_bytes([b[0], b[1]]) as i64)?
            }
            DType::I32 => self.gather(key, t, false, |b| {
                i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as i64
            })?,
            DType::I64 => self.gather(key, t, true, |b| {
                i64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])
            })?,
            DType::U16 => {
                self.gather(key, t, false, |b| u16::from_le_bytes([b[0], b[1]]) as i64)?
            }
            DType::U32 => self.gather(key, t, false, |b| {
                u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as i64
            })?,
            DType::U64 => {
                let v = self.gather(key, t, true, |b| {
                    u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])
                })?;
                let mut out = Vec::with_capacity(v.len());
                for x in v {
                    out.push(i64::try_from(x).map_err(|_| {
                        self.err(key, format!("uint64 value {x} does not fit in int64"))
                    })?);
                }
                out
            }
            other => {
                return Err(self.err(
                    key,
                    format!("expected an integer tensor, found {}", other.torch_name()),
                ));
            }
        };
        Ok((t.shape.clone(), v))
    }

    /// A per-item column for `key` when it is a numeric tensor of shape
    /// `[n]` or `[n, 1]`: f16/bf16/f32 → F32, f64 → F64, u8/bool → U8,
    /// i8 → I8, i16 → I16, u16 → U16, i32 → I32, u32 → U32, i64/u64 → I32
    /// when every value fits, else F64.
    fn item_column(&self, key: &str, n: usize) -> Result<Option<ScalarData>> {
        let Some(PtValue::Tensor(t)) = self.get(key) else {
            return Ok(None);
        };
        let ok_shape = matches!(t.shape.as_slice(), [a] | [a, 1] if *a == n);
        if !ok_shape {
            return Ok(None);
        }
        Ok(Some(match t.dtype {
            DType::F16 | DType::BF16 | DType::F32 => ScalarData::F32(self.tensor_f32(key)?.1),
            DType::F64 => ScalarData::F64(self.gather(key, t, true, |b| {
                f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])
            })?),
            DType::U8 | DType::Bool => ScalarData::U8(self.gather(key, t, true, |b| b[0])?),
            DType::I8 => ScalarData::I8(self.gather(key, t, true, |b| b[0] as i8)?),
            DType::I16 => {
                ScalarData::I16(self.gather(key, t, true, |b| i16::from_le_bytes([b[0], b[1]]))?)
            }
            DType::I32 => ScalarData::I32(self.gather(key, t, true, |b| {
                i32::from_le_bytes([b[0], b[1], b[2], b[3]])
            })?),
            DType::U16 => {
                ScalarData::U16(self.gather(key, t, true, |b| u16::from_le_bytes([b[0], b[1]]))?)
            }
            DType::U32 => ScalarData::U32(self.gather(key, t, true, |b| {
                u32::from_le_bytes([b[0], b[1], b[2], b[3]])
            })?),
            DType::I64 | DType::U64 => {
                let v = self.tensor_i64(key)?.1;
                if v.iter().all(|&x| i32::try_from(x).is_ok()) {
                    ScalarData::I32(v.into_iter().map(|x| x as i32).collect())
                } else {
                    ScalarData::F64(v.into_iter().map(|x| x as f64).collect())
                }
            }
        }))
    }

    /// An int entry (absent → `None`).
    fn int(&self, key: &str) -> Result<Option<i64>> {
        match self.get(key) {
            None => Ok(None),
            Some(PtValue::Int(i)) => Ok(Some(*i)),
            Some(PtValue::Bool(b)) => Ok(Some(*b as i64)),
            Some(PtValue::Tensor(t)) if t.numel() == 1 && !t.dtype.is_float() => {
                Ok(Some(self.tensor_i64(key)?.1[0]))
            }
            Some(other) => Err(self.err(key, format!("expected an int, found {other:?}"))),
        }
    }
}

/// Reads a Triangle Splatting checkpoint (`point_cloud_state_dict.pt`, or
/// `-` for stdin). See [`parse_triangle_checkpoint`].
pub fn read_triangle_checkpoint(path: &Path) -> Result<TriangleSoup> {
    let input = read_input(path)?;
    parse_triangle_checkpoint(&input.name, &input)
}

/// Keys the triangle reader interprets (others of per-triangle shape go to
/// `extras.item`).
const KNOWN_KEYS: [&str; 8] = [
    "triangles_points",
    "sigma",
    "opacity",
    "features_dc",
    "features_rest",
    "active_sh_degree",
    "_triangle_indices",
    "vertex_weight",
];

/// Opacity floor of the Triangle Splatting+ activation used by
/// [`parse_triangle_checkpoint`] for indexed checkpoints:
/// α = floor + (1 − floor)·sigmoid(w).
pub const TSPLUS_OPACITY_FLOOR: f64 = 0.9999;

/// Parses a Triangle Splatting checkpoint held in `bytes` (`name` is used in
/// errors) into a [`TriangleSoup`].
///
/// **Triangle Splatting** (`trianglesplatting/triangle-splatting`): a dict with
/// `triangles_points [N,3,3]` (triangle, vertex, xyz; world units),
/// `opacity [N,1]` (logit), `sigma [N,1]` (raw, σ = 0.01 + exp(raw)),
/// `features_dc [N,1,3]`, `features_rest [N,K,3]` (triangle, coefficient,
/// channel — the layout of `TriangleSoup::sh_rest`; K = (D+1)²−1 gives the
/// SH degree D; absent means D = 0) and the int `active_sh_degree` (absent
/// means D). `[N]` is accepted for opacity and sigma and `[N,3]` for
/// `features_dc`. Values are copied bit for bit from f32 storages, widened
/// exactly from f16 / bf16, rounded from f64. Other keys whose tensor has shape
/// `[N]` or `[N,1]` become `extras.item` columns named after the key.
///
/// **Triangle Splatting+** (`trianglesplatting2/triangle-splatting2`), detected
/// by `triangles_points` of rank 2 or the key `_triangle_indices`: vertices
/// `triangles_points [V,3]`, `_triangle_indices [T,3]` (integers in 0..V),
/// per-vertex `features_dc [V,1,3]` / `features_rest [V,K,3]`,
/// `vertex_weight [V,1]` and a single `sigma`. This is a **conversion** to
/// independent triangles, not a lossless read: each triangle gets copies of
/// its three vertices; its SH coefficients are the mean of its vertices'
/// (computed in f64); its opacity is the TS+ activation of the mean vertex
/// weight, α = [`TSPLUS_OPACITY_FLOOR`] + (1 − floor)·sigmoid(mean w),
/// stored as the logit of α; its raw sigma is the scalar `sigma` (taken to use
/// the Triangle Splatting activation 0.01 + exp(raw); a `sigma` of shape `[T]`
/// or `[T,1]` is used per triangle).
///
/// Every shape is checked; an error names the key (and, for indices, the
/// triangle) that is wrong.
pub fn parse_triangle_checkpoint(name: &str, bytes: &[u8]) -> Result<TriangleSoup> {
    let ck = TorchCheckpoint::parse(name, bytes)?;
    let tp = ck.tensor("triangles_points")?;
    let soup = if tp.shape.len() == 2 || ck.get("_triangle_indices").is_some() {
        indexed_soup(&ck)?
    } else {
        plain_soup(&ck)?
    };
    soup.validate().map_err(|e| e.in_file(name))?;
    Ok(soup)
}

fn shape_err(ck: &TorchCheckpoint, key: &str, got: &[usize], want: &str) -> Error {
    ck.err(key, format!("shape {got:?}, expected {want}"))
}

/// The per-item `[n,1]` / `[n]` float tensor `key`.
fn per_item(ck: &TorchCheckpoint, key: &str, n: usize, what: &str) -> Result<Vec<f32>> {
    let (shape, v) = ck.tensor_f32(key)?;
    match shape.as_slice() {
        [a, 1] | [a] if *a == n => Ok(v),
        _ => Err(shape_err(ck, key, &shape, &format!("[{n},1] ({what})"))),
    }
}

/// `features_dc` (`[n,1,3]` or `[n,3]`) and `features_rest` (`[n,K,3]`),
/// returning (dc, rest, degree).
fn sh_features(ck: &TorchCheckpoint, n: usize, what: &str) -> Result<(Vec<f32>, Vec<f32>, usize)> {
    let (shape, dc) = ck.tensor_f32("features_dc")?;
    match shape.as_slice() {
        [a, 1, 3] | [a, 3] if *a == n => {}
        _ => {
            return Err(shape_err(
                ck,
                "features_dc",
                &shape,
                &format!("[{n},1,3] ({what})"),
            ));
        }
    }
    if ck.get("features_rest").is_none() {
        return Ok((dc, Vec::new(), 0));
    }
    let (shape, rest) = ck.tensor_f32("features_rest")?;
    let degree = match shape.as_slice() {
        [a, k, 3] if *a == n => match k {
            0 => 0,
            3 => 1,
            8 => 2,
            15 => 3,
            _ => {
                return Err(ck.err(
                    "features_rest",
                    format!("{k} coefficients per channel, expected 0, 3, 8 or 15 (SH degree 0–3)"),
                ));
            }
        },
        _ => {
            return Err(shape_err(
                ck,
                "features_rest",
                &shape,
                &format!("[{n},K,3] ({what})"),
            ));
        }
    };
    Ok((dc, rest, degree))
}

fn active_degree(ck: &TorchCheckpoint, degree: usize) -> Result<usize> {
    match ck.int("active_sh_degree")? {
        None => Ok(degree),
        Some(a) if (0..=degree as i64).contains(&a) => Ok(a as usize),
        Some(a) => Err(ck.err(
            "active_sh_degree",
            format!("{a} is outside 0..={degree} (the degree of features_rest)"),
        )),
    }
}

fn extras_items(ck: &TorchCheckpoint, n: usize) -> Result<Vec<Property>> {
    let mut out = Vec::new();
    for (k, _) in ck.entries() {
        if KNOWN_KEYS.contains(&k.as_str()) {
            continue;
        }
        if let Some(data) = ck.item_column(k, n)? {
            out.push(Property {
                name: k.clone(),
                data: Column::Scalar(data),
            });
        }
    }
    Ok(out)
}

fn plain_soup(ck: &TorchCheckpoint) -> Result<TriangleSoup> {
    let (shape, pts) = ck.tensor_f32("triangles_points")?;
    let n = match shape.as_slice() {
        [n, 3, 3] => *n,
        _ => return Err(shape_err(ck, "triangles_points", &shape, "[N,3,3]")),
    };
    let opacity_raw = per_item(ck, "opacity", n, "one logit per triangle")?;
    let sigma_raw = per_item(ck, "sigma", n, "one raw sigma per triangle")?;
    let (dc, sh_rest, sh_degree) = sh_features(ck, n, "per triangle")?;
    let mut soup = TriangleSoup {
        // Lengths are multiples of 9 and 3 (shapes checked above).
        triangles: bytemuck::pod_collect_to_vec(&pts),
        opacity_raw,
        sigma_raw,
        sh_degree,
        active_sh_degree: active_degree(ck, sh_degree)?,
        sh_dc: bytemuck::pod_collect_to_vec(&dc),
        sh_rest,
        ..Default::default()
    };
    soup.extras.item = extras_items(ck, n)?;
    Ok(soup)
}

fn sigmoid64(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

fn indexed_soup(ck: &TorchCheckpoint) -> Result<TriangleSoup> {
    let (shape, verts) = ck.tensor_f32("triangles_points")?;
    let v = match shape.as_slice() {
        [v, 3] => *v,
        _ => {
            return Err(shape_err(
                ck,
                "triangles_points",
                &shape,
                "[V,3] (vertices of an indexed Triangle Splatting+ model)",
            ));
        }
    };
    let (ishape, idx) = ck.tensor_i64("_triangle_indices")?;
    let t = match ishape.as_slice() {
        [t, 3] => *t,
        _ => return Err(shape_err(ck, "_triangle_indices", &ishape, "[T,3]")),
    };
    let mut tris = Vec::with_capacity(t);
    for (i, c) in idx.chunks_exact(3).enumerate() {
        let mut tri = [0usize; 3];
        for (j, &x) in c.iter().enumerate() {
            if x < 0 || x as u64 >= v as u64 {
                return Err(ck.err(
                    "_triangle_indices",
                    format!("triangle {i} refers to vertex {x}, outside 0..{v}"),
                ));
            }
            tri[j] = x as usize;
        }
        tris.push(tri);
    }
    let weight = per_item(ck, "vertex_weight", v, "one weight per vertex")?;
    let (dc, rest, sh_degree) = sh_features(ck, v, "per vertex")?;
    let (sshape, sigma) = ck.tensor_f32("sigma")?;
    let sigma_raw: Vec<f32> = if sigma.len() == 1 {
        vec![sigma[0]; t]
    } else if matches!(sshape.as_slice(), [a] | [a, 1] if *a == t) {
        sigma
    } else {
        return Err(shape_err(
            ck,
            "sigma",
            &sshape,
            &format!("a single value or [{t},1]"),
        ));
    };
    let k3 = rest.len() / v.max(1);
    let mut soup = TriangleSoup {
        triangles: Vec::with_capacity(t),
        opacity_raw: Vec::with_capacity(t),
        sigma_raw,
        sh_degree,
        active_sh_degree: active_degree(ck, sh_degree)?,
        sh_dc: Vec::with_capacity(t),
        sh_rest: Vec::with_capacity(t * k3),
        ..Default::default()
    };
    let floor = TSPLUS_OPACITY_FLOOR;
    for tri in &tris {
        soup.triangles
            .push(tri.map(|i| [verts[3 * i], verts[3 * i + 1], verts[3 * i + 2]]));
        let m = tri.iter().map(|&i| weight[i] as f64).sum::<f64>() / 3.0;
        // logit(α) with 1 − α = (1 − floor)·sigmoid(−m), kept accurate near 1.
        let alpha = floor + (1.0 - floor) * sigmoid64(m);
        let one_minus = (1.0 - floor) * sigmoid64(-m);
        soup.opacity_raw.push((alpha / one_minus).ln() as f32);
        let mean = |vals: &[f32], stride: usize, c: usize| -> f32 {
            (tri.iter()
                .map(|&i| vals[i * stride + c] as f64)
                .sum::<f64>()
                / 3.0) as f32
        };
        soup.sh_dc.push([0, 1, 2].map(|c| mean(&dc, 3, c)));
        for c in 0..k3 {
            soup.sh_rest.push(mean(&rest, k3, c));
        }
    }
    soup.extras.item = extras_items(ck, t)?;
    Ok(soup)
}

/// A storage to be written: dtype, shape and its little-endian bytes,
/// produced in pieces as the zip writer takes them.
struct OutTensor<'s> {
    key: String,
    dtype: DType,
    shape: Vec<u64>,
    data: OutData<'s>,
}

enum OutData<'s> {
    F32(&'s [f32]),
    Scalars(&'s ScalarData),
}

impl OutData<'_> {
    fn emit(&self, sink: zip::Sink<'_>) -> std::io::Result<()> {
        const CHUNK: usize = 1 << 16;
        fn le<T: Copy, const B: usize>(
            v: &[T],
            f: impl Fn(T) -> [u8; B],
            sink: zip::Sink<'_>,
        ) -> std::io::Result<()> {
            let mut buf = Vec::with_capacity(CHUNK * B);
            for chunk in v.chunks(CHUNK) {
                buf.clear();
                for &x in chunk {
                    buf.extend(f(x));
                }
                sink(&buf)?;
            }
            Ok(())
        }
        match self {
            OutData::F32(v) => {
                if cfg!(target_endian = "little") {
                    for c in v.chunks(CHUNK * 16) {
                        sink(bytemuck::cast_slice(c))?;
                    }
                    Ok(())
                } else {
                    le(v, f32::to_le_bytes, sink)
                }
            }
            OutData::Scalars(d) => match d {
                ScalarData::I8(v) => le(v, i8::to_le_bytes, sink),
                ScalarData::U8(v) => le(v, u8::to_le_bytes, sink),
                ScalarData::I16(v) => le(v, i16::to_le_bytes, sink),
                ScalarData::U16(v) => le(v, |x| (x as i32).to_le_bytes(), sink),
                ScalarData::I32(v) => le(v, i32::to_le_bytes, sink),
                ScalarData::U32(v) => le(v, |x| (x as i64).to_le_bytes(), sink),
                ScalarData::F32(v) => le(v, f32::to_le_bytes, sink),
                ScalarData::F64(v) => le(v, f64::to_le_bytes, sink),
            },
        }
    }

    fn nbytes(&self, dtype: DType) -> usize {
        let n = match self {
            OutData::F32(v) => v.len(),
            OutData::Scalars(d) => d.len(),
        };
        n * dtype.size()
    }
}

/// Writes `soup` as a Triangle Splatting checkpoint that `torch.load` reads:
/// a zip of stored entries (`archive/data.pkl` pickle protocol 2,
/// `archive/data/0..`, `archive/byteorder` = `little`, `archive/version` =
/// `3`), with plain CPU float32 tensors (`_rebuild_tensor_v2`, contiguous)
/// under the keys of [`parse_triangle_checkpoint`] in the order the training
/// code saves them — `triangles_points [N,3,3]`, `sigma [N,1]`,
/// `active_sh_degree`, `features_dc [N,1,3]`, `features_rest [N,K,3]`,
/// `opacity [N,1]` — then each scalar `extras.item` column as a `[N]` tensor
/// (u16 widened to int32, u32 to int64; list columns, per-vertex extras and
/// other elements are not written). Storages are streamed: memory use does not
/// grow with the soup.
pub fn write_triangle_checkpoint(w: &mut dyn Write, soup: &TriangleSoup) -> Result<()> {
    write_checkpoint_impl(w, soup, false)
}

fn write_checkpoint_impl(w: &mut dyn Write, soup: &TriangleSoup, force_zip64: bool) -> Result<()> {
    soup.validate()
        .map_err(|m| Error::invalid(format!("cannot write the triangle soup: {m}")))?;
    let n = soup.len() as u64;
    let k = soup.rest_per_channel() as u64;
    let mut tensors = vec![
        OutTensor {
            key: "triangles_points".into(),
            dtype: DType::F32,
            shape: vec![n, 3, 3],
            data: OutData::F32(bytemuck::cast_slice(&soup.triangles)),
        },
        OutTensor {
            key: "sigma".into(),
            dtype: DType::F32,
            shape: vec![n, 1],
            data: OutData::F32(&soup.sigma_raw),
        },
        OutTensor {
            key: "features_dc".into(),
            dtype: DType::F32,
            shape: vec![n, 1, 3],
            data: OutData::F32(bytemuck::cast_slice(&soup.sh_dc)),
        },
        OutTensor {
            key: "features_rest".into(),
            dtype: DType::F32,
            shape: vec![n, k, 3],
            data: OutData::F32(&soup.sh_rest),
        },
        OutTensor {
            key: "opacity".into(),
            dtype: DType::F32,
            shape: vec![n, 1],
            data: OutData::F32(&soup.opacity_raw),
        },
    ];
    for p in &soup.extras.item {
        let Column::Scalar(d) = &p.data else { continue };
        if d.len() as u64 != n || KNOWN_KEYS.contains(&p.name.as_str()) {
            continue;
        }
        let dtype = match d {
            ScalarData::I8(_) => DType::I8,
            ScalarData::U8(_) => DType::U8,
            ScalarData::I16(_) => DType::I16,
            ScalarData::U16(_) | ScalarData::I32(_) => DType::I32,
            ScalarData::U32(_) => DType::I64,
            ScalarData::F32(_) => DType::F32,
            ScalarData::F64(_) => DType::F64,
        };
        tensors.push(OutTensor {
            key: p.name.clone(),
            dtype,
            shape: vec![n],
            data: OutData::Scalars(d),
        });
    }

    let mut pk = PickleWriter::new();
    pk.op(b'}');
    pk.memoize();
    pk.op(b'(');
    let emit_tensor = |pk: &mut PickleWriter, i: usize, t: &OutTensor| {
        pk.str(&t.key);
        pk.tensor(t.dtype, &i.to_string(), &t.shape);
    };
    // Training's key order: triangles_points, sigma, active_sh_degree, ...
    for (i, t) in tensors.iter().enumerate() {
        emit_tensor(&mut pk, i, t);
        if i == 1 {
            pk.str("active_sh_degree");
            pk.int(soup.active_sh_degree as i64);
        }
    }
    pk.op(b'u');
    let pkl = pk.finish();

    let mut z = zip::StoredZipWriter::new(w);
    z.force_zip64 = force_zip64;
    z.add("archive/data.pkl", &pkl).map_err(werr)?;
    z.add("archive/byteorder", b"little").map_err(werr)?;
    for (i, t) in tensors.iter().enumerate() {
        let name = format!("archive/data/{i}");
        let size = t.data.nbytes(t.dtype) as u64;
        z.add_streamed(&name, size, &|sink| t.data.emit(sink))
            .map_err(werr)?;
    }
    z.add("archive/version", b"3\n").map_err(werr)?;
    z.finish().map_err(werr)?;
    Ok(())
}

#[cfg(test)]
mod tests;
