//! A small pickle virtual machine (protocols 2–5) for the `data.pkl` record
//! of `torch.save` archives, and the matching pickle writer.
//!
//! Nothing is ever executed: `GLOBAL` / `STACK_GLOBAL` resolve to a closed set
//! of recognised names (tensor and parameter rebuilders, `OrderedDict`, storage
//! classes, dtypes); any other global becomes an opaque value, and calling it
//! (`REDUCE`, `NEWOBJ`) yields another opaque value, so unknown content in a
//! checkpoint does not stop the read. Values are immutable trees shared by
//! reference counting (a memo fetch is a cheap copy); mutating opcodes
//! (`APPEND`, `SETITEM`, ...) copy on write, so a memo entry keeps the value
//! it had when it was stored. Nesting depth, stack, mark stack and memo sizes
//! are bounded, and every length read from the stream is checked against the
//! bytes that remain before anything is allocated.

use std::collections::HashMap;
use std::rc::Rc;

/// Deepest nesting of containers accepted (a state dict needs about 4).
pub(crate) const MAX_DEPTH: u32 = 64;
/// Most values on the stack at once.
const MAX_STACK: usize = 1 << 20;
/// Most open `MARK`s at once.
const MAX_MARKS: usize = 1 << 16;
/// Most memo entries.
const MAX_MEMO: usize = 1 << 20;

/// Element type of a torch storage / tensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DType {
    /// IEEE half (`torch.float16`, `HalfStorage`).
    F16,
    /// bfloat16 (`torch.bfloat16`, `BFloat16Storage`).
    BF16,
    /// `torch.float32`, `FloatStorage`.
    F32,
    /// `torch.float64`, `DoubleStorage`.
    F64,
    /// `torch.uint8`, `ByteStorage`, and the bytes of an `UntypedStorage`.
    U8,
    /// `torch.int8`, `CharStorage`.
    I8,
    /// `torch.int16`, `ShortStorage`.
    I16,
    /// `torch.int32`, `IntStorage`.
    I32,
    /// `torch.int64`, `LongStorage`.
    I64,
    /// `torch.uint16` (pickled as an `UntypedStorage` + `_rebuild_tensor_v3`).
    U16,
    /// `torch.uint32` (as `U16`).
    U32,
    /// `torch.uint64` (as `U16`).
    U64,
    /// `torch.bool`, `BoolStorage` (one byte per value).
    Bool,
}

impl DType {
    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            DType::U8 | DType::I8 | DType::Bool => 1,
            DType::F16 | DType::BF16 | DType::I16 | DType::U16 => 2,
            DType::F32 | DType::I32 | DType::U32 => 4,
            DType::F64 | DType::I64 | DType::U64 => 8,
        }
    }

    /// True for the floating-point types.
    pub fn is_float(self) -> bool {
        matches!(self, DType::F16 | DType::BF16 | DType::F32 | DType::F64)
    }

    /// The legacy storage class name (`FloatStorage`, ...), as pickled by
    /// `torch.save` in persistent ids; `UntypedStorage` for the unsigned
    /// types above 8 bits, which have no typed class.
    pub fn storage_class(self) -> &'static str {
        match self {
            DType::F16 => "HalfStorage",
            DType::BF16 => "BFloat16Storage",
            DType::F32 => "FloatStorage",
            DType::F64 => "DoubleStorage",
            DType::U8 => "ByteStorage",
            DType::I8 => "CharStorage",
            DType::I16 => "ShortStorage",
            DType::I32 => "IntStorage",
            DType::I64 => "LongStorage",
            DType::Bool => "BoolStorage",
            DType::U16 | DType::U32 | DType::U64 => "UntypedStorage",
        }
    }

    /// The torch dtype name (`float32`, ...).
    pub fn torch_name(self) -> &'static str {
        match self {
            DType::F16 => "float16",
            DType::BF16 => "bfloat16",
            DType::F32 => "float32",
            DType::F64 => "float64",
            DType::U8 => "uint8",
            DType::I8 => "int8",
            DType::I16 => "int16",
            DType::I32 => "int32",
            DType::I64 => "int64",
            DType::Bool => "bool",
            DType::U16 => "uint16",
            DType::U32 => "uint32",
            DType::U64 => "uint64",
        }
    }

    fn from_storage_class(name: &str) -> Option<DType> {
        Some(match name {
            "HalfStorage" => DType::F16,
            "BFloat16Storage" => DType::BF16,
            "FloatStorage" => DType::F32,
            "DoubleStorage" => DType::F64,
            "ByteStorage" | "UntypedStorage" => DType::U8,
            "CharStorage" => DType::I8,
            "ShortStorage" => DType::I16,
            "IntStorage" => DType::I32,
            "LongStorage" => DType::I64,
            "BoolStorage" => DType::Bool,
            _ => return None,
        })
    }

    fn from_torch_name(name: &str) -> Option<DType> {
        Some(match name {
            "float16" | "half" => DType::F16,
            "bfloat16" => DType::BF16,
            "float32" | "float" => DType::F32,
            "float64" | "double" => DType::F64,
            "uint8" => DType::U8,
            "int8" => DType::I8,
            "int16" | "short" => DType::I16,
            "int32" | "int" => DType::I32,
            "int64" | "long" => DType::I64,
            "bool" => DType::Bool,
            "uint16" => DType::U16,
            "uint32" => DType::U32,
            "uint64" => DType::U64,
            _ => return None,
        })
    }
}

