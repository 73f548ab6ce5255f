use super::pickle::{Value, unpickle};
use super::zip::StoredZipWriter;
use super::*;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

fn random_soup(rng: &mut Pcg64, n: usize, degree: usize) -> TriangleSoup {
    let k = (degree + 1) * (degree + 1) - 1;
    let mut f = || rng.random_range(-3.0f32..3.0);
    let mut soup = TriangleSoup {
        triangles: (0..n)
            .map(|_| [[f(), f(), f()], [f(), f(), f()], [f(), f(), f()]])
            .collect(),
        opacity_raw: (0..n).map(|_| f()).collect(),
        sigma_raw: (0..n).map(|_| f()).collect(),
        sh_degree: degree,
        active_sh_degree: degree.saturating_sub(1),
        sh_dc: (0..n).map(|_| [f(), f(), f()]).collect(),
        sh_rest: (0..n * k * 3).map(|_| f()).collect(),
        ..Default::default()
    };
    // Special values must survive bit for bit.
    if n > 3 {
        soup.opacity_raw[0] = f32::INFINITY;
        soup.sigma_raw[1] = f32::NEG_INFINITY;
        soup.triangles[2][1][0] = -0.0;
        soup.sh_dc[3][2] = f32::from_bits(0x7fc0_1234); // NaN with a payload
        soup.opacity_raw[3] = f32::MIN_POSITIVE / 8.0; // subnormal
    }
    soup
}

fn to_bytes(soup: &TriangleSoup) -> Vec<u8> {
    let mut out = Vec::new();
    write_triangle_checkpoint(&mut out, soup).unwrap();
    out
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn assert_bit_identical(a: &TriangleSoup, b: &TriangleSoup) {
    assert_eq!(a.len(), b.len());
    assert_eq!(a.sh_degree, b.sh_degree);
    assert_eq!(a.active_sh_degree, b.active_sh_degree);
    let flat = |s: &TriangleSoup| bits(bytemuck::cast_slice(&s.triangles));
    assert_eq!(flat(a), flat(b));
    assert_eq!(bits(&a.opacity_raw), bits(&b.opacity_raw));
    assert_eq!(bits(&a.sigma_raw), bits(&b.sigma_raw));
    assert_eq!(
        bits(bytemuck::cast_slice(&a.sh_dc)),
        bits(bytemuck::cast_slice(&b.sh_dc))
    );
    assert_eq!(bits(&a.sh_rest), bits(&b.sh_rest));
}

#[test]
fn round_trip_is_bit_identical() {
    let mut rng = Pcg64::seed_from_u64(7);
    for (n, degree) in [(0, 3), (1, 0), (5, 1), (17, 2), (300, 3)] {
        let soup = random_soup(&mut rng, n, degree);
        let bytes = to_bytes(&soup);
        let back = parse_triangle_checkpoint("rt.pt", &bytes).unwrap();
        assert_bit_identical(&soup, &back);
        assert!(back.extras.item.is_empty());
    }
}

#[test]
fn round_trip_keeps_scalar_extras() {
    let mut rng = Pcg64::seed_from_u64(8);
    let mut soup = random_soup(&mut rng, 6, 3);
    soup.extras.item = vec![
        Property {
            name: "importance".into(),
            data: Column::Scalar(ScalarData::F32(vec![0.5, 1.0, 2.0, 3.0, 4.0, 5.0])),
        },
        Property {
            name: "visible".into(),
            data: Column::Scalar(ScalarData::U8(vec![1, 0, 1, 1, 0, 1])),
        },
        Property {
            name: "count".into(),
            data: Column::Scalar(ScalarData::I32(vec![-1, 7, 1 << 30, 0, 3, 9])),
        },
        Property {
            name: "weight".into(),
            data: Column::Scalar(ScalarData::F64(vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6])),
        },
    ];
    let back = parse_triangle_checkpoint("x.pt", &to_bytes(&soup)).unwrap();
    assert_bit_identical(&soup, &back);
    assert_eq!(back.extras.item, soup.extras.item);
    // Filtering the read soup keeps extras row-aligned.
    let kept = back.filter(&[true, false, true, false, false, true]);
    assert_eq!(
        kept.extras.item[2].data,
        Column::Scalar(ScalarData::I32(vec![-1, 1 << 30, 9]))
    );
}

#[test]
fn zip64_records_are_read() {
    let mut rng = Pcg64::seed_from_u64(9);
    let soup = random_soup(&mut rng, 40, 2);
    let mut out = Vec::new();
    write_checkpoint_impl(&mut out, &soup, true).unwrap();
    let back = parse_triangle_checkpoint("z64.pt", &out).unwrap();
    assert_bit_identical(&soup, &back);
    // The zip crate agrees on the layout (independent reader).
    let za = ::zip::ZipArchive::new(std::io::Cursor::new(&out[..])).unwrap();
    let names: Vec<String> = za.file_names().map(|n| n.unwrap().into_owned()).collect();
    assert!(names.iter().any(|n| n == "archive/data.pkl"));
    assert!(names.iter().any(|n| n == "archive/version"));
}

