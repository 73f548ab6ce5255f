use std::io::Write;

use super::*;
use rand::{RngExt, SeedableRng};

const NUMERIC: [MatClass; 10] = [
    MatClass::Double,
    MatClass::Single,
    MatClass::Int8,
    MatClass::Uint8,
    MatClass::Int16,
    MatClass::Uint16,
    MatClass::Int32,
    MatClass::Uint32,
    MatClass::Int64,
    MatClass::Uint64,
];

// ---- hand assembly of MAT-file bytes, independent of the writer ----

fn word(be: bool, v: u32) -> [u8; 4] {
    if be { v.to_be_bytes() } else { v.to_le_bytes() }
}

fn header(be: bool) -> Vec<u8> {
    let mut h = vec![b' '; 128];
    h[..20].copy_from_slice(b"MATLAB 5.0 MAT-file,");
    h[116..124].fill(0);
    if be {
        h[124..128].copy_from_slice(&[0x01, 0x00, b'M', b'I']);
    } else {
        h[124..128].copy_from_slice(&[0x00, 0x01, b'I', b'M']);
    }
    h
}

/// Tag, data, zero padding to 8 bytes.
fn element(be: bool, ty: u32, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&word(be, ty));
    out.extend_from_slice(&word(be, data.len() as u32));
    out.extend_from_slice(data);
    while out.len() % 8 != 0 {
        out.push(0);
    }
    out
}

/// Small data element: (bytes << 16 | type), then the data in 4 bytes.
fn small(be: bool, ty: u32, data: &[u8]) -> Vec<u8> {
    assert!(data.len() <= 4);
    let mut out = word(be, ((data.len() as u32) << 16) | ty).to_vec();
    out.extend_from_slice(data);
    out.resize(8, 0);
    out
}

fn flags(be: bool, class: u32, extra: u32) -> Vec<u8> {
    let mut d = word(be, class | extra).to_vec();
    d.extend_from_slice(&[0; 4]);
    element(be, MI_UINT32, &d)
}

fn dims(be: bool, d: &[i32]) -> Vec<u8> {
    let bytes: Vec<u8> = d.iter().flat_map(|&v| word(be, v as u32)).collect();
    element(be, MI_INT32, &bytes)
}

fn matrix(be: bool, parts: &[Vec<u8>]) -> Vec<u8> {
    element(be, MI_MATRIX, &parts.concat())
}

fn file(be: bool, elements: &[Vec<u8>]) -> Vec<u8> {
    let mut out = header(be);
    for e in elements {
        out.extend_from_slice(e);
    }
    out
}

fn compressed(element: &[u8]) -> Vec<u8> {
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    z.write_all(element).unwrap();
    let z = z.finish().unwrap();
    let mut out = MI_COMPRESSED.to_le_bytes().to_vec();
    out.extend_from_slice(&(z.len() as u32).to_le_bytes());
    out.extend_from_slice(&z);
    out
}

fn err_text(r: Result<Vec<MatArray>>) -> String {
    match r {
        Ok(v) => panic!("expected an error, parsed {} variables", v.len()),
        Err(e) => e.to_string(),
    }
}

/// Equality with f64 values compared bit for bit.
fn assert_same(a: &MatArray, b: &MatArray) {
    assert_eq!(
        (&a.name, &a.dims, a.class, a.logical, a.complex),
        (&b.name, &b.dims, b.class, b.logical, b.complex)
    );
    match (&a.data, &b.data) {
        (MatData::F64(x), MatData::F64(y)) => {
            let xb: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
            let yb: Vec<u64> = y.iter().map(|v| v.to_bits()).collect();
            assert_eq!(xb, yb, "variable {}", a.name);
        }
        (x, y) => assert_eq!(x, y, "variable {}", a.name),
    }
}

