//! Typed columns: the generic storage behind PLY elements and the extra
//! (unknown) properties that models carry so nothing is lost on
//! read-modify-write.

/// A PLY scalar type. Names follow PLY 1.0 (`char uchar short ushort int uint
/// float double`); the sized aliases (`int8 … float64`) are accepted on read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl ScalarType {
    /// All types, in PLY order.
    pub const ALL: [ScalarType; 8] = [
        ScalarType::I8,
        ScalarType::U8,
        ScalarType::I16,
        ScalarType::U16,
        ScalarType::I32,
        ScalarType::U32,
        ScalarType::F32,
        ScalarType::F64,
    ];

    /// Size in bytes.
    pub fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    /// Parses a PLY type name (classic or sized form).
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => ScalarType::I8,
            "uchar" | "uint8" => ScalarType::U8,
            "short" | "int16" => ScalarType::I16,
            "ushort" | "uint16" => ScalarType::U16,
            "int" | "int32" => ScalarType::I32,
            "uint" | "uint32" => ScalarType::U32,
            "float" | "float32" => ScalarType::F32,
            "double" | "float64" => ScalarType::F64,
            _ => return None,
        })
    }

    /// The classic PLY 1.0 name, which every reader understands.
    pub fn name(self) -> &'static str {
        match self {
            ScalarType::I8 => "char",
            ScalarType::U8 => "uchar",
            ScalarType::I16 => "short",
            ScalarType::U16 => "ushort",
            ScalarType::I32 => "int",
            ScalarType::U32 => "uint",
            ScalarType::F32 => "float",
            ScalarType::F64 => "double",
        }
    }

    /// True for `float` and `double`.
    pub fn is_float(self) -> bool {
        matches!(self, ScalarType::F32 | ScalarType::F64)
    }
}

