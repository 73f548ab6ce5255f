//! PLY tests: property round trips over every type and format, real files,
//! and a fuzz-style sweep of corrupted inputs.

use super::gaussians::{parse_gaussians, write_gaussians};
use super::mesh::{parse_mesh, write_mesh};
use super::points::{parse_points, write_points};
use super::soup::{parse_soup, write_soup};
use super::*;
use crate::model::{
    Column, Element, Extras, Gaussians, Mesh, PointCloud, ScalarData, ScalarType, TriangleSoup,
};
use crate::testing::shared_data;
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

const FORMATS: [Format; 3] = [
    Format::Ascii,
    Format::BinaryLittleEndian,
    Format::BinaryBigEndian,
];

fn to_bytes(ply: &Ply, f: Format) -> Vec<u8> {
    let mut v = Vec::new();
    write_ply(&mut v, ply, f).unwrap();
    v
}

/// Random column of type `t` with `n` values drawn from the whole bit range
/// (so NaN payloads, infinities, -0.0 and extreme integers all appear).
fn random_scalars(rng: &mut Pcg64Mcg, t: ScalarType, n: usize) -> ScalarData {
    match t {
        ScalarType::I8 => ScalarData::I8((0..n).map(|_| rng.random()).collect()),
        ScalarType::U8 => ScalarData::U8((0..n).map(|_| rng.random()).collect()),
        ScalarType::I16 => ScalarData::I16((0..n).map(|_| rng.random()).collect()),
        ScalarType::U16 => ScalarData::U16((0..n).map(|_| rng.random()).collect()),
        ScalarType::I32 => ScalarData::I32((0..n).map(|_| rng.random()).collect()),
        ScalarType::U32 => ScalarData::U32((0..n).map(|_| rng.random()).collect()),
        ScalarType::F32 => ScalarData::F32((0..n).map(|_| f32::from_bits(rng.random())).collect()),
        ScalarType::F64 => ScalarData::F64((0..n).map(|_| f64::from_bits(rng.random())).collect()),
    }
}

fn random_ply(seed: u64) -> Ply {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let ne = rng.random_range(1..4usize);
    let mut elements = Vec::new();
    for e in 0..ne {
        let count = rng.random_range(0..40usize);
        let mut el = Element::new(format!("el{e}"), count);
        for p in 0..rng.random_range(0..6usize) {
            let t = ScalarType::ALL[rng.random_range(0..8usize)];
            if rng.random_range(0..3u32) == 0 {
                let ct = [
                    ScalarType::U8,
                    ScalarType::I8,
                    ScalarType::U16,
                    ScalarType::I32,
                    ScalarType::U32,
                ][rng.random_range(0..5usize)];
                let mut offsets = vec![0];
                for _ in 0..count {
                    let len = rng.random_range(0..6usize);
                    offsets.push(offsets.last().unwrap() + len);
                }
                let values = random_scalars(&mut rng, t, *offsets.last().unwrap());
                el.push(
                    format!("l{p}"),
                    Column::List {
                        count_type: ct,
                        offsets,
                        values,
                    },
                );
            } else {
                el.push(
                    format!("p{p}"),
                    Column::Scalar(random_scalars(&mut rng, t, count)),
                );
            }
        }
        elements.push(el);
    }
    Ply {
        format: Format::BinaryLittleEndian,
        comments: vec!["made by a test".into(), "second comment".into()],
        obj_info: vec!["info line".into()],
        elements,
    }
}

/// Bit equality, except that ASCII cannot keep NaN payloads/signs: there any
/// NaN matches any NaN.
fn same_scalars(a: &ScalarData, b: &ScalarData, ascii: bool) -> bool {
    match (a, b) {
        (ScalarData::F32(x), ScalarData::F32(y)) => {
            x.len() == y.len()
                && x.iter()
                    .zip(y)
                    .all(|(p, q)| p.to_bits() == q.to_bits() || (ascii && p.is_nan() && q.is_nan()))
        }
        (ScalarData::F64(x), ScalarData::F64(y)) => {
            x.len() == y.len()
                && x.iter()
                    .zip(y)
                    .all(|(p, q)| p.to_bits() == q.to_bits() || (ascii && p.is_nan() && q.is_nan()))
        }
        _ => a == b,
    }
}