fn random_values(rng: &mut rand_pcg::Pcg64Mcg, class: MatClass, n: usize) -> Vec<f64> {
    // Integer ranges: the full class range, except 64-bit classes, kept
    // within ±2^53 where f64 holds every integer.
    let (lo, hi): (f64, f64) = match class {
        MatClass::Int8 => (-128.0, 127.0),
        MatClass::Uint8 => (0.0, 255.0),
        MatClass::Int16 => (-32768.0, 32767.0),
        MatClass::Uint16 => (0.0, 65535.0),
        MatClass::Int32 => (-2147483648.0, 2147483647.0),
        MatClass::Uint32 => (0.0, 4294967295.0),
        MatClass::Int64 => (-9007199254740992.0, 9007199254740992.0),
        MatClass::Uint64 => (0.0, 9007199254740992.0),
        _ => (0.0, 0.0),
    };
    (0..n)
        .map(|k| match class {
            MatClass::Double => match k % 7 {
                0 => f64::INFINITY,
                1 => -0.0,
                _ => rng.random_range(-1e6..1e6) * 10f64.powi(rng.random_range(-30..30)),
            },
            MatClass::Single => f64::from(rng.random_range(-1e3f32..1e3)),
            _ => {
                // Hit the extremes now and then.
                match k % 5 {
                    0 => lo,
                    1 => hi,
                    _ => rng.random_range(lo..=hi).round(),
                }
            }
        })
        .collect()
}

fn random_arrays(seed: u64) -> Vec<MatArray> {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let mut arrays = Vec::new();
    let names = ["a", "abcd", "abcde", "a_long_variable_name_12"];
    for (ci, &class) in NUMERIC.iter().enumerate() {
        for rank in 2..=4 {
            let dims: Vec<usize> = (0..rank).map(|_| rng.random_range(1..5)).collect();
            let n = dims.iter().product();
            let name = format!("{}{ci}{rank}", names[(ci + rank) % names.len()]);
            let data = if class == MatClass::Uint8 && rank == 3 {
                // uint8 given as f64 values: read back as bytes below.
                MatData::F64(random_values(&mut rng, class, n))
            } else if class == MatClass::Uint8 {
                MatData::U8((0..n).map(|_| rng.random()).collect())
            } else {
                MatData::F64(random_values(&mut rng, class, n))
            };
            arrays.push(MatArray {
                name,
                dims,
                class,
                logical: false,
                complex: false,
                data,
            });
        }
    }
    for rank in 2..=4 {
        let dims: Vec<usize> = (0..rank).map(|_| rng.random_range(1..6)).collect();
        let n = dims.iter().product();
        let data = (0..n).map(|_| u8::from(rng.random_bool(0.3))).collect();
        arrays.push(MatArray::logical(format!("mask{rank}"), dims, data));
    }
    // Empty arrays and short names (small data element format).
    arrays.push(MatArray::from_f64("e", vec![0, 3], vec![]));
    arrays.push(MatArray::logical("L", vec![2, 0, 1], vec![]));
    arrays
}

#[test]
fn round_trip_every_class_rank_and_compression() {
    let arrays = random_arrays(7);
    for compress in [false, true] {
        let mut bytes = Vec::new();
        write_mat(&mut bytes, &arrays, compress).unwrap();
        let back = parse_mat("t.mat", &bytes).unwrap();
        assert_eq!(back.len(), arrays.len());
        for (a, b) in arrays.iter().zip(&back) {
            let mut want = a.clone();
            if let (MatClass::Uint8, MatData::F64(v)) = (a.class, &a.data) {
                want.data = MatData::U8(v.iter().map(|&x| x as u8).collect());
            }
            assert_same(&want, b);
        }
        if !compress {
            // Uncompressed: every element starts 8-aligned.
            assert_eq!(bytes.len() % 8, 0);
        }
    }
}

#[test]
fn get_and_to_f64_are_column_major() {
    // 2×3×2 array whose value is 100·i + 10·j + k at (i, j, k).
    let mut data = Vec::new();
    for k in 0..2 {
        for j in 0..3 {
            for i in 0..2 {
                data.push(f64::from(100 * i + 10 * j + k));
            }
        }
    }
    let a = MatArray::from_f64("x", vec![2, 3, 2], data.clone());
    assert_eq!(a.get(&[1, 2, 1]), 121.0);
    assert_eq!(a.get(&[0, 1, 0]), 10.0);
    assert_eq!(a.linear_index(&[1, 2, 1]), Some(11));
    assert_eq!(a.linear_index(&[2, 0, 0]), None);
    assert_eq!(a.linear_index(&[0, 0]), None);
    assert_eq!(a.to_f64(), data);
    let m = MatArray::logical("m", vec![2, 2], vec![0, 1, 0, 1]);
    assert_eq!(m.get(&[1, 1]), 1.0);
    assert_eq!(m.get(&[0, 1]), 0.0);
}

