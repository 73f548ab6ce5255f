//! Property-based round trips of random meshes through every mesh writer and
//! reader (OBJ, OFF in both float styles, Triangle Splatting COFF, GLB, glTF).
//! Text formats must give back the same f32 bits (NaN: any NaN), binary
//! formats the same bits; faces and u8 colours exactly.

use proptest::prelude::*;
use splatkit::io::gltf::{GltfContainer, GltfWriteOptions, parse_gltf, write_gltf};
use splatkit::io::obj::{ObjWriteOptions, parse_obj, write_obj};
use splatkit::io::off::{FloatStyle, OffWriteOptions, parse_off, write_off};
use splatkit::model::Mesh;

/// Coordinates across magnitudes: any finite f32 bit pattern (normal,
/// subnormal, zeros of both signs), moderate values, and a few specials.
fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => prop::num::f32::NORMAL | prop::num::f32::SUBNORMAL | prop::num::f32::ZERO,
        4 => -1000.0f32..1000.0,
        1 => prop::sample::select(vec![
            0.1f32, -0.0, 1e-5, 1e16, f32::MAX, f32::MIN, f32::MIN_POSITIVE, 1.0, -2.5e-7,
        ]),
    ]
}

fn mesh_strategy(non_finite: bool) -> impl Strategy<Value = Mesh> {
    let c = if non_finite {
        prop_oneof![
            9 => coord(),
            1 => prop::sample::select(vec![f32::INFINITY, f32::NEG_INFINITY, f32::NAN]),
        ]
        .boxed()
    } else {
        coord().boxed()
    };
    (0usize..30)
        .prop_flat_map(move |nv| {
            let verts = prop::collection::vec([c.clone(), c.clone(), c.clone()], nv);
            let max_faces = if nv == 0 { 0 } else { 40 };
            let nv32 = nv.max(1) as u32;
            let faces = prop::collection::vec([0..nv32, 0..nv32, 0..nv32], 0..=max_faces);
            (Just(nv), verts, faces)
        })
        .prop_flat_map(|(nv, vertices, faces)| {
            let nf = faces.len();
            let normals = prop::option::of(prop::collection::vec(
                [-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0],
                nv,
            ));
            let vcol = prop::option::of(prop::collection::vec(any::<[u8; 4]>(), nv));
            let fcol = prop::option::of(prop::collection::vec(any::<[u8; 4]>(), nf));
            (Just(vertices), Just(faces), normals, vcol, fcol)
        })
        .prop_map(
            |(vertices, faces, normals, vertex_colors, face_colors)| Mesh {
                // Empty attribute lists cannot be told from absent ones in files.
                vertices,
                faces,
                normals: normals.filter(|v| !v.is_empty()),
                vertex_colors: vertex_colors.filter(|v| !v.is_empty()),
                face_colors: face_colors.filter(|v| !v.is_empty()),
                ..Default::default()
            },
        )
}

/// Same value: identical bits, or both NaN (text formats print one NaN).
fn same(a: &[[f32; 3]], b: &[[f32; 3]]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(p, q)| {
            p.iter()
                .zip(q)
                .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
        })
}

fn bits(a: &[[f32; 3]]) -> Vec<[u32; 3]> {
    a.iter().map(|p| p.map(f32::to_bits)).collect()
}