/// The written archive has torch's layout: stored records, 64-byte aligned
/// data, the expected names and contents, valid CRCs.
#[test]
fn written_archive_has_torch_layout() {
    let mut rng = Pcg64::seed_from_u64(10);
    let soup = random_soup(&mut rng, 9, 3);
    let bytes = to_bytes(&soup);
    let mut za = ::zip::ZipArchive::new(std::io::Cursor::new(&bytes[..])).unwrap();
    let mut names = Vec::new();
    for i in 0..za.len() {
        let mut f = za.by_index(i).unwrap();
        assert_eq!(f.compression(), ::zip::CompressionMethod::Stored);
        assert_eq!(f.data_start().unwrap() % 64, 0, "{}", f.name().unwrap());
        let mut content = Vec::new();
        // Reading through the zip crate checks the CRC32 of each record.
        std::io::Read::read_to_end(&mut f, &mut content).unwrap();
        let name = f.name().unwrap().to_string();
        if name == "archive/version" {
            assert_eq!(content, b"3\n");
        }
        if name == "archive/byteorder" {
            assert_eq!(content, b"little");
        }
        if name == "archive/data/0" {
            assert_eq!(content.len(), 9 * 9 * 4);
            assert_eq!(&content[..], bytemuck::cast_slice::<_, u8>(&soup.triangles));
        }
        names.push(name);
    }
    assert_eq!(names[0], "archive/data.pkl");
    for i in 0..5 {
        assert!(names.contains(&format!("archive/data/{i}")));
    }
    // Keys in the training code's order, with active_sh_degree an int.
    let ck = TorchCheckpoint::parse("w.pt", &bytes).unwrap();
    let keys: Vec<&str> = ck.entries().iter().map(|(k, _)| k.as_str()).collect();
    assert_eq!(
        keys,
        [
            "triangles_points",
            "sigma",
            "active_sh_degree",
            "features_dc",
            "features_rest",
            "opacity"
        ]
    );
    assert_eq!(ck.get("active_sh_degree"), Some(&PtValue::Int(2)));
    assert_eq!(ck.tensor("features_rest").unwrap().shape, [9, 15, 3]);
}

/// Raw pickle opcodes for hand-assembled streams (independent of
/// `PickleWriter`), protocol 4 style.
#[derive(Default)]
struct Raw(Vec<u8>, u32);