#[test]
fn big_endian_file() {
    let be = true;
    let bb: Vec<u8> = [-1.5f64, 2.0, 3.25, 1e300, -0.0, 7.0]
        .iter()
        .flat_map(|v| v.to_be_bytes())
        .collect();
    let i16s: Vec<u8> = [-2i16, 300].iter().flat_map(|v| v.to_be_bytes()).collect();
    let f = file(
        be,
        &[
            matrix(
                be,
                &[
                    flags(be, 6, 0),
                    dims(be, &[2, 3]),
                    small(be, MI_INT8, b"BB"),
                    element(be, MI_DOUBLE, &bb),
                ],
            ),
            matrix(
                be,
                &[
                    flags(be, 10, 0),
                    dims(be, &[2, 1]),
                    element(be, MI_INT8, b"counts"),
                    element(be, MI_INT16, &i16s),
                ],
            ),
            matrix(
                be,
                &[
                    flags(be, 9, FLAG_LOGICAL),
                    dims(be, &[1, 3]),
                    small(be, MI_INT8, b"m"),
                    small(be, MI_UINT8, &[1, 0, 1]),
                ],
            ),
        ],
    );
    let v = parse_mat("be.mat", &f).unwrap();
    assert_eq!(v.len(), 3);
    assert_eq!(v[0].name, "BB");
    assert_eq!(v[0].dims, [2, 3]);
    assert_eq!(v[0].class, MatClass::Double);
    assert_eq!(v[0].to_f64(), [-1.5, 2.0, 3.25, 1e300, -0.0, 7.0]);
    assert_eq!(v[0].get(&[1, 1]), 1e300);
    assert_eq!(v[1].name, "counts");
    assert_eq!(v[1].class, MatClass::Int16);
    assert_eq!(v[1].data, MatData::F64(vec![-2.0, 300.0]));
    assert_eq!(v[2].name, "m");
    assert!(v[2].logical);
    assert_eq!(v[2].data, MatData::U8(vec![1, 0, 1]));
}

/// What MATLAB writes: a double array whose values fit in uint8 stored as
/// miUINT8 in the small data element format, a 1×1 double stored as
/// miINT16, and a logical array as miUINT8.
#[test]
fn small_elements_and_narrow_storage() {
    let le = false;
    let f = file(
        le,
        &[
            matrix(
                le,
                &[
                    flags(le, 6, 0),
                    dims(le, &[1, 3]),
                    small(le, MI_INT8, b"x"),
                    small(le, MI_UINT8, &[1, 2, 250]),
                ],
            ),
            matrix(
                le,
                &[
                    flags(le, 6, 0),
                    dims(le, &[1, 1]),
                    small(le, MI_INT8, b"Res"),
                    small(le, MI_INT16, &(-7i16).to_le_bytes()),
                ],
            ),
            matrix(
                le,
                &[
                    flags(le, 9, FLAG_LOGICAL),
                    dims(le, &[2, 2]),
                    small(le, MI_INT8, b"mask"),
                    small(le, MI_UINT8, &[1, 0, 0, 1]),
                ],
            ),
            // A uint8 array stored as miINT16 is still read as bytes.
            matrix(
                le,
                &[
                    flags(le, 9, 0),
                    dims(le, &[1, 2]),
                    small(le, MI_INT8, b"u"),
                    small(le, MI_INT16, &[7, 0, 255, 0]),
                ],
            ),
        ],
    );
    let v = parse_mat("small.mat", &f).unwrap();
    assert_eq!(v.len(), 4);
    assert_eq!(v[0].class, MatClass::Double);
    assert_eq!(v[0].data, MatData::F64(vec![1.0, 2.0, 250.0]));
    assert_eq!(find(&v, "Res").unwrap().to_f64(), [-7.0]);
    let m = find(&v, "mask").unwrap();
    assert!(m.logical);
    assert_eq!(m.class, MatClass::Uint8);
    assert_eq!(m.data, MatData::U8(vec![1, 0, 0, 1]));
    assert_eq!(find(&v, "u").unwrap().data, MatData::U8(vec![7, 255]));

    // The same element compressed.
    let mut fz = header(le);
    fz.extend(compressed(&matrix(
        le,
        &[
            flags(le, 6, 0),
            dims(le, &[1, 3]),
            small(le, MI_INT8, b"x"),
            small(le, MI_UINT8, &[1, 2, 250]),
        ],
    )));
    let vz = parse_mat("smallz.mat", &fz).unwrap();
    assert_same(&vz[0], &v[0]);
}