fn off_round_trip(mesh: &Mesh, style: FloatStyle) -> Mesh {
    let opts = OffWriteOptions {
        float_style: style,
        ..OffWriteOptions::for_mesh(mesh)
    };
    let mut out = Vec::new();
    write_off(&mut out, mesh, &opts).unwrap();
    parse_off("rt.off", &out).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn off_round_trip_is_exact(mesh in mesh_strategy(true)) {
        for style in [FloatStyle::Shortest, FloatStyle::PythonRepr] {
            let back = off_round_trip(&mesh, style);
            prop_assert!(same(&back.vertices, &mesh.vertices), "{:?}", style);
            prop_assert_eq!(&back.faces, &mesh.faces);
            prop_assert_eq!(&back.vertex_colors, &mesh.vertex_colors);
            prop_assert_eq!(&back.face_colors, &mesh.face_colors);
            prop_assert_eq!(&back.normals, &None);
        }
    }

    #[test]
    fn triangle_splatting_layout_round_trip(mesh in mesh_strategy(false)) {
        prop_assume!(mesh.face_colors.is_some());
        let mut out = Vec::new();
        write_off(&mut out, &mesh, &OffWriteOptions::triangle_splatting()).unwrap();
        let text = String::from_utf8(out.clone()).unwrap();
        // Every face line is `3 i j k r g b 255` and vertex lines have 3 tokens.
        let mut lines = text.lines();
        prop_assert_eq!(lines.next(), Some("COFF"));
        let nv = mesh.vertices.len();
        let counts = format!("{} {} 0", nv, mesh.faces.len());
        prop_assert_eq!(lines.next(), Some(counts.as_str()));
        for (i, l) in lines.enumerate() {
            let n = l.split(' ').count();
            prop_assert_eq!(n, if i < nv { 3 } else { 8 });
            if i >= nv {
                prop_assert!(l.starts_with("3 ") && l.ends_with(" 255"));
            }
        }
        let back = parse_off("ts.off", &out).unwrap();
        prop_assert_eq!(bits(&back.vertices), bits(&mesh.vertices));
        prop_assert_eq!(&back.faces, &mesh.faces);
        let opaque: Vec<[u8; 4]> = mesh
            .face_colors
            .as_ref()
            .unwrap()
            .iter()
            .map(|c| [c[0], c[1], c[2], 255])
            .collect();
        prop_assert_eq!(back.face_colors, Some(opaque));
        prop_assert_eq!(back.vertex_colors, None);
    }

    #[test]
    fn obj_round_trip_is_exact(mesh in mesh_strategy(true)) {
        let mut out = Vec::new();
        write_obj(&mut out, &mesh, &ObjWriteOptions::default()).unwrap();
        let back = parse_obj("rt.obj", &out).unwrap();
        let opaque = |c: &Vec<[u8; 4]>| -> Vec<[u8; 4]> {
            c.iter().map(|c| [c[0], c[1], c[2], 255]).collect()
        };
        if mesh.vertex_colors.is_none() && mesh.face_colors.is_some() {
            // Un-shared: vertex 3i+k is corner k of face i, coloured by face i.
            let nf = mesh.faces.len();
            prop_assert_eq!(back.vertices.len(), 3 * nf);
            for (i, f) in mesh.faces.iter().enumerate() {
                prop_assert_eq!(back.faces[i], [3 * i as u32, 3 * i as u32 + 1, 3 * i as u32 + 2]);
                for (k, &fk) in f.iter().enumerate() {
                    let v = fk as usize;
                    prop_assert!(same(&[back.vertices[3 * i + k]], &[mesh.vertices[v]]));
                    let fc = mesh.face_colors.as_ref().unwrap()[i];
                    prop_assert_eq!(
                        back.vertex_colors.as_ref().unwrap()[3 * i + k],
                        [fc[0], fc[1], fc[2], 255]
                    );
                    if let Some(n) = &mesh.normals {
                        prop_assert_eq!(back.normals.as_ref().unwrap()[3 * i + k], n[v]);
                    }
                }
            }
        } else {
            prop_assert!(same(&back.vertices, &mesh.vertices));
            prop_assert_eq!(&back.faces, &mesh.faces);
            prop_assert_eq!(&back.normals, &mesh.normals);
            prop_assert_eq!(back.vertex_colors, mesh.vertex_colors.as_ref().map(opaque));
            prop_assert_eq!(back.face_colors, None);
        }
    }

    #[test]
    fn gltf_round_trip_is_exact(mesh in mesh_strategy(true)) {
        for container in [GltfContainer::Glb, GltfContainer::Gltf] {
            let mut out = Vec::new();
            write_gltf(&mut out, &mesh, &GltfWriteOptions {
                container,
                ..Default::default()
            }).unwrap();
            let back = parse_gltf("rt.glb", &out).unwrap();
            if mesh.vertex_colors.is_none() && mesh.face_colors.is_some() {
                let nf = mesh.faces.len();
                prop_assert_eq!(back.vertices.len(), 3 * nf);
                for (i, f) in mesh.faces.iter().enumerate() {
                    prop_assert_eq!(back.faces[i], [3 * i as u32, 3 * i as u32 + 1, 3 * i as u32 + 2]);
                    for (k, &fk) in f.iter().enumerate() {
                        let v = fk as usize;
                        prop_assert_eq!(
                            back.vertices[3 * i + k].map(f32::to_bits),
                            mesh.vertices[v].map(f32::to_bits)
                        );
                        prop_assert_eq!(
                            back.vertex_colors.as_ref().unwrap()[3 * i + k],
                            mesh.face_colors.as_ref().unwrap()[i]
                        );
                    }
                }
            } else {
                // Binary: identical bits, NaN payloads included.
                prop_assert_eq!(bits(&back.vertices), bits(&mesh.vertices));
                prop_assert_eq!(&back.faces, &mesh.faces);
                prop_assert_eq!(
                    back.normals.as_deref().map(bits),
                    mesh.normals.as_deref().map(bits)
                );
                prop_assert_eq!(&back.vertex_colors, &mesh.vertex_colors);
                prop_assert_eq!(back.face_colors, None);
            }
        }
    }

    /// Random byte corruption of valid files: every reader returns a value
    /// or an error naming the file, never panics.
    #[test]
    fn corrupted_files_never_panic(
        mesh in mesh_strategy(false),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
    ) {
        let mut files: Vec<(&str, Vec<u8>)> = Vec::new();
        let mut off = Vec::new();
        write_off(&mut off, &mesh, &OffWriteOptions::for_mesh(&mesh)).unwrap();
        files.push(("c.off", off));
        let mut obj = Vec::new();
        write_obj(&mut obj, &mesh, &ObjWriteOptions::default()).unwrap();
        files.push(("c.obj", obj));
        let mut glb = Vec::new();
        write_gltf(&mut glb, &mesh, &GltfWriteOptions::default()).unwrap();
        files.push(("c.glb", glb));
        for (name, mut bytes) in files {
            for (at, b) in &edits {
                let i = at.index(bytes.len());
                bytes[i] = *b;
            }
            let r = match name {
                "c.off" => parse_off(name, &bytes),
                "c.obj" => parse_obj(name, &bytes),
                _ => parse_gltf(name, &bytes),
            };
            match r {
                Ok(m) => prop_assert!(m.validate().is_ok()),
                Err(e) => prop_assert!(e.to_string().starts_with(name), "{}", e),
            }
        }
    }
}