/// A storage named by a persistent id `('storage', type, key, location, numel)`.
#[derive(Debug, PartialEq)]
pub(crate) struct StorageRef {
    pub dtype: DType,
    /// The record name under `<prefix>/data/`.
    pub key: String,
    /// Declared element count (bytes for an untyped storage).
    pub numel: u64,
}

/// A tensor view: storage, element offset, sizes and strides (in elements).
#[derive(Debug, PartialEq)]
pub(crate) struct TensorRef {
    pub storage: Rc<StorageRef>,
    pub offset: u64,
    pub size: Vec<u64>,
    pub stride: Vec<u64>,
}

/// Callables the VM recognises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Func {
    /// `torch._utils._rebuild_tensor_v2` and `_rebuild_tensor`.
    RebuildTensor,
    /// `torch._utils._rebuild_tensor_v3`: an untyped (byte) storage viewed
    /// with the dtype given as 7th argument.
    RebuildTensorV3,
    /// `torch._utils._rebuild_parameter` and `_rebuild_parameter_with_state`.
    RebuildParameter,
    /// `collections.OrderedDict`.
    OrderedDict,
}

/// A sequence (list or tuple) with its nesting depth.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Seq {
    pub items: Vec<Value>,
    depth: u32,
}

/// A dict in insertion order; string keys are indexed so that a repeated key
/// replaces its value as in Python.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Map {
    pub items: Vec<(Value, Value)>,
    index: HashMap<Rc<str>, usize>,
    depth: u32,
}

impl Map {
    fn insert(&mut self, k: Value, v: Value) -> Result<(), String> {
        let d = 1 + k.depth().max(v.depth());
        if d > MAX_DEPTH {
            return Err(format!("containers nested deeper than {MAX_DEPTH}"));
        }
        self.depth = self.depth.max(d);
        if let Value::Str(s) = &k {
            if let Some(&i) = self.index.get(s) {
                self.items[i].1 = v;
                return Ok(());
            }
            self.index.insert(s.clone(), self.items.len());
        }
        self.items.push((k, v));
        Ok(())
    }

    /// The value of string key `key`.
    #[cfg(test)]
    pub fn get(&self, key: &str) -> Option<&Value> {
        self.index.get(key).map(|&i| &self.items[i].1)
    }
}

/// A pickled value.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Value {
    None,
    Bool(bool),
    Int(i64),
    /// An integer outside the i64 range (only its byte length is kept).
    BigInt(usize),
    Float(f64),
    Str(Rc<str>),
    /// A bytes object (only its length is kept).
    Bytes(usize),
    List(Rc<Seq>),
    Tuple(Rc<Seq>),
    Dict(Rc<Map>),
    Func(Func),
    /// A storage class or a `torch.<dtype>` object.
    Dtype(DType),
    Storage(Rc<StorageRef>),
    Tensor(Rc<TensorRef>),
    /// Anything not interpreted: an unknown global, or the result of calling
    /// or instantiating one. The string says what it was.
    Opaque(Rc<str>),
}