/// A column of scalars of one type.
#[derive(Clone, Debug, PartialEq)]
pub enum ScalarData {
    I8(Vec<i8>),
    U8(Vec<u8>),
    I16(Vec<i16>),
    U16(Vec<u16>),
    I32(Vec<i32>),
    U32(Vec<u32>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

/// Applies `$body` to the vector inside any [`ScalarData`] variant.
#[macro_export]
macro_rules! with_scalars {
    ($data:expr, $v:ident => $body:expr) => {
        match $data {
            $crate::model::ScalarData::I8($v) => $body,
            $crate::model::ScalarData::U8($v) => $body,
            $crate::model::ScalarData::I16($v) => $body,
            $crate::model::ScalarData::U16($v) => $body,
            $crate::model::ScalarData::I32($v) => $body,
            $crate::model::ScalarData::U32($v) => $body,
            $crate::model::ScalarData::F32($v) => $body,
            $crate::model::ScalarData::F64($v) => $body,
        }
    };
}

impl ScalarData {
    /// An empty column of type `t` with room for `cap` values.
    pub fn with_capacity(t: ScalarType, cap: usize) -> Self {
        match t {
            ScalarType::I8 => ScalarData::I8(Vec::with_capacity(cap)),
            ScalarType::U8 => ScalarData::U8(Vec::with_capacity(cap)),
            ScalarType::I16 => ScalarData::I16(Vec::with_capacity(cap)),
            ScalarType::U16 => ScalarData::U16(Vec::with_capacity(cap)),
            ScalarType::I32 => ScalarData::I32(Vec::with_capacity(cap)),
            ScalarType::U32 => ScalarData::U32(Vec::with_capacity(cap)),
            ScalarType::F32 => ScalarData::F32(Vec::with_capacity(cap)),
            ScalarType::F64 => ScalarData::F64(Vec::with_capacity(cap)),
        }
    }

    /// The element type.
    pub fn scalar_type(&self) -> ScalarType {
        match self {
            ScalarData::I8(_) => ScalarType::I8,
            ScalarData::U8(_) => ScalarType::U8,
            ScalarData::I16(_) => ScalarType::I16,
            ScalarData::U16(_) => ScalarType::U16,
            ScalarData::I32(_) => ScalarType::I32,
            ScalarData::U32(_) => ScalarType::U32,
            ScalarData::F32(_) => ScalarType::F32,
            ScalarData::F64(_) => ScalarType::F64,
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        with_scalars!(self, v => v.len())
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `i` widened to f64 (exact for every PLY type).
    pub fn get_f64(&self, i: usize) -> f64 {
        #[allow(clippy::unnecessary_cast)]
        let x = with_scalars!(self, v => v[i] as f64);
        x
    }

    /// The column converted to f32 (a copy; lossy for f64 and large ints).
    pub fn to_f32(&self) -> Vec<f32> {
        match self {
            ScalarData::F32(v) => v.clone(),
            #[allow(clippy::unnecessary_cast)]
            other => with_scalars!(other, v => v.iter().map(|&x| x as f32).collect()),
        }
    }

    /// The column converted to f64.
    pub fn to_f64(&self) -> Vec<f64> {
        #[allow(clippy::unnecessary_cast)]
        let v = with_scalars!(self, v => v.iter().map(|&x| x as f64).collect());
        v
    }

    /// Keeps the rows whose `keep` flag is set.
    pub fn filter(&self, keep: &[bool]) -> ScalarData {
        fn f<T: Copy>(v: &[T], keep: &[bool]) -> Vec<T> {
            v.iter()
                .zip(keep)
                .filter(|(_, k)| **k)
                .map(|(x, _)| *x)
                .collect()
        }
        match self {
            ScalarData::I8(v) => ScalarData::I8(f(v, keep)),
            ScalarData::U8(v) => ScalarData::U8(f(v, keep)),
            ScalarData::I16(v) => ScalarData::I16(f(v, keep)),
            ScalarData::U16(v) => ScalarData::U16(f(v, keep)),
            ScalarData::I32(v) => ScalarData::I32(f(v, keep)),
            ScalarData::U32(v) => ScalarData::U32(f(v, keep)),
            ScalarData::F32(v) => ScalarData::F32(f(v, keep)),
            ScalarData::F64(v) => ScalarData::F64(f(v, keep)),
        }
    }

    /// Rows in the order given by `idx`.
    pub fn gather(&self, idx: &[usize]) -> ScalarData {
        fn g<T: Copy>(v: &[T], idx: &[usize]) -> Vec<T> {
            idx.iter().map(|&i| v[i]).collect()
        }
        match self {
            ScalarData::I8(v) => ScalarData::I8(g(v, idx)),
            ScalarData::U8(v) => ScalarData::U8(g(v, idx)),
            ScalarData::I16(v) => ScalarData::I16(g(v, idx)),
            ScalarData::U16(v) => ScalarData::U16(g(v, idx)),
            ScalarData::I32(v) => ScalarData::I32(g(v, idx)),
            ScalarData::U32(v) => ScalarData::U32(g(v, idx)),
            ScalarData::F32(v) => ScalarData::F32(g(v, idx)),
            ScalarData::F64(v) => ScalarData::F64(g(v, idx)),
        }
    }
}

/// One property's values for every row of an element.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    /// One scalar per row.
    Scalar(ScalarData),
    /// A list per row: row `i` holds `values[offsets[i]..offsets[i+1]]`;
    /// `count_type` is the type of the length prefix in the file.
    List {
        count_type: ScalarType,
        offsets: Vec<usize>,
        values: ScalarData,
    },
}

impl Column {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        match self {
            Column::Scalar(d) => d.len(),
            Column::List { offsets, .. } => offsets.len().saturating_sub(1),
        }
    }

    /// The scalar column, if this is one.
    pub fn as_scalar(&self) -> Option<&ScalarData> {
        match self {
            Column::Scalar(d) => Some(d),
            Column::List { .. } => None,
        }
    }

    /// Keeps the rows whose `keep` flag is set.
    pub fn filter(&self, keep: &[bool]) -> Column {
        match self {
            Column::Scalar(d) => Column::Scalar(d.filter(keep)),
            Column::List { .. } => {
                let idx: Vec<usize> = (0..keep.len()).filter(|&i| keep[i]).collect();
                self.gather(&idx)
            }
        }
    }

    /// Rows in the order given by `idx`.
    pub fn gather(&self, idx: &[usize]) -> Column {
        match self {
            Column::Scalar(d) => Column::Scalar(d.gather(idx)),
            Column::List {
                count_type,
                offsets,
                values,
            } => {
                let mut new_offsets = Vec::with_capacity(idx.len() + 1);
                let mut flat = Vec::new();
                new_offsets.push(0);
                for &i in idx {
                    flat.extend(offsets[i]..offsets[i + 1]);
                    new_offsets.push(flat.len());
                }
                Column::List {
                    count_type: *count_type,
                    offsets: new_offsets,
                    values: values.gather(&flat),
                }
            }
        }
    }
}

/// A named column.
#[derive(Clone, Debug, PartialEq)]
pub struct Property {
    pub name: String,
    pub data: Column,
}

/// A PLY element: a name, a row count and its properties (in file order).
#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    pub name: String,
    pub count: usize,
    pub properties: Vec<Property>,
}

impl Element {
    /// An element with no properties yet.
    pub fn new(name: impl Into<String>, count: usize) -> Self {
        Element {
            name: name.into(),
            count,
            properties: Vec::new(),
        }
    }