impl Raw {
    fn b(&mut self, bytes: &[u8]) -> &mut Self {
        self.0.extend_from_slice(bytes);
        self
    }
    /// MEMOIZE (the entry index is the number of earlier MEMOIZEs).
    fn m(&mut self) -> &mut Self {
        self.0.push(0x94);
        self.1 += 1;
        self
    }
    /// LONG_BINGET.
    fn get(&mut self, i: u32) -> &mut Self {
        self.0.push(b'j');
        self.0.extend_from_slice(&i.to_le_bytes());
        self
    }
    /// SHORT_BINUNICODE + MEMOIZE.
    fn s(&mut self, s: &str) -> &mut Self {
        self.0.push(0x8c);
        self.0.push(s.len() as u8);
        self.0.extend_from_slice(s.as_bytes());
        self.m()
    }
    /// A global through STACK_GLOBAL.
    fn g(&mut self, module: &str, name: &str) -> &mut Self {
        self.s(module).s(name).b(&[0x93]).m()
    }
    /// BININT (4-byte signed).
    fn i(&mut self, v: i32) -> &mut Self {
        self.0.push(b'J');
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    /// MARK ints TUPLE.
    fn tuple(&mut self, v: &[i32]) -> &mut Self {
        self.b(b"(");
        for &x in v {
            self.i(x);
        }
        self.b(b"t")
    }
    /// `_rebuild_tensor_v2(persistent storage, offset, size, stride, False, OrderedDict())`
    /// with the storage given by `storage` (a closure pushing it).
    fn tensor(
        &mut self,
        storage: impl FnOnce(&mut Raw),
        offset: i32,
        size: &[i32],
        stride: &[i32],
    ) -> &mut Self {
        self.g("torch._utils", "_rebuild_tensor_v2");
        self.b(b"(");
        storage(self);
        self.i(offset).tuple(size).tuple(stride);
        self.b(&[0x89]);
        self.g("collections", "OrderedDict").b(b")R");
        self.b(b"tR")
    }
}

fn pid(r: &mut Raw, class: &str, key: &str, numel: i32) {
    r.b(b"(")
        .s("storage")
        .g("torch", class)
        .s(key)
        .s("cuda:0")
        .i(numel);
    r.b(b"tQ");
}

fn archive(records: &[(&str, &[u8])]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut z = StoredZipWriter::new(&mut out);
    for (name, data) in records {
        z.add(name, data).unwrap();
    }
    z.finish().unwrap();
    out
}

fn le_f32(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A checkpoint built opcode by opcode: OrderedDict top level with BUILD,
/// `_rebuild_parameter`, a transposed (non-contiguous) view with a storage
/// offset, a strided view sharing a memoized storage, an f16 and an f64
/// storage, an int64 per-triangle extra and an unknown object.
#[test]
fn hand_assembled_pickle_with_views_and_half() {
    const N: usize = 4;
    // Storage 0: 5 leading values, then 4×9 values; value j is 0.25·j − 3.
    let s0: Vec<f32> = (0..5 + 9 * N).map(|j| 0.25 * j as f32 - 3.0).collect();
    let s1: Vec<half::f16> = [0.5f32, -1.25, 2.0, 65504.0]
        .iter()
        .map(|&x| half::f16::from_f32(x))
        .collect();
    let s3: Vec<f32> = (0..N * 3).map(|j| j as f32 * 0.125).collect();
    let s4: Vec<f64> = (0..N * 9).map(|j| 1.0 / (j as f64 + 3.0)).collect();
    let s5: Vec<i64> = vec![10, -20, 30, 1 << 40];

    let mut r = Raw::default();
    r.b(&[0x80, 4, 0x95]).b(&0u64.to_le_bytes()); // PROTO 4, FRAME
    r.g("collections", "OrderedDict").b(b")R").m().b(b"(");
    // triangles_points: Parameter of a view of storage 0 at offset 5,
    // size (4,3,3), stride (9,1,3): element [i,v,c] = s0[5 + 9i + v + 3c].
    r.s("triangles_points")
        .g("torch._utils", "_rebuild_parameter");
    let mut storage0 = 0;
    r.b(b"(")
        .tensor(
            |r| {
                pid(r, "FloatStorage", "0", s0.len() as i32);
                storage0 = r.1;
                r.m();
            },
            5,
            &[4, 3, 3],
            &[9, 1, 3],
        )
        .b(&[0x88]) // requires_grad
        .g("collections", "OrderedDict")
        .b(b")R")
        .b(b"tR");
    // sigma: a view of the same storage object, fetched from the memo:
    // offset 0, size (4,1), stride (2,1) -> s0[0], s0[2], s0[4], s0[6].
    r.s("sigma").tensor(
        |r| {
            r.get(storage0);
        },
        0,
        &[4, 1],
        &[2, 1],
    );
    r.s("opacity")
        .tensor(|r| pid(r, "HalfStorage", "1", 4), 0, &[4, 1], &[1, 1]);
    r.s("features_dc").tensor(
        |r| pid(r, "FloatStorage", "3", 12),
        0,
        &[4, 1, 3],
        &[3, 3, 1],
    );
    r.s("features_rest").tensor(
        |r| pid(r, "DoubleStorage", "4", 36),
        0,
        &[4, 3, 3],
        &[9, 3, 1],
    );
    r.s("active_sh_degree").b(&[b'K', 1]);
    r.s("importance")
        .tensor(|r| pid(r, "LongStorage", "5", 4), 0, &[4], &[1]);
    // An object that must not be executed, only carried as opaque.
    r.s("callback")
        .g("os", "system")
        .s("echo pwned")
        .b(&[0x85])
        .b(b"R");
    r.b(b"u");
    // BUILD with a state dict (OrderedDict._metadata), then STOP.
    r.b(b"}").s("_metadata").b(b"N").b(b"s").b(b"b.");

    let f16_bytes: Vec<u8> = s1.iter().flat_map(|x| x.to_bits().to_le_bytes()).collect();
    let f64_bytes: Vec<u8> = s4.iter().flat_map(|x| x.to_le_bytes()).collect();
    let i64_bytes: Vec<u8> = s5.iter().flat_map(|x| x.to_le_bytes()).collect();
    let bytes = archive(&[
        ("model/data.pkl", &r.0),
        ("model/byteorder", b"little"),
        ("model/data/0", &le_f32(&s0)),
        ("model/data/1", &f16_bytes),
        ("model/data/3", &le_f32(&s3)),
        ("model/data/4", &f64_bytes),
        ("model/data/5", &i64_bytes),
        ("model/version", b"3\n"),
    ]);
    let soup = parse_triangle_checkpoint("hand.pt", &bytes).unwrap();
    assert_eq!(soup.len(), N);
    for i in 0..N {
        for v in 0..3 {
            for c in 0..3 {
                assert_eq!(soup.triangles[i][v][c], s0[5 + 9 * i + v + 3 * c]);
            }
        }
        assert_eq!(soup.sigma_raw[i], s0[2 * i]);
        assert_eq!(soup.opacity_raw[i], s1[i].to_f32());
        assert_eq!(soup.sh_dc[i], [s3[3 * i], s3[3 * i + 1], s3[3 * i + 2]]);
    }
    assert_eq!(soup.opacity_raw, [0.5, -1.25, 2.0, 65504.0]);
    assert_eq!(soup.sh_degree, 1);
    assert_eq!(soup.active_sh_degree, 1);
    let rest: Vec<f32> = s4.iter().map(|&x| x as f32).collect();
    assert_eq!(soup.sh_rest, rest);
    // int64 values beyond i32 become f64.
    assert_eq!(soup.extras.item.len(), 1);
    assert_eq!(soup.extras.item[0].name, "importance");
    assert_eq!(
        soup.extras.item[0].data,
        Column::Scalar(ScalarData::F64(vec![
            10.0,
            -20.0,
            30.0,
            (1u64 << 40) as f64
        ]))
    );
    let ck = TorchCheckpoint::parse("hand.pt", &bytes).unwrap();
    assert_eq!(
        ck.get("callback"),
        Some(&PtValue::Other("object os.system(...)".into()))
    );
}

#[test]
fn big_endian_storages_are_swapped() {
    let mut r = Raw::default();
    r.b(&[0x80, 2]).b(b"}(").s("x");
    r.tensor(|r| pid(r, "FloatStorage", "0", 3), 0, &[3], &[1]);
    r.s("y")
        .tensor(|r| pid(r, "IntStorage", "1", 2), 1, &[1], &[1]);
    r.b(b"u.");
    let be: Vec<u8> = [1.5f32, -2.0, 3.25]
        .iter()
        .flat_map(|x| x.to_be_bytes())
        .collect();
    let ints: Vec<u8> = [7i32, -9].iter().flat_map(|x| x.to_be_bytes()).collect();
    let bytes = archive(&[
        ("a/data.pkl", &r.0),
        ("a/byteorder", b"big"),
        ("a/data/0", &be),
        ("a/data/1", &ints),
    ]);
    let ck = TorchCheckpoint::parse("be.pt", &bytes).unwrap();
    assert_eq!(
        ck.tensor_f32("x").unwrap(),
        (vec![3], vec![1.5, -2.0, 3.25])
    );
    assert_eq!(ck.tensor_i64("y").unwrap(), (vec![1], vec![-9]));
}

#[test]
fn pickle_values() {
    let mut r = Raw::default();
    r.b(&[0x80, 2]);
    r.b(b"]").b(b"(");
    r.b(&[0x8a, 2, 0x00, 0x80]); // LONG1 -32768
    r.b(&[0x8a, 9, 1, 0, 0, 0, 0, 0, 0, 0, 0]); // LONG1 1 with sign padding
    r.b(&[0x8a, 9, 0, 0, 0, 0, 0, 0, 0, 0, 1]); // 2^64: does not fit
    r.b(b"G").b(&2.5f64.to_be_bytes());
    r.b(b"X").b(&3u32.to_le_bytes()).b("é!".as_bytes());
    r.b(&[b'C', 2, 9, 9]); // bytes
    r.b(&[b'M', 0x34, 0x12]);
    r.i(-5);
    r.b(&[0x88, 0x89, b'N']);
    r.b(b"e");
    r.b(&[b'q', 7]); // memoize the list
    r.b(&[b'K', 1]).b(b"a"); // mutate the list after memoizing it
    r.b(&[b'h', 7]); // the memo keeps the value as stored
    r.b(&[0x86, b'.']);
    let Value::Tuple(t) = unpickle(&r.0).unwrap() else {
        panic!("expected a tuple")
    };
    let (Value::List(now), Value::List(memo)) = (&t.items[0], &t.items[1]) else {
        panic!("expected two lists")
    };
    assert_eq!(now.items.len(), memo.items.len() + 1);
    let want = [
        Value::Int(-32768),
        Value::Int(1),
        Value::BigInt(9),
        Value::Float(2.5),
        Value::Str("é!".into()),
        Value::Bytes(2),
        Value::Int(0x1234),
        Value::Int(-5),
        Value::Bool(true),
        Value::Bool(false),
        Value::None,
    ];
    assert_eq!(memo.items, want);
    assert_eq!(now.items.last(), Some(&Value::Int(1)));
}

#[test]
fn pickle_repeated_key_replaces_value() {
    let mut r = Raw::default();
    r.b(&[0x80, 2])
        .b(b"}(")
        .s("a")
        .b(&[b'K', 1])
        .s("b")
        .b(&[b'K', 2]);
    r.s("a").b(&[b'K', 3]).b(b"u.");
    let Value::Dict(m) = unpickle(&r.0).unwrap() else {
        panic!("expected a dict")
    };
    assert_eq!(m.items.len(), 2);
    assert_eq!(m.get("a"), Some(&Value::Int(3)));
}

#[test]
fn pickle_errors_name_the_offset() {
    let cases: &[(&[u8], usize, &str)] = &[
        (b"\x80\x02}q\x00(K\x01u.", 8, "odd number"),
        (b"\x80\x02h\x05.", 2, "memo entry 5"),
        (b"\x80\x02I12\n.", 2, "unsupported pickle opcode 0x49 ('I')"),
        (b"\x80\x02X\xff\xff\xff\x7fab.", 2, "exceeds"),
        (b"\x80\x02K\x01", 4, "truncated"),
        (b"\x80\x02.", 2, "underflow"),
        (
            b"\x80\x02(K\x01K\x02\x86\x01.",
            8,
            "unsupported pickle opcode 0x01",
        ),
        (b"\x80\x09.", 0, "protocol 9"),
        (b"\x80\x02(K\x01\x86.", 5, "underflow"),
    ];
    for (data, offset, msg) in cases {
        let e = unpickle(data).unwrap_err();
        assert_eq!(e.offset, *offset, "{data:?}: {}", e.msg);
        assert!(e.msg.contains(msg), "{data:?}: {}", e.msg);
    }
}

#[test]
fn pickle_nesting_is_bounded() {
    // 200 nested lists built with MARK ... LIST.
    let nested = |depth: usize| {
        let mut data = vec![0x80, 2];
        data.extend(std::iter::repeat_n(b'(', depth));
        data.push(b'N');
        data.extend(std::iter::repeat_n(b'l', depth));
        data.push(b'.');
        data
    };
    let e = unpickle(&nested(200)).unwrap_err();
    assert!(e.msg.contains("nested deeper"), "{}", e.msg);
    assert!(matches!(unpickle(&nested(60)), Ok(Value::List(_))));
}

/// Memo fetches share values instead of copying them: 5000 references to a
/// tuple holding 5000 references to a 1000-element list (25 million
/// elements if copied) parse at once.
#[test]
fn pickle_memo_fetches_share() {
    let mut data = vec![0x80, 2, b'('];
    for _ in 0..1000 {
        data.extend([b'K', 1]);
    }
    data.extend([b'l', b'q', 0, b'(']);
    for _ in 0..5000 {
        data.extend([b'h', 0]);
    }
    data.extend([b't', b'q', 1, b'(']);
    for _ in 0..5000 {
        data.extend([b'h', 1]);
    }
    data.extend([b'l', b'.']);
    let Value::List(outer) = unpickle(&data).unwrap() else {
        panic!("expected a list")
    };
    let Value::Tuple(mid) = &outer.items[4999] else {
        panic!("expected a tuple")
    };
    let Value::List(inner) = &mid.items[4999] else {
        panic!("expected a list")
    };
    assert_eq!(inner.items.len(), 1000);
}

/// (key, storage class, size, stride, storage numel).
type Entry<'a> = (&'a str, &'a str, Vec<i32>, &'a [i32], usize);

fn soup_entry_bytes(keys: &[Entry]) -> Vec<u8> {
    // (key, storage class, size, stride, storage numel) with zero-filled f32 storages.
    let mut r = Raw::default();
    r.b(&[0x80, 2]).b(b"}(");
    let mut recs: Vec<(String, Vec<u8>)> = Vec::new();
    for (i, (key, class, size, stride, numel)) in keys.iter().enumerate() {
        let sk = i.to_string();
        r.s(key)
            .tensor(|r| pid(r, class, &sk, *numel as i32), 0, size, stride);
        recs.push((format!("a/data/{i}"), vec![0u8; numel * 4]));
    }
    r.b(b"u.");
    let mut all: Vec<(&str, &[u8])> = vec![("a/data.pkl", &r.0)];
    for (n, b) in &recs {
        all.push((n, b));
    }
    archive(&all)
}

#[test]
fn shape_errors_name_the_key() {
    let n = 5;
    let good = |k: &'static str| -> (&'static str, &'static str, Vec<i32>, &'static [i32], usize) {
        match k {
            "triangles_points" => (k, "FloatStorage", vec![n, 3, 3], &[9, 3, 1], 45),
            "opacity" | "sigma" => (k, "FloatStorage", vec![n, 1], &[1, 1], 5),
            "features_dc" => (k, "FloatStorage", vec![n, 1, 3], &[3, 3, 1], 15),
            "features_rest" => (k, "FloatStorage", vec![n, 15, 3], &[45, 3, 1], 225),
            _ => unreachable!(),
        }
    };
    let keys = [
        "triangles_points",
        "opacity",
        "sigma",
        "features_dc",
        "features_rest",
    ];
    let all: Vec<_> = keys.iter().map(|k| good(k)).collect();
    let soup = parse_triangle_checkpoint("ok.pt", &soup_entry_bytes(&all)).unwrap();
    assert_eq!(
        (soup.len(), soup.sh_degree, soup.active_sh_degree),
        (5, 3, 3)
    );