impl Value {
    fn depth(&self) -> u32 {
        match self {
            Value::List(s) | Value::Tuple(s) => s.depth,
            Value::Dict(m) => m.depth,
            _ => 0,
        }
    }

    /// A short description for error messages.
    pub fn kind(&self) -> String {
        match self {
            Value::None => "None".into(),
            Value::Bool(b) => format!("bool {b}"),
            Value::Int(i) => format!("int {i}"),
            Value::BigInt(n) => format!("{n}-byte int"),
            Value::Float(f) => format!("float {f}"),
            Value::Str(s) => format!("str {s:?}"),
            Value::Bytes(n) => format!("{n} bytes"),
            Value::List(s) => format!("list of {}", s.items.len()),
            Value::Tuple(s) => format!("tuple of {}", s.items.len()),
            Value::Dict(m) => format!("dict of {}", m.items.len()),
            Value::Func(f) => format!("{f:?}"),
            Value::Dtype(d) => format!("dtype {}", d.torch_name()),
            Value::Storage(_) => "storage".into(),
            Value::Tensor(t) => format!("tensor {:?}", t.size),
            Value::Opaque(s) => format!("object {s}"),
        }
    }

    fn seq(items: Vec<Value>) -> Result<Seq, String> {
        let depth = 1 + items.iter().map(Value::depth).max().unwrap_or(0);
        if depth > MAX_DEPTH {
            return Err(format!("containers nested deeper than {MAX_DEPTH}"));
        }
        Ok(Seq { items, depth })
    }
}

/// A VM failure: the byte offset of the offending opcode and why.
#[derive(Debug)]
pub(crate) struct PickleError {
    pub offset: usize,
    pub msg: String,
}

struct Vm<'a> {
    data: &'a [u8],
    pos: usize,
    stack: Vec<Value>,
    marks: Vec<usize>,
    memo: HashMap<u32, Value>,
}

/// Runs `data` to its `STOP` and returns the resulting value.
pub(crate) fn unpickle(data: &[u8]) -> Result<Value, PickleError> {
    let mut vm = Vm {
        data,
        pos: 0,
        stack: Vec::new(),
        marks: Vec::new(),
        memo: HashMap::new(),
    };
    loop {
        let start = vm.pos;
        match vm.step() {
            Ok(Some(v)) => return Ok(v),
            Ok(None) => {}
            Err(msg) => return Err(PickleError { offset: start, msg }),
        }
    }
}

fn resolve_global(module: &str, name: &str) -> Value {
    match (module, name) {
        ("torch._utils", "_rebuild_tensor_v2" | "_rebuild_tensor") => {
            Value::Func(Func::RebuildTensor)
        }
        ("torch._utils", "_rebuild_tensor_v3") => Value::Func(Func::RebuildTensorV3),
        ("torch._utils", "_rebuild_parameter" | "_rebuild_parameter_with_state") => {
            Value::Func(Func::RebuildParameter)
        }
        ("collections", "OrderedDict") => Value::Func(Func::OrderedDict),
        ("torch" | "torch.storage", _) => {
            if let Some(d) = DType::from_storage_class(name).or(DType::from_torch_name(name)) {
                Value::Dtype(d)
            } else {
                Value::Opaque(format!("{module}.{name}").into())
            }
        }
        _ => Value::Opaque(format!("{module}.{name}").into()),
    }
}

fn as_index(v: &Value, what: &str) -> Result<u64, String> {
    match v {
        Value::Int(i) if *i >= 0 => Ok(*i as u64),
        Value::Bool(b) => Ok(*b as u64),
        other => Err(format!(
            "{what} must be a non-negative int, found {}",
            other.kind()
        )),
    }
}

fn as_index_tuple(v: &Value, what: &str) -> Result<Vec<u64>, String> {
    match v {
        Value::Tuple(s) | Value::List(s) => s
            .items
            .iter()
            .map(|x| as_index(x, what))
            .collect::<Result<_, _>>(),
        other => Err(format!(
            "{what} must be a tuple of ints, found {}",
            other.kind()
        )),
    }
}