    /// The property called `name`.
    pub fn property(&self, name: &str) -> Option<&Column> {
        self.properties
            .iter()
            .find(|p| p.name == name)
            .map(|p| &p.data)
    }

    /// Index of the property called `name`.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.properties.iter().position(|p| p.name == name)
    }

    /// Appends a property (its row count must equal `self.count`).
    pub fn push(&mut self, name: impl Into<String>, data: Column) {
        debug_assert_eq!(data.rows(), self.count);
        self.properties.push(Property {
            name: name.into(),
            data,
        });
    }

    /// Removes and returns the property called `name`.
    pub fn take(&mut self, name: &str) -> Option<Column> {
        let i = self.index_of(name)?;
        Some(self.properties.remove(i).data)
    }

    /// Keeps the rows whose `keep` flag is set (in every property).
    pub fn filter(&self, keep: &[bool]) -> Element {
        Element {
            name: self.name.clone(),
            count: keep.iter().filter(|k| **k).count(),
            properties: self
                .properties
                .iter()
                .map(|p| Property {
                    name: p.name.clone(),
                    data: p.data.filter(keep),
                })
                .collect(),
        }
    }
}

/// What a model read from a PLY did not itself interpret, carried along so
/// that a read-modify-write keeps it: extra properties of the model's main
/// elements (row-aligned with the model), other elements, comments, obj_info.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Extras {
    /// Extra properties of the per-item element (`vertex` for points and
    /// Gaussians, `face` for triangle soups), one row per item.
    pub item: Vec<Property>,
    /// Extra per-vertex properties of a mesh.
    pub vertex: Vec<Property>,
    /// Elements the model does not know, written back after its own.
    pub elements: Vec<Element>,
    /// `comment` lines of the header.
    pub comments: Vec<String>,
    /// `obj_info` lines of the header.
    pub obj_info: Vec<String>,
}

impl Extras {
    /// Keeps the item rows whose `keep` flag is set.
    pub fn filter_items(&mut self, keep: &[bool]) {
        for p in &mut self.item {
            p.data = p.data.filter(keep);
        }
    }

    /// Reorders / selects item rows.
    pub fn gather_items(&mut self, idx: &[usize]) {
        for p in &mut self.item {
            p.data = p.data.gather(idx);
        }
    }
}
