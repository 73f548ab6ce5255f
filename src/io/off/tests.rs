use crate::Result;
use crate::model::Mesh;

use super::*;

fn parse(s: &str) -> Result<Mesh> {
    parse_off("t.off", s.as_bytes())
}

fn write_string(mesh: &Mesh, opts: &OffWriteOptions) -> String {
    let mut out = Vec::new();
    write_off(&mut out, mesh, opts).unwrap();
    String::from_utf8(out).unwrap()
}

#[test]
fn python_repr_matches_cpython() {
    // Expected strings printed by CPython 3.11 `repr(float)`; the f32
    // cases by `repr(struct.unpack('f', struct.pack('f', x))[0])`.
    let cases: &[(f64, &str)] = &[
        (0.1f32 as f64, "0.10000000149011612"),
        (0.2f32 as f64, "0.20000000298023224"),
        (0.3f32 as f64, "0.30000001192092896"),
        (1e-5, "1e-05"),
        (1e-5f32 as f64, "9.999999747378752e-06"),
        (1e16f32 as f64, "1.0000000272564224e+16"),
        (1e15f32 as f64, "999999986991104.0"),
        (9.5e15f32 as f64, "9499999507316736.0"),
        (1.2e16f32 as f64, "1.2000000112328704e+16"),
        (1e-4f32 as f64, "9.999999747378752e-05"),
        (7e-4f32 as f64, "0.000699999975040555"),
        (12345.678f32 as f64, "12345.677734375"),
        // Exactly halfway between two 16-digit strings that both round-trip:
        // Python takes the even one, Rust's shortest `{:e}` the other.
        // (the value is exactly 966.76934814453125).
        (f64::from_bits(4651715008936280064), "966.7693481445312"),
        (5e-324, "5e-324"),
        (123456789012345678.0, "1.2345678901234568e+17"),
        (1.0, "1.0"),
        (3.0, "3.0"),
        (100.0, "100.0"),
        (65504.0, "65504.0"),
        (-1.25, "-1.25"),
        (0.0001, "0.0001"),
        (-2.5e-7, "-2.5e-07"),
        (-2.5e-7f32 as f64, "-2.499999993688107e-07"),
        (1e16, "1e+16"),
        (0.0, "0.0"),
        (-0.0, "-0.0"),
        (f32::MAX as f64, "3.4028234663852886e+38"),
        (f32::from_bits(1) as f64, "1.401298464324817e-45"),
        (f64::INFINITY, "inf"),
        (f64::NEG_INFINITY, "-inf"),
        (f64::NAN, "nan"),
    ];
    for &(x, want) in cases {
        assert_eq!(python_float_repr(x), want, "repr of {x:e}");
    }
}

#[test]
fn shortest_round_trips() {
    for x in [
        0.1f32,
        -0.0,
        1e-7,
        f32::MAX,
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        123456.79,
        -1.2345678e-5,
        -9.999999e15,
        9.99e15,
        1e16,
    ] {
        let s = format_f32_shortest(x);
        assert_eq!(s.parse::<f32>().unwrap().to_bits(), x.to_bits(), "{s}");
        // 16 digits plus a sign at most (positional just below 1e16).
        assert!(s.len() <= 17, "{s} is long");
    }
}

#[test]
fn triangle_splatting_golden() {
    // Two independent triangles (V = 6), face colours with alpha values
    // that compatibility mode must replace by 255. The expected text is
    // written from the create_off.py description, not from the writer:
    // `COFF`, `V F 0`, Python repr of the f32 values widened to f64,
    // `3 i j k r g b 255`.
    let mesh = Mesh {
        vertices: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.1, 0.2, 0.3],
            [-2.5, 1e-5, 1e16],
            [100.0, -0.0, 7e-4],
        ],
        faces: vec![[0, 1, 2], [3, 4, 5]],
        face_colors: Some(vec![[255, 0, 0, 10], [12, 34, 56, 200]]),
        ..Default::default()
    };
    let golden = "COFF\n\
                      6 2 0\n\
                      0.0 0.0 0.0\n\
                      1.0 0.0 0.0\n\
                      0.0 1.0 0.0\n\
                      0.10000000149011612 0.20000000298023224 0.30000001192092896\n\
                      -2.5 9.999999747378752e-06 1.0000000272564224e+16\n\
                      100.0 -0.0 0.000699999975040555\n\
                      3 0 1 2 255 0 0 255\n\
                      3 3 4 5 12 34 56 255\n";
    let opts = OffWriteOptions::triangle_splatting();
    assert_eq!(write_string(&mesh, &opts), golden);
    // And it reads back to the same mesh (alpha 255 as written).
    let back = parse(golden).unwrap();
    assert_eq!(back.vertices.len(), 6);
    for (a, b) in back.vertices.iter().zip(&mesh.vertices) {
        for k in 0..3 {
            assert_eq!(a[k].to_bits(), b[k].to_bits());
        }
    }
    assert_eq!(back.faces, mesh.faces);
    assert_eq!(
        back.face_colors,
        Some(vec![[255, 0, 0, 255], [12, 34, 56, 255]])
    );
    assert_eq!(back.vertex_colors, None);
    // With face_alpha the alpha is kept.
    let with_alpha = write_string(
        &mesh,
        &OffWriteOptions {
            face_alpha: true,
            ..opts
        },
    );
    assert!(with_alpha.ends_with("3 0 1 2 255 0 0 10\n3 3 4 5 12 34 56 200\n"));
}