#[test]
fn skipped_variables_are_named_in_errors() {
    let le = false;
    let f = file(
        le,
        &[
            // A 1×1 struct with one field `a` = 1.0 (not decoded).
            matrix(
                le,
                &[
                    flags(le, 2, 0),
                    dims(le, &[1, 1]),
                    small(le, MI_INT8, b"s"),
                    small(le, MI_INT32, &32i32.to_le_bytes()),
                    element(le, MI_INT8, &[&b"a"[..], &[0; 31]].concat()),
                    matrix(
                        le,
                        &[
                            flags(le, 6, 0),
                            dims(le, &[1, 1]),
                            element(le, MI_INT8, b""),
                            element(le, MI_DOUBLE, &1.0f64.to_le_bytes()),
                        ],
                    ),
                ],
            ),
            // A char array.
            matrix(
                le,
                &[
                    flags(le, 4, 0),
                    dims(le, &[1, 2]),
                    small(le, MI_INT8, b"c"),
                    small(le, 17, b"h\0i\0"),
                ],
            ),
            // A complex double.
            matrix(
                le,
                &[
                    flags(le, 6, FLAG_COMPLEX),
                    dims(le, &[1, 1]),
                    small(le, MI_INT8, b"z"),
                    element(le, MI_DOUBLE, &1.0f64.to_le_bytes()),
                    element(le, MI_DOUBLE, &2.0f64.to_le_bytes()),
                ],
            ),
            // An empty miMATRIX (an empty cell slot) yields no variable.
            element(le, MI_MATRIX, &[]),
        ],
    );
    let v = parse_mat("s.mat", &f).unwrap();
    assert_eq!(v.len(), 3);
    assert!(v.iter().all(|a| a.data == MatData::Skipped));
    let e = require_numeric(&v, "s", "s.mat").unwrap_err().to_string();
    assert_eq!(
        e,
        "s.mat: variable 's' is a 1×1 struct, expected a numeric array"
    );
    let e = require_numeric(&v, "c", "s.mat").unwrap_err().to_string();
    assert!(e.contains("'c' is a 1×2 char"), "{e}");
    let e = require_numeric(&v, "z", "s.mat").unwrap_err().to_string();
    assert!(e.contains("'z' is a 1×1 complex double array"), "{e}");
    let e = require_numeric(&v, "P", "s.mat").unwrap_err().to_string();
    assert_eq!(
        e,
        "s.mat: no variable 'P' in this MAT-file (it has 's', 'c', 'z')"
    );
}

/// Two variables, uncompressed or compressed, and the file offsets where
/// a truncated copy is still a whole file (header end, first element end).
fn two_variable_file(compress: bool) -> (Vec<u8>, Vec<usize>) {
    let arrays = [
        MatArray::from_f64("BB", vec![2, 3], vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.5]),
        MatArray::logical("ObsMask", vec![2, 2, 2], vec![1, 0, 0, 1, 1, 1, 0, 0]),
    ];
    let mut bytes = Vec::new();
    write_mat(&mut bytes, &arrays, compress).unwrap();
    let mut first = Vec::new();
    write_mat(&mut first, &arrays[..1], compress).unwrap();
    (bytes, vec![128, first.len()])
}

#[test]
fn every_truncation_is_an_error_or_a_whole_prefix() {
    for compress in [false, true] {
        let (bytes, whole) = two_variable_file(compress);
        assert_eq!(parse_mat("t.mat", &bytes).unwrap().len(), 2);
        for n in 0..bytes.len() {
            match parse_mat("t.mat", &bytes[..n]) {
                Ok(v) => {
                    let k = whole.iter().position(|&w| w == n);
                    assert_eq!(k, Some(v.len()), "truncation at {n} parsed as {v:?}");
                }
                Err(e) => {
                    assert!(!whole.contains(&n), "truncation at {n}: {e}");
                    assert!(e.to_string().starts_with("t.mat: "), "{e}");
                }
            }
        }
    }
}