    let bad: Vec<(_, &str)> = vec![
        (
            (
                "triangles_points",
                "FloatStorage",
                vec![5, 9],
                &[9, 1][..],
                45,
            ),
            "triangles_points",
        ),
        (
            (
                "triangles_points",
                "FloatStorage",
                vec![5, 3, 2],
                &[6, 2, 1][..],
                45,
            ),
            "triangles_points",
        ),
        (
            ("opacity", "FloatStorage", vec![4, 1], &[1, 1][..], 5),
            "opacity",
        ),
        (
            ("sigma", "FloatStorage", vec![5, 2], &[2, 1][..], 10),
            "sigma",
        ),
        (
            (
                "features_dc",
                "FloatStorage",
                vec![5, 2, 3],
                &[6, 3, 1][..],
                30,
            ),
            "features_dc",
        ),
        (
            (
                "features_rest",
                "FloatStorage",
                vec![5, 7, 3],
                &[21, 3, 1][..],
                105,
            ),
            "features_rest",
        ),
        (
            (
                "features_rest",
                "FloatStorage",
                vec![6, 15, 3],
                &[45, 3, 1][..],
                270,
            ),
            "features_rest",
        ),
        (
            (
                "features_dc",
                "IntStorage",
                vec![5, 1, 3],
                &[3, 3, 1][..],
                15,
            ),
            "features_dc",
        ),
        // View past the end of its storage.
        (
            ("sigma", "FloatStorage", vec![5, 1], &[2, 1][..], 6),
            "sigma",
        ),
    ];
    for (replacement, key) in bad {
        let entries: Vec<_> = keys
            .iter()
            .map(|k| {
                if *k == replacement.0 {
                    replacement.clone()
                } else {
                    good(k)
                }
            })
            .collect();
        let e = parse_triangle_checkpoint("bad.pt", &soup_entry_bytes(&entries)).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("bad.pt: "), "{msg}");
        assert!(msg.contains(&format!("\"{key}\"")), "{msg}");
    }
    // A missing key is named.
    let e = parse_triangle_checkpoint("m.pt", &soup_entry_bytes(&all[..3])).unwrap_err();
    assert!(e.to_string().contains("missing key \"features_dc\""), "{e}");
}