/// The Stanford Bunny (ASCII PLY in the shared data) rewritten as an OFF
/// text by plain line surgery (vertex lines keep only x y z; face lines are
/// already `3 a b c`), then read by the OFF reader and sent through every
/// writer/reader pair. Counts and bounds come from the data set's SOURCE.md.
#[test]
fn stanford_bunny_through_every_format() {
    let Some(p) = splatkit::testing::shared_data("scanned-meshes/bun_zipper.ply") else {
        return;
    };
    let text = std::fs::read_to_string(p).unwrap();
    let body = text.split_once("end_header\n").unwrap().1;
    let mut lines = body.lines();
    let mut off = String::from("OFF\n35947 69451 0\n");
    for l in lines.by_ref().take(35947) {
        let xyz: Vec<&str> = l.split_whitespace().take(3).collect();
        off.push_str(&xyz.join(" "));
        off.push('\n');
    }
    for l in lines.take(69451) {
        off.push_str(l);
        off.push('\n');
    }
    let mesh = parse_off("bunny.off", off.as_bytes()).unwrap();
    assert_eq!((mesh.vertices.len(), mesh.faces.len()), (35947, 69451));
    let (lo, hi) = mesh.bounds().unwrap();
    // SOURCE.md gives the box to 3 significant digits (±0.00005 m).
    let want_lo = [-0.0947f32, 0.0330, -0.0619];
    let want_hi = [0.0610f32, 0.1873, 0.0588];
    for k in 0..3 {
        assert!((lo[k] - want_lo[k]).abs() < 6e-5, "{lo:?}");
        assert!((hi[k] - want_hi[k]).abs() < 6e-5, "{hi:?}");
    }
    let mut obj = Vec::new();
    write_obj(&mut obj, &mesh, &ObjWriteOptions::default()).unwrap();
    assert_eq!(parse_obj("bunny.obj", &obj).unwrap(), mesh);
    let mut glb = Vec::new();
    write_gltf(&mut glb, &mesh, &GltfWriteOptions::default()).unwrap();
    assert_eq!(parse_gltf("bunny.glb", &glb).unwrap(), mesh);
    let mut ts = Vec::new();
    let coloured = Mesh {
        face_colors: Some(vec![[200, 100, 50, 255]; mesh.faces.len()]),
        ..mesh.clone()
    };
    write_off(&mut ts, &coloured, &OffWriteOptions::triangle_splatting()).unwrap();
    assert_eq!(parse_off("bunny_ts.off", &ts).unwrap(), coloured);
}