#[test]
fn truncated_zlib_streams_are_errors() {
    let el = matrix(
        false,
        &[
            flags(false, 6, 0),
            dims(false, &[3, 1]),
            small(false, MI_INT8, b"P"),
            element(false, MI_DOUBLE, &[7u8; 24]),
        ],
    );
    let z = compressed(&el);
    let payload = &z[8..];
    for k in 0..payload.len() {
        // The outer tag agrees with the truncated payload, so only the
        // inflater can notice.
        let mut f = header(false);
        f.extend_from_slice(&MI_COMPRESSED.to_le_bytes());
        f.extend_from_slice(&(k as u32).to_le_bytes());
        f.extend_from_slice(&payload[..k]);
        let e = err_text(parse_mat("z.mat", &f));
        assert!(
            e.starts_with("z.mat: byte 128: compressed element"),
            "{k}: {e}"
        );
    }
}

#[test]
fn corrupted_bytes_never_panic() {
    for compress in [false, true] {
        let (bytes, _) = two_variable_file(compress);
        for i in 0..bytes.len() {
            for v in [0x00, 0xff, bytes[i] ^ 0x01, bytes[i] ^ 0x80] {
                let mut b = bytes.clone();
                b[i] = v;
                if let Err(e) = parse_mat("c.mat", &b) {
                    assert!(e.to_string().starts_with("c.mat: "), "{e}");
                }
            }
        }
    }
}

#[test]
fn corrupted_tags_give_located_errors() {
    let (bytes, _) = two_variable_file(false);
    // Top-level element type.
    let mut b = bytes.clone();
    b[128..132].copy_from_slice(&99u32.to_le_bytes());
    let e = err_text(parse_mat("c.mat", &b));
    assert!(e.contains("byte 128: data element of type 99"), "{e}");
    // Top-level byte count beyond the file.
    let mut b = bytes.clone();
    b[132..136].copy_from_slice(&0xffff_fff0u32.to_le_bytes());
    let e = err_text(parse_mat("c.mat", &b));
    assert!(e.contains("declares 4294967280 bytes but only"), "{e}");
    // Array flags with the wrong type.
    let mut b = bytes.clone();
    b[136..140].copy_from_slice(&MI_DOUBLE.to_le_bytes());
    let e = err_text(parse_mat("c.mat", &b));
    assert!(e.contains("byte 136: array flags"), "{e}");
    // Small data element claiming 5 bytes (the name "BB" is small).
    let name_at = 136 + 16 + 16;
    let mut b = bytes.clone();
    b[name_at..name_at + 4].copy_from_slice(&((5u32 << 16) | MI_INT8).to_le_bytes());
    let e = err_text(parse_mat("c.mat", &b));
    assert!(
        e.contains(&format!("byte {name_at}: small data element")),
        "{e}"
    );
    // Real part with a non-numeric type names the variable.
    let real_at = name_at + 8;
    let mut b = bytes.clone();
    b[real_at..real_at + 4].copy_from_slice(&MI_MATRIX.to_le_bytes());
    let e = err_text(parse_mat("c.mat", &b));
    assert!(
        e.contains(&format!(
            "byte {real_at}: variable 'BB': real part stored as type 14"
        )),
        "{e}"
    );
    // Negative dimension.
    let mut b = bytes.clone();
    b[160..164].copy_from_slice(&(-2i32).to_le_bytes());
    let e = err_text(parse_mat("c.mat", &b));
    assert!(
        e.contains("byte 160: variable 'BB': negative dimension -2"),
        "{e}"
    );
}