#[test]
fn declared_sizes_are_checked_before_allocating() {
    // A view claiming 2^31−1 rows over a 45-value storage, a storage whose
    // declared numel exceeds its record, and an overflowing shape product.
    let cases: Vec<Vec<Entry>> = vec![
        vec![(
            "triangles_points",
            "FloatStorage",
            vec![i32::MAX, 3, 3],
            &[9, 3, 1],
            45,
        )],
        vec![(
            "triangles_points",
            "FloatStorage",
            vec![i32::MAX, i32::MAX, i32::MAX],
            &[1, 1, 1],
            45,
        )],
    ];
    let msgs = ["more than its storage's 45", "shape product overflows"];
    for (entries, msg) in cases.into_iter().zip(msgs) {
        let bytes = soup_entry_bytes(&entries);
        let e = parse_triangle_checkpoint("big.pt", &bytes).unwrap_err();
        assert!(e.to_string().contains("\"triangles_points\""), "{e}");
        assert!(e.to_string().contains(msg), "{e}");
    }
    // The storage record is shorter than the persistent id says.
    let mut r = Raw::default();
    r.b(&[0x80, 2]).b(b"}(").s("triangles_points");
    r.tensor(
        |r| pid(r, "FloatStorage", "0", i32::MAX),
        0,
        &[1, 3, 3],
        &[9, 3, 1],
    );
    r.b(b"u.");
    let bytes = archive(&[("a/data.pkl", &r.0), ("a/data/0", &[0u8; 36])]);
    let e = parse_triangle_checkpoint("short.pt", &bytes).unwrap_err();
    assert!(e.to_string().contains("record holds 36 bytes"), "{e}");
}