fn call(func: &Value, args: &Value) -> Result<Value, String> {
    let Value::Tuple(args) = args else {
        return Err(format!(
            "REDUCE arguments must be a tuple, found {}",
            args.kind()
        ));
    };
    let a = &args.items;
    match func {
        Value::Func(f @ (Func::RebuildTensor | Func::RebuildTensorV3)) => {
            let v3 = *f == Func::RebuildTensorV3;
            let name = if v3 {
                "_rebuild_tensor_v3"
            } else {
                "_rebuild_tensor_v2"
            };
            let need = if v3 { 7 } else { 4 };
            if a.len() < need {
                return Err(format!(
                    "{name} needs at least {need} arguments, found {}",
                    a.len()
                ));
            }
            let storage = match &a[0] {
                Value::Storage(s) => s.clone(),
                // A storage of a type we do not read: the tensor stays opaque.
                Value::Opaque(s) => return Ok(Value::Opaque(format!("tensor on {s}").into())),
                other => {
                    return Err(format!(
                        "{name}: first argument must be a storage, found {}",
                        other.kind()
                    ));
                }
            };
            let storage = if v3 {
                // The view is in elements of the given dtype over bytes.
                let Value::Dtype(d) = a[6] else {
                    return Ok(Value::Opaque(format!("tensor of {}", a[6].kind()).into()));
                };
                if storage.dtype != DType::U8 {
                    return Err(format!(
                        "{name}: storage must be untyped, found {}",
                        storage.dtype.torch_name()
                    ));
                }
                Rc::new(StorageRef {
                    dtype: d,
                    key: storage.key.clone(),
                    numel: storage.numel / d.size() as u64,
                })
            } else {
                storage
            };
            let offset = as_index(&a[1], "tensor storage offset")?;
            let size = as_index_tuple(&a[2], "tensor size")?;
            let stride = as_index_tuple(&a[3], "tensor stride")?;
            if size.len() != stride.len() {
                return Err(format!(
                    "tensor size {size:?} and stride {stride:?} have different lengths"
                ));
            }
            Ok(Value::Tensor(Rc::new(TensorRef {
                storage,
                offset,
                size,
                stride,
            })))
        }
        Value::Func(Func::RebuildParameter) => match a.first() {
            Some(t @ (Value::Tensor(_) | Value::Opaque(_))) => Ok(t.clone()),
            Some(other) => Err(format!(
                "_rebuild_parameter: first argument must be a tensor, found {}",
                other.kind()
            )),
            None => Err("_rebuild_parameter without arguments".into()),
        },
        Value::Func(Func::OrderedDict) if a.is_empty() => Ok(Value::Dict(Rc::default())),
        Value::Func(Func::OrderedDict) => Ok(Value::Opaque("OrderedDict(...)".into())),
        Value::Opaque(name) => Ok(Value::Opaque(format!("{name}(...)").into())),
        other => Ok(Value::Opaque(format!("{}(...)", other.kind()).into())),
    }
}

fn persistent_load(pid: &Value) -> Result<Value, String> {
    let Value::Tuple(t) = pid else {
        return Err(format!(
            "persistent id must be a tuple, found {}",
            pid.kind()
        ));
    };
    let a = &t.items;
    match a.first() {
        Some(Value::Str(s)) if &**s == "storage" => {}
        _ => {
            return Err(
                "unsupported persistent id (expected ('storage', type, key, location, numel))"
                    .into(),
            );
        }
    }
    if a.len() != 5 {
        return Err(format!(
            "storage persistent id has {} fields, expected 5",
            a.len()
        ));
    }
    let dtype = match &a[1] {
        Value::Dtype(d) => *d,
        // e.g. torch.ComplexFloatStorage: kept opaque so that other keys
        // still read.
        Value::Opaque(name) => return Ok(Value::Opaque(format!("storage {name}").into())),
        other => return Err(format!("unsupported storage type {}", other.kind())),
    };
    let key = match &a[2] {
        Value::Str(s) => s.to_string(),
        Value::Int(i) => i.to_string(),
        other => return Err(format!("storage key must be a str, found {}", other.kind())),
    };
    let numel = as_index(&a[4], "storage size")?;
    Ok(Value::Storage(Rc::new(StorageRef { dtype, key, numel })))
}