fn same_ply(a: &Ply, b: &Ply, ascii: bool) -> bool {
    a.comments == b.comments
        && a.obj_info == b.obj_info
        && a.elements.len() == b.elements.len()
        && a.elements.iter().zip(&b.elements).all(|(x, y)| {
            x.name == y.name
                && x.count == y.count
                && x.properties.len() == y.properties.len()
                && x.properties.iter().zip(&y.properties).all(|(p, q)| {
                    p.name == q.name
                        && match (&p.data, &q.data) {
                            (Column::Scalar(s), Column::Scalar(t)) => same_scalars(s, t, ascii),
                            (
                                Column::List {
                                    count_type: c1,
                                    offsets: o1,
                                    values: v1,
                                },
                                Column::List {
                                    count_type: c2,
                                    offsets: o2,
                                    values: v2,
                                },
                            ) => c1 == c2 && o1 == o2 && same_scalars(v1, v2, ascii),
                            _ => false,
                        }
                })
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// Any PLY (every scalar type, lists with every integer count type,
    /// empty elements) survives write→read in all three formats.
    #[test]
    fn random_ply_round_trips(seed in any::<u64>()) {
        let ply = random_ply(seed);
        for f in FORMATS {
            let bytes = to_bytes(&ply, f);
            let back = parse_ply("t.ply", &bytes).unwrap();
            prop_assert_eq!(back.format, f);
            prop_assert!(same_ply(&ply, &back, f == Format::Ascii), "format {:?}", f);
        }
    }
}

fn random_gaussians(seed: u64, n: usize, degree: usize, normals: bool) -> Gaussians {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut f = || f32::from_bits(rng.random());
    let k3 = ((degree + 1) * (degree + 1) - 1) * 3;
    Gaussians {
        means: (0..n).map(|_| [f(), f(), f()]).collect(),
        normals: normals.then(|| (0..n).map(|_| [f(), f(), f()]).collect()),
        sh_degree: degree,
        sh_dc: (0..n).map(|_| [f(), f(), f()]).collect(),
        sh_rest: (0..n * k3).map(|_| f()).collect(),
        opacity_logits: (0..n).map(|_| f()).collect(),
        log_scales: (0..n).map(|_| [f(), f(), f()]).collect(),
        rotations: (0..n).map(|_| [f(), f(), f(), f()]).collect(),
        extras: Extras::default(),
    }
}

fn bits(g: &Gaussians) -> Vec<u32> {
    let mut v: Vec<u32> = Vec::new();
    let mut add = |x: &[f32]| v.extend(x.iter().map(|f| f.to_bits()));
    add(g.means.as_flattened());
    if let Some(n) = &g.normals {
        add(n.as_flattened());
    }
    add(g.sh_dc.as_flattened());
    add(&g.sh_rest);
    add(&g.opacity_logits);
    add(g.log_scales.as_flattened());
    add(g.rotations.as_flattened());
    v
}

#[test]
fn gaussians_round_trip_bit_identical() {
    for degree in 0..=3 {
        for normals in [false, true] {
            let g = random_gaussians(degree as u64 * 7 + normals as u64, 257, degree, normals);
            for f in [Format::BinaryLittleEndian, Format::BinaryBigEndian] {
                let mut bytes = Vec::new();
                write_gaussians(&mut bytes, &g, f).unwrap();
                let back = parse_gaussians("g.ply", &bytes).unwrap();
                assert_eq!(back.sh_degree, degree);
                assert_eq!(back.normals.is_some(), normals);
                assert_eq!(
                    bits(&back),
                    bits(&g),
                    "degree {degree} normals {normals} {f:?}"
                );
            }
        }
    }
}

#[test]
fn gaussians_layout_is_the_3dgs_one() {
    let g = random_gaussians(1, 3, 3, true);
    let mut bytes = Vec::new();
    write_gaussians(&mut bytes, &g, Format::BinaryLittleEndian).unwrap();
    let h = Header::parse("g", &bytes).unwrap();
    let names: Vec<&str> = h.elements[0]
        .properties
        .iter()
        .map(|p| p.name.as_str())
        .collect();
    assert_eq!(names.len(), 62);
    assert_eq!(
        &names[..9],
        [
            "x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"
        ]
    );
    assert_eq!(names[9], "f_rest_0");
    assert_eq!(names[53], "f_rest_44");
    assert_eq!(
        &names[54..],
        [
            "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"
        ]
    );
    // Channel-major f_rest: f_rest_1 is coefficient 2 (k=1) of red, f_rest_15 is coefficient 1 of green.
    let body = &bytes[h.body_offset..];
    let val = |j: usize| f32::from_le_bytes(body[j * 4..j * 4 + 4].try_into().unwrap()).to_bits();
    assert_eq!(val(9 + 1), g.sh_rest[3].to_bits()); // (k=1, c=0)
    assert_eq!(val(9 + 15), g.sh_rest[1].to_bits()); // (k=0, c=1)
}

#[test]
fn gaussians_any_order_any_type_and_extras_preserved() {
    // Properties shuffled, positions in double, an extra uchar property and
    // an extra element: read by name, extras written back.
    let text = "ply\nformat ascii 1.0\ncomment hello\nelement vertex 2\nproperty float rot_3\nproperty double x\nproperty double y\nproperty double z\nproperty uchar tag\nproperty float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\nproperty float opacity\nproperty float scale_0\nproperty float scale_1\nproperty float scale_2\nproperty float rot_0\nproperty float rot_1\nproperty float rot_2\nelement camera 1\nproperty float fov\nend_header\n\
        4 1 2 3 7 0.1 0.2 0.3 0.5 -1 -2 -3 1 2 3\n\
        8 4 5 6 9 0.4 0.5 0.6 0.7 -4 -5 -6 5 6 7\n\
        0.75\n";
    let g = parse_gaussians("a.ply", text.as_bytes()).unwrap();
    assert_eq!(g.means, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
    assert_eq!(g.rotations[1], [5.0, 6.0, 7.0, 8.0]);
    assert_eq!(g.sh_degree, 0);
    assert_eq!(g.extras.item[0].name, "tag");
    assert_eq!(g.extras.elements[0].name, "camera");
    let mut out = Vec::new();
    write_gaussians(&mut out, &g, Format::BinaryLittleEndian).unwrap();
    let back = parse_gaussians("b.ply", &out).unwrap();
    assert_eq!(back.extras, g.extras);
    assert_eq!(back.means, g.means);
}

#[test]
fn mesh_points_soup_round_trip() {
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    let nv = 50;
    let mut m = Mesh::new(
        (0..nv)
            .map(|_| [rng.random(), rng.random(), rng.random()])
            .collect(),
        (0..80)
            .map(|_| {
                [
                    rng.random_range(0..nv as u32),
                    rng.random_range(0..nv as u32),
                    rng.random_range(0..nv as u32),
                ]
            })
            .collect(),
    );
    m.normals = Some(
        (0..nv)
            .map(|_| [rng.random(), rng.random(), rng.random()])
            .collect(),
    );
    m.vertex_colors = Some(
        (0..nv)
            .map(|_| [rng.random(), rng.random(), rng.random(), 255])
            .collect(),
    );
    m.face_colors = Some(
        (0..80)
            .map(|_| [rng.random(), rng.random(), rng.random(), rng.random()])
            .collect(),
    );
    m.vertex_scalars
        .push(("density".into(), (0..nv).map(|_| rng.random()).collect()));
    for f in FORMATS {
        let mut b = Vec::new();
        write_mesh(&mut b, &m, f).unwrap();
        assert_eq!(parse_mesh("m.ply", &b).unwrap(), m, "{f:?}");
    }
    let pc = PointCloud {
        positions: m.vertices.clone(),
        normals: m.normals.clone(),
        colors: Some(
            (0..nv)
                .map(|_| [rng.random(), rng.random(), rng.random()])
                .collect(),
        ),
        extras: Extras::default(),
    };
    for f in FORMATS {
        let mut b = Vec::new();
        write_points(&mut b, &pc, f).unwrap();
        assert_eq!(parse_points("p.ply", &b).unwrap(), pc, "{f:?}");
    }
    let n = 30;
    let soup = TriangleSoup {
        triangles: (0..n)
            .map(|_| [[rng.random(), rng.random(), rng.random()]; 3])
            .collect(),
        opacity_raw: (0..n).map(|_| rng.random()).collect(),
        sigma_raw: (0..n).map(|_| rng.random()).collect(),
        sh_degree: 3,
        active_sh_degree: 2,
        sh_dc: (0..n)
            .map(|_| [rng.random(), rng.random(), rng.random()])
            .collect(),
        sh_rest: (0..n * 45).map(|_| rng.random()).collect(),
        extras: Extras::default(),
    };
    for f in FORMATS {
        let mut b = Vec::new();
        write_soup(&mut b, &soup, f).unwrap();
        assert_eq!(parse_soup("s.ply", &b).unwrap(), soup, "{f:?}");
    }
}

#[test]
fn polygons_are_fan_triangulated_with_face_properties_repeated() {
    let text = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nproperty int label\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 0\n4 0 1 2 3 7\n3 1 4 2 9\n";
    let m = parse_mesh("q.ply", text.as_bytes()).unwrap();
    assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3], [1, 4, 2]]);
    assert_eq!(
        m.extras.item[0].data,
        Column::Scalar(ScalarData::I32(vec![7, 7, 9]))
    );
}