#[test]
fn broadcast_stride_zero_view_is_read() {
    // A [3,3,3] view with stride (0,3,1) repeats one triangle (9 values) in a
    // 27-value storage: 27 elements ≤ storage numel, so it is allowed.
    let mut r = Raw::default();
    r.b(&[0x80, 2]).b(b"}(").s("t");
    r.tensor(
        |r| pid(r, "FloatStorage", "0", 27),
        2,
        &[3, 3, 3],
        &[0, 3, 1],
    );
    r.b(b"u.");
    let vals: Vec<f32> = (0..27).map(|i| i as f32).collect();
    let bytes = archive(&[("a/data.pkl", &r.0), ("a/data/0", &le_f32(&vals))]);
    let ck = TorchCheckpoint::parse("b.pt", &bytes).unwrap();
    let (_, v) = ck.tensor_f32("t").unwrap();
    let one: Vec<f32> = (2..11).map(|i| i as f32).collect();
    assert_eq!(v, [one.clone(), one.clone(), one].concat());
}

fn tsplus_bytes(sigma_size: &[i32], bad_index: bool) -> Vec<u8> {
    // 4 vertices, 2 triangles (0,1,2), (0,2,3); degree-1 SH per vertex.
    let verts: [f32; 12] = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.];
    let idx: [i64; 6] = [0, 1, 2, 0, 2, if bad_index { 4 } else { 3 }];
    let dc: Vec<f32> = (0..12).map(|j| j as f32 * 0.5).collect();
    let rest: Vec<f32> = (0..36).map(|j| (j as f32 - 18.0) * 0.1).collect();
    let w: [f32; 4] = [-2.0, 0.0, 3.0, 6.0];
    let mut r = Raw::default();
    r.b(&[0x80, 2]).b(b"}(");
    r.s("triangles_points")
        .tensor(|r| pid(r, "FloatStorage", "0", 12), 0, &[4, 3], &[3, 1]);
    r.s("_triangle_indices")
        .tensor(|r| pid(r, "LongStorage", "1", 6), 0, &[2, 3], &[3, 1]);
    r.s("features_dc").tensor(
        |r| pid(r, "FloatStorage", "2", 12),
        0,
        &[4, 1, 3],
        &[3, 3, 1],
    );
    r.s("features_rest").tensor(
        |r| pid(r, "FloatStorage", "3", 36),
        0,
        &[4, 3, 3],
        &[9, 3, 1],
    );
    r.s("vertex_weight")
        .tensor(|r| pid(r, "FloatStorage", "4", 4), 0, &[4, 1], &[1, 1]);
    let stride: Vec<i32> = sigma_size.iter().map(|_| 1).collect();
    r.s("sigma")
        .tensor(|r| pid(r, "FloatStorage", "5", 1), 0, sigma_size, &stride);
    r.s("active_sh_degree").b(&[b'K', 1]);
    r.b(b"u.");
    let i64b: Vec<u8> = idx.iter().flat_map(|x| x.to_le_bytes()).collect();
    archive(&[
        ("ts/data.pkl", &r.0),
        ("ts/data/0", &le_f32(&verts)),
        ("ts/data/1", &i64b),
        ("ts/data/2", &le_f32(&dc)),
        ("ts/data/3", &le_f32(&rest)),
        ("ts/data/4", &le_f32(&w)),
        ("ts/data/5", &le_f32(&[-1.5])),
    ])
}

#[test]
fn triangle_splatting_plus_is_converted() {
    let soup = parse_triangle_checkpoint("tsp.pt", &tsplus_bytes(&[], false)).unwrap();
    assert_eq!(soup.len(), 2);
    assert_eq!(
        soup.triangles[1],
        [[0., 0., 0.], [1., 1., 0.], [0., 1., 0.]]
    );
    assert_eq!(soup.sigma_raw, [-1.5, -1.5]);
    assert_eq!((soup.sh_degree, soup.active_sh_degree), (1, 1));
    // Triangle 1 = vertices 0, 2, 3: dc mean of channel c = 0.5·(c + (6+c) + (9+c))/3.
    for c in 0..3 {
        let want = 0.5 * (c as f32 * 3.0 + 15.0) / 3.0;
        assert!((soup.sh_dc[1][c] - want).abs() < 1e-6, "{c}");
    }
    // Rest coefficient j of triangle 0 (vertices 0,1,2): mean of 0.1·(j − 18 + 9v).
    for j in 0..9 {
        let want = (0..3)
            .map(|v| (j as f32 + 9.0 * v as f32 - 18.0) * 0.1)
            .sum::<f32>()
            / 3.0;
        // f32 rounding of the stored values and of the mean: a few ulps of 1.
        assert!((soup.sh_rest[j] - want).abs() < 1e-6, "{j}");
    }
    // Opacity: α = 0.9999 + 0.0001·sigmoid(mean w); logit computed here in
    // f64 the direct way (fine at these weights).
    for (t, m) in [(0, (-2.0 + 0.0 + 3.0) / 3.0), (1, (-2.0 + 3.0 + 6.0) / 3.0)] {
        let s = 1.0 / (1.0 + f64::exp(-m));
        let alpha = 0.9999 + 0.0001 * s;
        let want = (alpha / (1.0 - alpha)).ln();
        // The direct formula loses ~1e-12 relative in 1 − α; f32 storage
        // rounds to ~1e-6 relative of ~10.
        assert!((soup.opacity_raw[t] as f64 - want).abs() < 1e-5, "{t}");
        assert!((soup.opacity(t) as f64 - alpha).abs() < 1e-6);
    }
    // Scalar sigma given as [1] and per triangle.
    assert!(parse_triangle_checkpoint("s1.pt", &tsplus_bytes(&[1], false)).is_ok());
    let e = parse_triangle_checkpoint("s3.pt", &tsplus_bytes(&[1, 1, 1, 1], false));
    assert!(e.is_ok(), "numel 1 in any shape is a scalar");
    let e = parse_triangle_checkpoint("bad.pt", &tsplus_bytes(&[], true)).unwrap_err();
    assert!(
        e.to_string()
            .contains("\"_triangle_indices\": triangle 1 refers to vertex 4"),
        "{e}"
    );
}