impl Vm<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        if self.data.len() - self.pos < n {
            return Err(format!(
                "truncated: needs {n} bytes, {} remain",
                self.data.len() - self.pos
            ));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }

    fn u16(&mut self) -> Result<u16, String> {
        let b = self.take(2)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }

    fn u32(&mut self) -> Result<u32, String> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self) -> Result<u64, String> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes(b.try_into().expect("8 bytes")))
    }

    /// A length prefix, checked against the bytes that remain.
    fn len_prefixed(&mut self, n: u64) -> Result<&[u8], String> {
        let remain = (self.data.len() - self.pos) as u64;
        if n > remain {
            return Err(format!(
                "declared length {n} exceeds the {remain} bytes left"
            ));
        }
        self.take(n as usize)
    }

    fn line(&mut self) -> Result<&str, String> {
        let rest = &self.data[self.pos..];
        let Some(end) = rest.iter().position(|&b| b == b'\n') else {
            return Err("unterminated text line".into());
        };
        self.pos += end + 1;
        std::str::from_utf8(&rest[..end]).map_err(|_| "text line is not UTF-8".to_string())
    }

    fn utf8(bytes: &[u8]) -> Result<Value, String> {
        std::str::from_utf8(bytes)
            .map(|s| Value::Str(s.into()))
            .map_err(|_| "string is not valid UTF-8".to_string())
    }

    fn push(&mut self, v: Value) -> Result<(), String> {
        if self.stack.len() >= MAX_STACK {
            return Err(format!("stack deeper than {MAX_STACK}"));
        }
        self.stack.push(v);
        Ok(())
    }

    fn pop(&mut self) -> Result<Value, String> {
        let floor = self.marks.last().copied().unwrap_or(0);
        if self.stack.len() <= floor {
            return Err("stack underflow".into());
        }
        Ok(self.stack.pop().expect("non-empty"))
    }

    fn top(&mut self) -> Result<&mut Value, String> {
        let floor = self.marks.last().copied().unwrap_or(0);
        if self.stack.len() <= floor {
            return Err("stack underflow".into());
        }
        Ok(self.stack.last_mut().expect("non-empty"))
    }

    /// Pops everything above the last mark, and the mark.
    fn pop_mark(&mut self) -> Result<Vec<Value>, String> {
        let Some(m) = self.marks.pop() else {
            return Err("no MARK to pop to".into());
        };
        Ok(self.stack.split_off(m))
    }

    fn memo_put(&mut self, idx: u32) -> Result<(), String> {
        let v = self.top()?.clone();
        if self.memo.len() >= MAX_MEMO && !self.memo.contains_key(&idx) {
            return Err(format!("more than {MAX_MEMO} memo entries"));
        }
        self.memo.insert(idx, v);
        Ok(())
    }

    fn memo_get(&mut self, idx: u32) -> Result<(), String> {
        let v = self
            .memo
            .get(&idx)
            .cloned()
            .ok_or_else(|| format!("memo entry {idx} is not defined"))?;
        self.push(v)
    }

    fn int_le(bytes: &[u8]) -> Value {
        if bytes.is_empty() {
            return Value::Int(0);
        }
        if bytes.len() > 8 {
            // Fits in i64 only if the extra bytes are pure sign extension.
            let neg = bytes[7] & 0x80 != 0;
            let fill = if neg { 0xff } else { 0 };
            if bytes[8..].iter().any(|&b| b != fill) {
                return Value::BigInt(bytes.len());
            }
        }
        let n = bytes.len().min(8);
        let neg = bytes[n - 1] & 0x80 != 0;
        let mut buf = if neg { [0xff; 8] } else { [0; 8] };
        buf[..n].copy_from_slice(&bytes[..n]);
        Value::Int(i64::from_le_bytes(buf))
    }

    fn append(&mut self, items: Vec<Value>) -> Result<(), String> {
        let top = self.top()?;
        match top {
            Value::List(s) => {
                let s = Rc::make_mut(s);
                let d = 1 + items.iter().map(Value::depth).max().unwrap_or(0);
                if d > MAX_DEPTH {
                    return Err(format!("containers nested deeper than {MAX_DEPTH}"));
                }
                s.depth = s.depth.max(d);
                s.items.extend(items);
                Ok(())
            }
            // A list-like object we do not model: its content is dropped.
            Value::Opaque(_) => Ok(()),
            other => Err(format!("APPEND to {}", other.kind())),
        }
    }

    fn set_items(&mut self, items: Vec<Value>) -> Result<(), String> {
        if !items.len().is_multiple_of(2) {
            return Err("SETITEMS with an odd number of values".into());
        }
        let top = self.top()?;
        match top {
            Value::Dict(m) => {
                let m = Rc::make_mut(m);
                let mut it = items.into_iter();
                while let (Some(k), Some(v)) = (it.next(), it.next()) {
                    m.insert(k, v)?;
                }
                Ok(())
            }
            Value::Opaque(_) => Ok(()),
            other => Err(format!("SETITEM on {}", other.kind())),
        }
    }

    /// Executes one opcode; `Some` at `STOP`.
    fn step(&mut self) -> Result<Option<Value>, String> {
        let op = self.u8()?;
        match op {
            0x80 => {
                // PROTO
                let p = self.u8()?;
                if p > 5 {
                    return Err(format!("unsupported pickle protocol {p}"));
                }
            }
            0x95 => {
                // FRAME: the frame length only has to fit.
                let n = self.u64()?;
                if n > (self.data.len() - self.pos) as u64 {
                    return Err(format!("frame of {n} bytes exceeds the data"));
                }
            }
            b'.' => {
                // STOP
                let v = self.pop()?;
                return Ok(Some(v));
            }
            b'(' => {
                if self.marks.len() >= MAX_MARKS {
                    return Err(format!("more than {MAX_MARKS} open MARKs"));
                }
                self.marks.push(self.stack.len());
            }
            b'0' => {
                self.pop()?;
            }
            b'1' => {
                self.pop_mark()?;
            }
            b'2' => {
                let v = self.top()?.clone();
                self.push(v)?;
            }
            b'N' => self.push(Value::None)?,
            0x88 => self.push(Value::Bool(true))?,
            0x89 => self.push(Value::Bool(false))?,
            b'J' => {
                let v = self.u32()? as i32;
                self.push(Value::Int(v as i64))?;
            }
            b'K' => {
                let v = self.u8()?;
                self.push(Value::Int(v as i64))?;
            }
            b'M' => {
                let v = self.u16()?;
                self.push(Value::Int(v as i64))?;
            }
            0x8a => {
                let n = self.u8()? as u64;
                let v = Self::int_le(self.len_prefixed(n)?);
                self.push(v)?;
            }
            0x8b => {
                let n = self.u32()? as u64;
                let v = Self::int_le(self.len_prefixed(n)?);
                self.push(v)?;
            }
            b'G' => {
                let b = self.take(8)?;
                let v = f64::from_be_bytes(b.try_into().expect("8 bytes"));
                self.push(Value::Float(v))?;
            }
            0x8c => {
                let n = self.u8()? as u64;
                let v = Self::utf8(self.len_prefixed(n)?)?;
                self.push(v)?;
            }
            b'X' => {
                let n = self.u32()? as u64;
                let v = Self::utf8(self.len_prefixed(n)?)?;
                self.push(v)?;
            }
            0x8d => {
                let n = self.u64()?;
                let v = Self::utf8(self.len_prefixed(n)?)?;
                self.push(v)?;
            }
            b'U' => {
                // SHORT_BINSTRING (Python 2 str): latin-1 text.
                let n = self.u8()? as u64;
                let s: String = self.len_prefixed(n)?.iter().map(|&b| b as char).collect();
                self.push(Value::Str(s.into()))?;
            }
            b'T' => {
                let n = self.u32()? as u64;
                let s: String = self.len_prefixed(n)?.iter().map(|&b| b as char).collect();
                self.push(Value::Str(s.into()))?;
            }
            b'C' => {
                let n = self.u8()? as u64;
                let len = self.len_prefixed(n)?.len();
                self.push(Value::Bytes(len))?;
            }
            b'B' => {
                let n = self.u32()? as u64;
                let len = self.len_prefixed(n)?.len();
                self.push(Value::Bytes(len))?;
            }
            0x8e | 0x96 => {
                let n = self.u64()?;
                let len = self.len_prefixed(n)?.len();
                self.push(Value::Bytes(len))?;
            }
            b'}' => self.push(Value::Dict(Rc::default()))?,
            b']' => self.push(Value::List(Rc::default()))?,
            b')' => self.push(Value::Tuple(Rc::default()))?,
            0x8f => self.push(Value::Opaque("set".into()))?,
            b'd' => {
                let items = self.pop_mark()?;
                self.push(Value::Dict(Rc::default()))?;
                self.set_items(items)?;
            }
            b'l' => {
                let items = self.pop_mark()?;
                self.push(Value::List(Rc::new(Value::seq(items)?)))?;
            }
            b't' => {
                let items = self.pop_mark()?;
                self.push(Value::Tuple(Rc::new(Value::seq(items)?)))?;
            }
            0x85..=0x87 => {
                let n = (op - 0x84) as usize;
                let floor = self.marks.last().copied().unwrap_or(0);
                if self.stack.len() < floor + n {
                    return Err("stack underflow".into());
                }
                let items = self.stack.split_off(self.stack.len() - n);
                self.push(Value::Tuple(Rc::new(Value::seq(items)?)))?;
            }
            0x91 => {
                self.pop_mark()?;
                self.push(Value::Opaque("frozenset".into()))?;
            }
            0x90 => {
                // ADDITEMS to a set (opaque).
                self.pop_mark()?;
                self.top()?;
            }
            b'a' => {
                let v = self.pop()?;
                self.append(vec![v])?;
            }
            b'e' => {
                let items = self.pop_mark()?;
                self.append(items)?;
            }
            b's' => {
                let v = self.pop()?;
                let k = self.pop()?;
                self.set_items(vec![k, v])?;
            }
            b'u' => {
                let items = self.pop_mark()?;
                self.set_items(items)?;
            }
            b'q' => {
                let i = self.u8()? as u32;
                self.memo_put(i)?;
            }
            b'r' => {
                let i = self.u32()?;
                self.memo_put(i)?;
            }
            0x94 => {
                let i = u32::try_from(self.memo.len()).map_err(|_| "memo overflow".to_string())?;
                self.memo_put(i)?;
            }
            b'h' => {
                let i = self.u8()? as u32;
                self.memo_get(i)?;
            }
            b'j' => {
                let i = self.u32()?;
                self.memo_get(i)?;
            }
            b'c' => {
                let module = self.line()?.to_string();
                let name = self.line()?.to_string();
                self.push(resolve_global(&module, &name))?;
            }
            0x93 => {
                let name = self.pop()?;
                let module = self.pop()?;
                let (Value::Str(m), Value::Str(n)) = (&module, &name) else {
                    return Err(format!(
                        "STACK_GLOBAL needs two strs, found {} and {}",
                        module.kind(),
                        name.kind()
                    ));
                };
                let v = resolve_global(m, n);
                self.push(v)?;
            }
            b'R' => {
                let args = self.pop()?;
                let func = self.pop()?;
                let v = call(&func, &args)?;
                self.push(v)?;
            }
            0x81 => {
                // NEWOBJ cls args
                let _args = self.pop()?;
                let cls = self.pop()?;
                self.push(Value::Opaque(format!("{} instance", cls.kind()).into()))?;
            }
            0x92 => {
                // NEWOBJ_EX cls args kwargs
                let _kwargs = self.pop()?;
                let _args = self.pop()?;
                let cls = self.pop()?;
                self.push(Value::Opaque(format!("{} instance", cls.kind()).into()))?;
            }
            b'b' => {
                // BUILD: the state (attributes such as `_metadata`) is dropped.
                let _state = self.pop()?;
                self.top()?;
            }
            b'Q' => {
                let pid = self.pop()?;
                let v = persistent_load(&pid)?;
                self.push(v)?;
            }
            0x97 | 0x98 => {
                return Err("out-of-band buffers (pickle protocol 5) are not supported".into());
            }
            other => {
                return Err(format!(
                    "unsupported pickle opcode 0x{other:02x}{}",
                    if other.is_ascii_graphic() {
                        format!(" ('{}')", other as char)
                    } else {
                        String::new()
                    }
                ));
            }
        }
        Ok(None)
    }
}