#[test]
fn tricky_input() {
    let text = "# a comment before the header\r\n\
                    \r\n\
                    COFF # trailing comment\r\n\
                    5\r\n\
                    3 12\r\n\
                    0 0 0   255 0 0\r\n\
                    1 0 0 0.5 0.5 1.0 0.25\r\n\
                    # comment between vertices\r\n\
                    1 1\r\n\
                    0\r\n\
                    0 1 0\r\n\
                    2 2 2 1 2 3 4\r\n\
                    4 0 1 2 3 10 20 30\r\n\
                    3 0 1 4 0.0 1.0 0.5 0.5\r\n\
                    3 2 3 4\r\n";
    let m = parse(text).unwrap();
    assert_eq!(m.vertices.len(), 5);
    assert_eq!(m.vertices[2], [1.0, 1.0, 0.0]);
    // Quad fan-triangulated, then a triangle, then an uncoloured one.
    assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3], [0, 1, 4], [2, 3, 4]]);
    assert_eq!(
        m.face_colors,
        Some(vec![
            [10, 20, 30, 255],
            [10, 20, 30, 255],
            // Float colours scale by 255 and round: 0.5 -> 127.5 -> 128.
            [0, 255, 128, 128],
            [255, 255, 255, 255],
        ])
    );
    assert_eq!(
        m.vertex_colors,
        Some(vec![
            [255, 0, 0, 255],
            [128, 128, 255, 64],
            [255, 255, 255, 255],
            [255, 255, 255, 255],
            [1, 2, 3, 4],
        ])
    );
}

#[test]
fn headerless_noff_and_counts_on_keyword_line() {
    let m = parse("3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
    assert_eq!(m.faces, vec![[0, 1, 2]]);
    let m = parse("NOFF 3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 2 1 0\n").unwrap();
    assert_eq!(m.normals, Some(vec![[0.0, 0.0, 1.0]; 3]));
    assert_eq!(m.faces, vec![[2, 1, 0]]);
    let m = parse("CNOFF\n1 0 0\n1 2 3 0 0 1 9 8 7 6\n").unwrap();
    assert_eq!(m.vertex_colors, Some(vec![[9, 8, 7, 6]]));
}

fn assert_err(text: &str, needles: &[&str]) {
    let e = parse(text).unwrap_err().to_string();
    assert!(e.starts_with("t.off: "), "{e}");
    for n in needles {
        assert!(e.contains(n), "'{e}' lacks '{n}'");
    }
}

#[test]
fn malformed_inputs() {
    assert_err("", &["empty file"]);
    assert_err("PLY\n", &["line 1", "header keyword"]);
    assert_err("4OFF\n", &["line 1", "header keyword"]);
    assert_err(
        "OFF\n1000000000000 1000000000000 0\n0 0 0\n",
        &["line 2", "declares 1000000000000 vertices"],
    );
    assert_err(
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        &["line 6", "face 0 of 1", "index 3 is out of range"],
    );
    assert_err(
        "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n",
        &["line 4", "vertex 1 of 3", "found 'x'"],
    );
    assert_err(
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n",
        &["line 6", "non-negative integer"],
    );
    assert_err(
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 300 0 0\n",
        &["line 6", "outside 0..=255"],
    );
    assert_err(
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1 1\n",
        &["line 6", "found 2"],
    );
    assert_err(
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n",
        &["line 6", "does not fit"],
    );
}

#[test]
fn truncation_at_every_byte_is_an_error() {
    let text =
        "COFF\n4 2 0\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0\n1.5 -2 3e2\n3 0 1 2 1 2 3\n3 1 2 3\n";
    parse(text).unwrap();
    // Cutting inside the data must never panic and must fail, except at
    // cuts that leave a complete file (the final newline, or a last face
    // line cut after a complete index list).
    for cut in 0..text.len() {
        let head = &text[..cut];
        match parse(head) {
            Ok(m) => {
                assert!(
                    head.starts_with(&text[..text.len() - 2]),
                    "cut {cut} parsed"
                );
                assert_eq!(m.faces.len(), 2);
            }
            Err(e) => {
                let s = e.to_string();
                assert!(s.starts_with("t.off: "), "{s}");
                assert!(s.contains("line") || s.contains("empty file"), "{s}");
            }
        }
    }
}

#[test]
fn writer_checks_its_inputs() {
    let mut m = Mesh::new(vec![[0.0; 3]; 3], vec![[0, 1, 3]]);
    let mut out = Vec::new();
    assert!(write_off(&mut out, &m, &OffWriteOptions::default()).is_err());
    m.faces[0][2] = 2;
    let opts = OffWriteOptions {
        vertex_colors: true,
        ..Default::default()
    };
    assert!(write_off(&mut out, &m, &opts).is_err());
    assert!(write_off(&mut out, &m, &OffWriteOptions::triangle_splatting()).is_err());
}

#[test]
fn non_finite_coordinates_are_written_as_is() {
    let m = Mesh::new(vec![[f32::INFINITY, f32::NEG_INFINITY, f32::NAN]], vec![]);
    let s = write_string(&m, &OffWriteOptions::default());
    assert_eq!(s, "OFF\n1 0 0\ninf -inf NaN\n");
    let back = parse(&s).unwrap();
    assert!(back.vertices[0][2].is_nan() && back.vertices[0][0] == f32::INFINITY);
    let s = write_string(
        &m,
        &OffWriteOptions {
            float_style: FloatStyle::PythonRepr,
            ..Default::default()
        },
    );
    assert_eq!(s, "OFF\n1 0 0\ninf -inf nan\n");
}