fn catch<T>(f: impl FnOnce() -> T + std::panic::UnwindSafe) -> T {
    match std::panic::catch_unwind(f) {
        Ok(v) => v,
        Err(_) => panic!("the reader panicked"),
    }
}

/// Every truncation of a checkpoint is an error; byte flips never panic
/// and, when they still parse, give a consistent soup.
#[test]
fn fuzz_checkpoint_bytes() {
    let mut rng = Pcg64::seed_from_u64(11);
    let soup = random_soup(&mut rng, 3, 1);
    let bytes = to_bytes(&soup);
    for len in 0..bytes.len() {
        let cut = &bytes[..len];
        let r = catch(|| parse_triangle_checkpoint("cut.pt", cut));
        assert!(r.is_err(), "truncation to {len} bytes parsed");
    }
    let mut ok = 0;
    for trial in 0..3000 {
        let mut m = bytes.clone();
        let flips = 1 + trial % 3;
        for _ in 0..flips {
            let at = rng.random_range(0..m.len());
            m[at] ^= 1 << rng.random_range(0..8);
        }
        if let Ok(s) = catch(|| parse_triangle_checkpoint("flip.pt", &m)) {
            s.validate().unwrap();
            ok += 1;
        }
    }
    // Flips inside tensor data, CRCs and timestamps are not detectable, so
    // some mutants parse; most hit structure.
    eprintln!("{ok} of 3000 flipped checkpoints parsed");
    assert!(ok > 0 && ok < 3000, "{ok}");
}

/// Truncations and flips of `data.pkl` alone (the archive rebuilt around it).
#[test]
fn fuzz_data_pkl() {
    let mut rng = Pcg64::seed_from_u64(12);
    let soup = random_soup(&mut rng, 4, 1);
    let bytes = to_bytes(&soup);
    let ck = TorchCheckpoint::parse("p.pt", &bytes).unwrap();
    let pkl = ck.archive.record("data.pkl").unwrap().into_owned();
    let storages: Vec<Vec<u8>> = (0..5)
        .map(|i| {
            ck.archive
                .record(&format!("data/{i}"))
                .unwrap()
                .into_owned()
        })
        .collect();
    let rebuild = |p: &[u8]| {
        let mut recs: Vec<(String, &[u8])> = vec![("archive/data.pkl".into(), p)];
        for (i, s) in storages.iter().enumerate() {
            recs.push((format!("archive/data/{i}"), s));
        }
        let refs: Vec<(&str, &[u8])> = recs.iter().map(|(n, b)| (n.as_str(), *b)).collect();
        archive(&refs)
    };
    assert_bit_identical(
        &soup,
        &parse_triangle_checkpoint("p.pt", &rebuild(&pkl)).unwrap(),
    );
    for len in 0..pkl.len() {
        let a = rebuild(&pkl[..len]);
        let r = catch(|| parse_triangle_checkpoint("cut.pt", &a));
        let e = r.expect_err("truncated data.pkl parsed");
        assert!(e.to_string().contains("data.pkl byte"), "{e}");
    }
    for trial in 0..3000 {
        let mut m = pkl.clone();
        for _ in 0..1 + trial % 2 {
            let at = rng.random_range(0..m.len());
            m[at] = if trial % 4 == 0 {
                rng.random()
            } else {
                m[at] ^ (1 << rng.random_range(0..8))
            };
        }
        let a = rebuild(&m);
        if let Ok(s) = catch(|| parse_triangle_checkpoint("flip.pt", &a)) {
            s.validate().unwrap();
        }
    }
}

#[test]
fn legacy_and_foreign_files_are_rejected_clearly() {
    let e = parse_triangle_checkpoint("old.pt", b"\x80\x02\x8a\x0alz\xfc\x9cF\xf9 j\xa8P\x19.")
        .unwrap_err();
    assert!(e.to_string().contains("legacy torch format"), "{e}");
    let e = parse_triangle_checkpoint("x.ply", b"ply\nformat ascii 1.0\n").unwrap_err();
    assert!(e.to_string().contains("not a torch zip archive"), "{e}");
    // A zip without data.pkl.
    let z = archive(&[("a/readme.txt", b"hello")]);
    let e = parse_triangle_checkpoint("z.zip", &z).unwrap_err();
    assert!(e.to_string().contains("no data.pkl"), "{e}");
}

#[test]
fn read_from_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("point_cloud_state_dict.pt");
    let mut rng = Pcg64::seed_from_u64(13);
    let soup = random_soup(&mut rng, 10, 3);
    std::fs::write(&path, to_bytes(&soup)).unwrap();
    assert_bit_identical(&soup, &read_triangle_checkpoint(&path).unwrap());
    let e = read_triangle_checkpoint(&dir.path().join("missing.pt")).unwrap_err();
    assert!(e.to_string().contains("missing.pt"), "{e}");
}