/// Builds a pickle (protocol 2) the way `torch.save` lays one out.
#[derive(Debug)]
pub(crate) struct PickleWriter {
    pub buf: Vec<u8>,
    next_memo: u32,
    globals: HashMap<(String, String), u32>,
}

impl PickleWriter {
    /// A writer that has emitted `PROTO 2`.
    pub fn new() -> Self {
        PickleWriter {
            buf: vec![0x80, 2],
            next_memo: 0,
            globals: HashMap::new(),
        }
    }

    /// Emits one raw opcode byte.
    pub fn op(&mut self, op: u8) {
        self.buf.push(op);
    }

    /// Stores the top of the stack in the memo and returns its index.
    pub fn memoize(&mut self) -> u32 {
        let i = self.next_memo;
        self.next_memo += 1;
        if i < 256 {
            self.buf.extend([b'q', i as u8]);
        } else {
            self.buf.push(b'r');
            self.buf.extend(i.to_le_bytes());
        }
        i
    }

    /// Pushes memo entry `i`.
    pub fn get(&mut self, i: u32) {
        if i < 256 {
            self.buf.extend([b'h', i as u8]);
        } else {
            self.buf.push(b'j');
            self.buf.extend(i.to_le_bytes());
        }
    }

    /// Pushes a str (memoized, as Python does).
    pub fn str(&mut self, s: &str) {
        self.buf.push(b'X');
        self.buf.extend((s.len() as u32).to_le_bytes());
        self.buf.extend(s.as_bytes());
        self.memoize();
    }