#[test]
fn bunny_reads_with_its_material_element() {
    let Some(p) = shared_data("scanned-meshes/bun_zipper.ply") else {
        return;
    };
    let m = parse_mesh("bun", &std::fs::read(&p).unwrap()).unwrap();
    assert_eq!(m.vertices.len(), 35_947);
    assert_eq!(m.faces.len(), 69_451);
    // Bounding box from SOURCE.md (metres).
    let (lo, hi) = m.bounds().unwrap();
    assert!(
        (lo[0] + 0.0947).abs() < 1e-4 && (hi[1] - 0.1873).abs() < 1e-4,
        "{lo:?} {hi:?}"
    );
    assert_eq!(m.extras.elements.len(), 1);
    let mat = &m.extras.elements[0];
    assert_eq!(mat.name, "material");
    assert_eq!(mat.properties[0].name, "ambient_red");
    assert_eq!(m.scalar("confidence").map(<[f32]>::len), Some(35_947));
    // Read-modify-write keeps the material element and the extra scalars.
    let mut b = Vec::new();
    write_mesh(&mut b, &m, Format::BinaryLittleEndian).unwrap();
    assert_eq!(parse_mesh("bun2", &b).unwrap(), m);
}

#[test]
fn trailing_bytes_are_ignored_and_counted() {
    let Some(p) = shared_data("3dgs-pc-short/pc_short.ply") else {
        return;
    };
    let bytes = std::fs::read(&p).unwrap();
    let g = parse_gaussians("pc_short", &bytes).unwrap();
    assert_eq!(g.len(), 100);
    assert_eq!(g.sh_degree, 3);
    let (_, trailing) = PlyReader::new("pc_short", &bytes).unwrap().read().unwrap();
    assert_eq!(trailing, 38_829 - 24_800); // SOURCE.md: 14,029 bytes after the 100 rows
}