/// `stored` (a checkpoint) re-zipped with every record deflated, after
/// `edit(name, data)` has had a chance to change each record.
fn repack_deflated(stored: &[u8], edit: impl Fn(&str, &mut Vec<u8>)) -> Vec<u8> {
    let mut src = ::zip::ZipArchive::new(std::io::Cursor::new(stored)).unwrap();
    let mut out = std::io::Cursor::new(Vec::new());
    {
        let mut w = ::zip::ZipWriter::new(&mut out);
        let opts = ::zip::write::SimpleFileOptions::default()
            .compression_method(::zip::CompressionMethod::Deflated);
        for i in 0..src.len() {
            let mut f = src.by_index(i).unwrap();
            let name = f.name().unwrap().to_string();
            let mut data = Vec::new();
            std::io::Read::read_to_end(&mut f, &mut data).unwrap();
            edit(&name, &mut data);
            w.start_file(name, opts).unwrap();
            std::io::Write::write_all(&mut w, &data).unwrap();
        }
        w.finish().unwrap();
    }
    out.into_inner()
}

/// A checkpoint re-zipped with deflate compression (not what torch writes,
/// but what an archiver may produce) is inflated and read.
#[test]
fn deflated_records_are_inflated() {
    let mut rng = Pcg64::seed_from_u64(14);
    let soup = random_soup(&mut rng, 12, 2);
    let stored = to_bytes(&soup);
    let deflated = repack_deflated(&stored, |_, _| {});
    let mut za = ::zip::ZipArchive::new(std::io::Cursor::new(&deflated[..])).unwrap();
    assert_eq!(
        za.by_index_raw(0).unwrap().compression(),
        ::zip::CompressionMethod::Deflated
    );
    assert_bit_identical(
        &soup,
        &parse_triangle_checkpoint("d.pt", &deflated).unwrap(),
    );
}

/// A storage record that inflates to far more than its tensors need (a
/// small file claiming a large uncompressed size, as a "zip bomb") is
/// refused before it is inflated: the declared size is checked against the
/// storage's element count times its element size.
#[test]
fn oversized_deflated_records_are_refused_before_inflating() {
    let mut rng = Pcg64::seed_from_u64(16);
    let soup = random_soup(&mut rng, 12, 2);
    let stored = to_bytes(&soup);
    let bomb = repack_deflated(&stored, |name, data| {
        if name.ends_with("/data/0") {
            data.resize(data.len() + (20 << 20), 0);
        }
    });
    assert!(
        bomb.len() < 200_000,
        "the padded archive stays small: {}",
        bomb.len()
    );
    let e = parse_triangle_checkpoint("bomb.pt", &bomb)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("bomb.pt") && e.contains("needs at most"),
        "{e}"
    );
}

/// Enough extras that the writer's memo passes 256 entries (LONG_BINPUT /
/// LONG_BINGET) and the storage keys reach two digits.
#[test]
fn many_extras_use_long_memo_indices() {
    let mut rng = Pcg64::seed_from_u64(15);
    let mut soup = random_soup(&mut rng, 3, 0);
    for c in 0..40 {
        soup.extras.item.push(Property {
            name: format!("extra_{c}"),
            data: Column::Scalar(ScalarData::F32(vec![c as f32, -(c as f32), 0.5])),
        });
    }
    let bytes = to_bytes(&soup);
    let ck = TorchCheckpoint::parse("m.pt", &bytes).unwrap();
    let pkl = ck.archive.record("data.pkl").unwrap();
    // LONG_BINPUT of an index in 256..512.
    assert!(pkl.windows(5).any(|w| w[0] == b'r' && w[2..5] == [1, 0, 0]));
    let back = parse_triangle_checkpoint("m.pt", &bytes).unwrap();
    assert_bit_identical(&soup, &back);
    assert_eq!(back.extras.item, soup.extras.item);
}

/// `_rebuild_tensor_v3` (uint16/32/64 since torch 2.3): an untyped byte
/// storage viewed with an explicit dtype; and a storage type the reader does
/// not know (complex) leaves its key opaque without failing the read.
#[test]
fn rebuild_tensor_v3_and_unknown_storage_types() {
    let mut r = Raw::default();
    r.b(&[0x80, 2]).b(b"}(").s("u");
    r.g("torch._utils", "_rebuild_tensor_v3").b(b"(");
    pid(&mut r, "UntypedStorage", "0", 10); // 10 bytes = 5 uint16
    r.i(1).tuple(&[2, 2]).tuple(&[1, 2]).b(&[0x89]);
    r.g("collections", "OrderedDict").b(b")R");
    r.g("torch", "uint16").b(b"tR");
    r.s("z")
        .tensor(|r| pid(r, "ComplexFloatStorage", "1", 2), 0, &[2], &[1]);
    r.b(b"u.");
    let vals: Vec<u8> = [1u16, 2, 3, 65535, 5]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let bytes = archive(&[
        ("a/data.pkl", &r.0),
        ("a/data/0", &vals),
        ("a/data/1", &[0u8; 16]),
    ]);
    let ck = TorchCheckpoint::parse("v3.pt", &bytes).unwrap();
    let t = ck.tensor("u").unwrap();
    assert_eq!((t.dtype, t.shape.clone()), (DType::U16, vec![2, 2]));
    // Offset 1, transposed strides: [[2, 3], [65535, 5]] read column-major.
    assert_eq!(ck.tensor_i64("u").unwrap().1, [2, 65535, 3, 5]);
    assert!(matches!(ck.get("z"), Some(PtValue::Other(_))));
    let e = ck.tensor_f32("z").unwrap_err();
    assert!(
        e.to_string().contains("key \"z\": expected a tensor"),
        "{e}"
    );
}