    /// Pushes an int with the smallest opcode that holds it.
    pub fn int(&mut self, v: i64) {
        if (0..256).contains(&v) {
            self.buf.extend([b'K', v as u8]);
        } else if (0..65536).contains(&v) {
            self.buf.push(b'M');
            self.buf.extend((v as u16).to_le_bytes());
        } else if let Ok(v32) = i32::try_from(v) {
            self.buf.push(b'J');
            self.buf.extend(v32.to_le_bytes());
        } else {
            let b = v.to_le_bytes();
            self.buf.extend([0x8a, 8]);
            self.buf.extend(b);
        }
    }

    /// Pushes a bool.
    pub fn bool(&mut self, b: bool) {
        self.buf.push(if b { 0x88 } else { 0x89 });
    }

    /// Pushes a global (memoized once, fetched from the memo afterwards).
    pub fn global(&mut self, module: &str, name: &str) {
        let key = (module.to_string(), name.to_string());
        if let Some(&i) = self.globals.get(&key) {
            self.get(i);
            return;
        }
        self.buf.push(b'c');
        self.buf.extend(module.as_bytes());
        self.buf.push(b'\n');
        self.buf.extend(name.as_bytes());
        self.buf.push(b'\n');
        let i = self.memoize();
        self.globals.insert(key, i);
    }