#[test]
fn real_3dgs_files_of_every_degree_read() {
    for (rel, n, deg, normals) in [
        ("3dgs-kacytran-iter7000/point_cloud.ply", 9080, 3, true),
        ("3dgs-donut-mipsplatting/fused.ply", 45_624, 0, false),
        (
            "3dgs-playcanvas-guitar/guitar.decoded_sh0.ply",
            90_854,
            0,
            true,
        ),
    ] {
        let Some(p) = shared_data(rel) else { return };
        let bytes = std::fs::read(&p).unwrap();
        let g = parse_gaussians(rel, &bytes).unwrap();
        assert_eq!(
            (g.len(), g.sh_degree, g.normals.is_some()),
            (n, deg, normals),
            "{rel}"
        );
        // Rewriting reproduces the file byte for byte (same layout, same header).
        let mut out = Vec::new();
        write_gaussians(&mut out, &g, Format::BinaryLittleEndian).unwrap();
        assert_eq!(out, bytes, "{rel}");
    }
    let Some(p) = shared_data("3dgs-playcanvas-guitar/guitar.compressed.ply") else {
        return;
    };
    // a SuperSplat compressed PLY is decoded (io::splat::compressed_ply)
    let g = parse_gaussians("c.ply", &std::fs::read(&p).unwrap()).unwrap();
    assert_eq!((g.len(), g.sh_degree), (90854, 0));
}