#[test]
fn absurd_dimensions_are_refused_without_allocating() {
    let le = false;
    let one = element(le, MI_DOUBLE, &1.0f64.to_le_bytes());
    let f = file(
        le,
        &[matrix(
            le,
            &[
                flags(le, 6, 0),
                dims(le, &[1_000_000, 1_000_000]),
                small(le, MI_INT8, b"big"),
                one.clone(),
            ],
        )],
    );
    let e = err_text(parse_mat("d.mat", &f));
    assert!(
        e.contains("variable 'big': dimensions 1000000×1000000 declare 1000000000000 values"),
        "{e}"
    );
    let f = file(
        le,
        &[matrix(
            le,
            &[
                flags(le, 6, 0),
                dims(le, &[i32::MAX, i32::MAX, i32::MAX, i32::MAX]),
                small(le, MI_INT8, b"big"),
                one,
            ],
        )],
    );
    let e = err_text(parse_mat("d.mat", &f));
    assert!(e.contains("overflow"), "{e}");
    // A compressed element whose inner tag declares ~4 GiB but whose
    // stream holds 16 bytes: refused after inflating what is there.
    let mut inner = MI_MATRIX.to_le_bytes().to_vec();
    inner.extend_from_slice(&0xffff_fff0u32.to_le_bytes());
    inner.extend_from_slice(&[0; 16]);
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    z.write_all(&inner).unwrap();
    let z = z.finish().unwrap();
    let mut f = header(le);
    f.extend_from_slice(&MI_COMPRESSED.to_le_bytes());
    f.extend_from_slice(&(z.len() as u32).to_le_bytes());
    f.extend_from_slice(&z);
    let e = err_text(parse_mat("d.mat", &f));
    assert!(
        e.contains("zlib stream ends after 24 inflated bytes, its element declares 4294967288"),
        "{e}"
    );
}

#[test]
fn header_errors() {
    let e = err_text(parse_mat("h.mat", b"MATLAB"));
    assert!(e.contains("shorter than the 128-byte"), "{e}");
    let mut h = header(false);
    h[126..128].copy_from_slice(b"XX");
    let e = err_text(parse_mat("h.mat", &h));
    assert!(e.contains("byte 126: endian indicator"), "{e}");
    let mut h = header(false);
    h[124..126].copy_from_slice(&0x0200u16.to_le_bytes());
    let e = err_text(parse_mat("h.mat", &h));
    assert!(e.contains("v7.3 HDF5"), "{e}");
    // A bare header is a valid, empty file.
    assert!(parse_mat("h.mat", &header(true)).unwrap().is_empty());
}

#[test]
fn writer_refuses_what_it_cannot_store() {
    let cases = [
        (
            MatArray {
                class: MatClass::Uint8,
                ..MatArray::from_f64("u", vec![1, 2], vec![1.0, 256.0])
            },
            "value 1 (256) is not representable as uint8",
        ),
        (
            MatArray {
                class: MatClass::Int32,
                ..MatArray::from_f64("i", vec![1, 1], vec![1.5])
            },
            "not representable as int32",
        ),
        (
            MatArray {
                class: MatClass::Single,
                ..MatArray::from_f64("f", vec![1, 1], vec![0.1])
            },
            "not representable as single",
        ),
        (
            MatArray {
                class: MatClass::Int64,
                ..MatArray::from_f64("j", vec![1, 1], vec![9223372036854775808.0])
            },
            "not representable as int64",
        ),
        (
            MatArray::from_f64("x", vec![2, 2], vec![1.0; 3]),
            "need 4 values, the data hold 3",
        ),
        (MatArray::from_f64("x", vec![3], vec![1.0; 3]), "at least 2"),
        (
            MatArray::from_f64("1x", vec![1, 1], vec![1.0]),
            "not a MATLAB identifier",
        ),
        (
            MatArray {
                logical: true,
                ..MatArray::from_f64("x", vec![1, 1], vec![1.0])
            },
            "logical flag needs class uint8",
        ),
    ];
    for (a, want) in cases {
        let e = write_mat(&mut Vec::new(), &[a], false)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{e} (wanted {want})");
    }
    // Extremes that are representable are accepted.
    let ok = MatArray {
        class: MatClass::Int64,
        ..MatArray::from_f64("j", vec![1, 2], vec![-9223372036854775808.0, 0.0])
    };
    let mut bytes = Vec::new();
    write_mat(&mut bytes, std::slice::from_ref(&ok), false).unwrap();
    assert_same(&parse_mat("j.mat", &bytes).unwrap()[0], &ok);
}