    /// Pushes a tuple of ints.
    pub fn int_tuple(&mut self, v: &[u64]) {
        match v.len() {
            0 => self.op(b')'),
            1..=3 => {
                for &x in v {
                    self.int(x as i64);
                }
                self.op(0x84 + v.len() as u8);
            }
            _ => {
                self.op(b'(');
                for &x in v {
                    self.int(x as i64);
                }
                self.op(b't');
            }
        }
        self.memoize();
    }

    /// Pushes `torch._utils._rebuild_tensor_v2(storage, 0, size, contiguous
    /// stride, False, OrderedDict())` for storage record `key` of `dtype`.
    pub fn tensor(&mut self, dtype: DType, key: &str, size: &[u64]) {
        let numel: u64 = size.iter().product();
        let mut stride = vec![0u64; size.len()];
        let mut acc = 1u64;
        for d in (0..size.len()).rev() {
            stride[d] = acc;
            acc *= size[d].max(1);
        }
        self.global("torch._utils", "_rebuild_tensor_v2");
        self.op(b'(');
        // Persistent id ('storage', torch.FloatStorage, key, 'cpu', numel).
        self.op(b'(');
        self.str("storage");
        self.global("torch", dtype.storage_class());
        self.str(key);
        self.str("cpu");
        self.int(numel as i64);
        self.op(b't');
        self.memoize();
        self.op(b'Q');
        self.int(0);
        self.int_tuple(size);
        self.int_tuple(&stride);
        self.bool(false);
        self.global("collections", "OrderedDict");
        self.op(b')');
        self.op(b'R');
        self.memoize();
        self.op(b't');
        self.memoize();
        self.op(b'R');
        self.memoize();
    }

    /// Emits `STOP` and returns the bytes.
    pub fn finish(mut self) -> Vec<u8> {
        self.buf.push(b'.');
        self.buf
    }
}