#[test]
fn errors_name_file_element_row_and_offset() {
    let g = random_gaussians(3, 10, 1, true);
    let mut b = Vec::new();
    write_gaussians(&mut b, &g, Format::BinaryLittleEndian).unwrap();
    let cut = &b[..b.len() - 5];
    let e = parse_gaussians("cut.ply", cut).unwrap_err().to_string();
    assert!(
        e.starts_with("cut.ply:") && e.contains("'vertex'") && e.contains("byte offset"),
        "{e}"
    );
    let text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1.5\nabc\n";
    let e = parse_ply("t.ply", text.as_bytes()).unwrap_err().to_string();
    assert!(
        e.contains("row 1") && e.contains("line 7") && e.contains("'abc'"),
        "{e}"
    );
    let huge = "ply\nformat binary_little_endian 1.0\nelement vertex 999999999999\nproperty float x\nend_header\n";
    let e = parse_ply("h.ply", huge.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("999999999999 rows"), "{e}");
    let badtype = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n1\n";
    let e = parse_ply("b.ply", badtype.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 4") && e.contains("float128"), "{e}");
}

/// Fuzz-style sweep: thousands of truncations and corruptions of valid files
/// (headers and bodies, all formats). Each must return `Ok` or `Err`, never
/// panic, and a huge declared count must not allocate (the process would abort).
#[test]
fn corrupted_inputs_never_panic() {
    let mut seeds: Vec<Vec<u8>> = Vec::new();
    for f in FORMATS {
        seeds.push(to_bytes(&random_ply(11), f));
        let mut with_lists = random_ply(4);
        with_lists.elements.retain(|e| {
            e.properties
                .iter()
                .any(|p| matches!(p.data, Column::List { .. }))
        });
        if !with_lists.elements.is_empty() {
            seeds.push(to_bytes(&with_lists, f));
        }
    }
    let mut gb = Vec::new();
    write_gaussians(
        &mut gb,
        &random_gaussians(2, 6, 1, true),
        Format::BinaryLittleEndian,
    )
    .unwrap();
    seeds.push(gb);
    let mut rng = Pcg64Mcg::seed_from_u64(99);
    let mut cases = 0usize;
    let mut errors = 0usize;
    let mut check = |bytes: &[u8]| {
        let r = std::panic::catch_unwind(|| {
            let a = parse_ply("fuzz.ply", bytes).is_err();
            let b = parse_gaussians("fuzz.ply", bytes).is_err();
            let c = parse_mesh("fuzz.ply", bytes).is_err();
            let d = parse_soup("fuzz.ply", bytes).is_err();
            a as usize + b as usize + c as usize + d as usize
        });
        match r {
            Ok(e) => errors += e,
            Err(_) => panic!(
                "panic on input {:?}",
                String::from_utf8_lossy(&bytes[..bytes.len().min(400)])
            ),
        }
        cases += 1;
    };
    for s in &seeds {
        // Every truncation.
        for cut in 0..s.len() {
            check(&s[..cut]);
        }
        // Random byte flips, in the header and in the body.
        for _ in 0..300 {
            let mut c = s.clone();
            for _ in 0..rng.random_range(1..4usize) {
                let i = rng.random_range(0..c.len());
                c[i] = rng.random();
            }
            check(&c);
        }
        // Header counts replaced with absurd values.
        let text = String::from_utf8_lossy(s).to_string();
        for big in ["18446744073709551615", "4294967296", "-1", "1e9"] {
            let mutated = text.replacen("element el0 ", &format!("element el0 {big} x"), 1);
            check(mutated.as_bytes());
        }
    }
    assert!(cases > 3000, "only {cases} cases");
    assert!(
        errors > cases,
        "expected most corrupted inputs to be rejected"
    );
}

/// A non-canonical `f_rest` name (`f_rest_036` for `f_rest_36`, the
/// mutation the reader fuzzer found on 2026-11-26, which panicked) is an
/// error, not a crash: it is another property, which leaves a gap at 36 in
/// the coefficients' numbering.
#[test]
fn non_canonical_f_rest_name_is_an_error() {
    let g = random_gaussians(1, 3, 3, true);
    let mut bytes = Vec::new();
    write_gaussians(&mut bytes, &g, Format::BinaryLittleEndian).unwrap();
    let text_end = bytes.windows(10).position(|w| w == b"end_header").unwrap();
    let head = String::from_utf8(bytes[..text_end].to_vec()).unwrap();
    let head = head.replace("property float f_rest_36\n", "property float f_rest_036\n");
    let mut mutated = head.into_bytes();
    mutated.extend_from_slice(&bytes[text_end..]);
    let e = parse_gaussians("m.ply", &mutated).unwrap_err().to_string();
    assert!(e.contains("not numbered 0..44 without gaps"), "{e}");
}
