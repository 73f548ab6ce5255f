use crate::model::Mesh;

use super::*;

fn write(mesh: &Mesh, container: GltfContainer) -> Vec<u8> {
    let mut out = Vec::new();
    write_gltf(
        &mut out,
        mesh,
        &GltfWriteOptions {
            container,
            ..Default::default()
        },
    )
    .unwrap();
    out
}

fn sample() -> Mesh {
    Mesh {
        vertices: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [-3.5, 1e-30, 7e20],
        ],
        faces: vec![[0, 1, 2], [2, 1, 3]],
        normals: Some(vec![[0.0, 0.0, 1.0]; 4]),
        vertex_colors: Some(vec![
            [1, 2, 3, 4],
            [5, 6, 7, 8],
            [9, 10, 11, 12],
            [0, 255, 0, 128],
        ]),
        ..Default::default()
    }
}

#[test]
fn base64_known_vectors() {
    // RFC 4648 section 10 test vectors.
    let cases = [
        ("", ""),
        ("f", "Zg=="),
        ("fo", "Zm8="),
        ("foo", "Zm9v"),
        ("foob", "Zm9vYg=="),
        ("fooba", "Zm9vYmE="),
        ("foobar", "Zm9vYmFy"),
    ];
    for (plain, enc) in cases {
        assert_eq!(base64_encode(plain.as_bytes()), enc);
        assert_eq!(base64_decode(enc).unwrap(), plain.as_bytes());
    }
    assert_eq!(base64_decode("Zm9v!mFy"), Err(4));
    assert_eq!(base64_decode("Z"), Err(0));
    let all: Vec<u8> = (0..=255).collect();
    assert_eq!(base64_decode(&base64_encode(&all)).unwrap(), all);
}

#[test]
fn glb_and_gltf_round_trip() {
    let m = sample();
    for c in [GltfContainer::Glb, GltfContainer::Gltf] {
        let bytes = write(&m, c);
        let back = parse_gltf("t", &bytes).unwrap();
        assert_eq!(back, m, "{c:?}");
    }
    let glb = write(&m, GltfContainer::Glb);
    assert_eq!(&glb[..4], b"glTF");
    assert_eq!(glb.len() % 4, 0, "GLB chunks are 4-byte aligned");
    assert_eq!(
        u32::from_le_bytes(glb[8..12].try_into().unwrap()) as usize,
        glb.len()
    );
    let text = String::from_utf8(write(&m, GltfContainer::Gltf)).unwrap();
    assert!(text.contains("data:application/octet-stream;base64,"));
    // POSITION min/max as the specification requires.
    let root: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(
        root["accessors"][0]["min"],
        serde_json::json!([-3.5, 0.0, 0.0])
    );
    assert_eq!(root["accessors"][0]["max"][0], serde_json::json!(1.0));
}

#[test]
fn face_colours_become_corner_colours() {
    let m = Mesh {
        vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
        faces: vec![[0, 1, 2], [2, 1, 3]],
        face_colors: Some(vec![[10, 20, 30, 40], [50, 60, 70, 80]]),
        ..Default::default()
    };
    let back = parse_gltf("t", &write(&m, GltfContainer::Glb)).unwrap();
    assert_eq!(back.faces, vec![[0, 1, 2], [3, 4, 5]]);
    assert_eq!(
        back.vertices[3..],
        [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]
    );
    let c = back.vertex_colors.unwrap();
    assert_eq!(c[..3], [[10, 20, 30, 40]; 3]);
    assert_eq!(c[3..], [[50, 60, 70, 80]; 3]);
}

#[test]
fn empty_and_point_meshes() {
    let empty = Mesh::default();
    for c in [GltfContainer::Glb, GltfContainer::Gltf] {
        assert_eq!(parse_gltf("t", &write(&empty, c)).unwrap(), empty);
    }
    let pts = Mesh::new(vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], vec![]);
    assert_eq!(
        parse_gltf("t", &write(&pts, GltfContainer::Glb)).unwrap(),
        pts
    );
}

/// A hand-made glTF: vertex data in a data URI, u16 indices and u8
/// normalised VEC3 colours, and the mesh instanced by two nodes.
fn hand_made(node_json: &str, mode: u32, indices: &[u16]) -> String {
    let mut bin = Vec::new();
    for p in [
        [0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ] {
        for x in p {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    for k in 0..4u8 {
        // VEC3 u8 colours, padded to 4 bytes per element via byteStride.
        bin.extend_from_slice(&[10 * k, 20, 30, 0]);
    }
    for i in indices {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let n = indices.len();
    format!(
        r#"{{"asset":{{"version":"2.0"}},
            "buffers":[{{"byteLength":{len},"uri":"data:application/gltf-buffer;base64,{b64}"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},
                           {{"buffer":0,"byteOffset":48,"byteLength":16,"byteStride":4}},
                           {{"buffer":0,"byteOffset":64,"byteLength":{ilen}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5121,"normalized":true,"count":4,"type":"VEC3"}},
                         {{"bufferView":2,"componentType":5123,"count":{n},"type":"SCALAR"}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"COLOR_0":1}},"indices":2,"mode":{mode}}},
                                      {{"attributes":{{"POSITION":0}},"mode":1}}]}}],
            {node_json}}}"#,
        len = bin.len(),
        b64 = base64_encode(&bin),
        ilen = 2 * n,
    )
}

#[test]
fn node_transforms_and_merging() {
    // Node 0: translation (10, 0, 0) and child node 1 scaled by 2 (so the
    // child's world transform is translate(10,0,0) * scale(2)); both
    // instance mesh 0. The LINES primitive is skipped.
    let nodes = r#""nodes":[{"mesh":0,"translation":[10,0,0],"children":[1]},
                                 {"mesh":0,"scale":[2,2,2]}],
                       "scenes":[{"nodes":[0]}],"scene":0"#;
    let text = hand_made(nodes, 4, &[0, 1, 2, 2, 1, 3]);
    let m = parse_gltf("t.gltf", text.as_bytes()).unwrap();
    let want: Vec<[f32; 3]> = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ]
    .iter()
    .map(|p| [p[0] + 10.0, p[1], p[2]])
    .chain(
        [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ]
        .iter()
        .map(|p| [2.0 * p[0] + 10.0, 2.0 * p[1], 2.0 * p[2]]),
    )
    .collect();
    assert_eq!(m.vertices, want);
    assert_eq!(m.faces, vec![[0, 1, 2], [2, 1, 3], [4, 5, 6], [6, 5, 7]]);
    // The u8 colours are linear: read back as sRGB codes.
    let c = m.vertex_colors.unwrap();
    assert_eq!(c.len(), 8);
    let s = |k: u8| oetf8(f64::from(k) / 255.0);
    assert_eq!(c[1], [s(10), s(20), s(30), 255]);
    assert_eq!(c[7], [s(30), s(20), s(30), 255]);
    assert_eq!([s(10), s(20), s(30)], [56, 79, 96]);
}

#[test]
fn mirroring_flips_winding_and_strips_fans() {
    let mirror = r#""nodes":[{"mesh":0,"matrix":[-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]"#;
    let m = parse_gltf("t", hand_made(mirror, 4, &[0, 1, 2]).as_bytes()).unwrap();
    assert_eq!(m.vertices[1], [-1.0, 0.0, 0.0]);
    assert_eq!(m.faces, vec![[0, 2, 1]]);
    // TRIANGLE_STRIP 0 1 2 3 -> (0 1 2), (2 1 3); no nodes at all: the mesh
    // is read untransformed.
    let m = parse_gltf("t", hand_made(r#""nodes":[]"#, 5, &[0, 1, 2, 3]).as_bytes()).unwrap();
    assert_eq!(m.faces, vec![[0, 1, 2], [2, 1, 3]]);
    // TRIANGLE_FAN 0 1 3 2 -> (1 3 0), (3 2 0).
    let m = parse_gltf("t", hand_made(r#""nodes":[]"#, 6, &[0, 1, 3, 2]).as_bytes()).unwrap();
    assert_eq!(m.faces, vec![[1, 3, 0], [3, 2, 0]]);
}

fn err_of(bytes: &[u8]) -> String {
    parse_gltf("t.glb", bytes).unwrap_err().to_string()
}

#[test]
fn malformed_glb() {
    let glb = write(&sample(), GltfContainer::Glb);
    // Every truncation fails cleanly: the header declares the length.
    for cut in 4..glb.len() {
        let e = err_of(&glb[..cut]);
        assert!(e.starts_with("t.glb: byte offset "), "cut {cut}: {e}");
    }
    // JSON chunk length too large.
    let mut bad = glb.clone();
    bad[12..16].copy_from_slice(&(glb.len() as u32).to_le_bytes());
    let e = err_of(&bad);
    assert!(
        e.contains("byte offset 12") && e.contains("chunk length"),
        "{e}"
    );
    // BIN chunk length too large.
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let bin_at = 20 + json_len;
    let mut bad = glb.clone();
    bad[bin_at..bin_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let e = err_of(&bad);
    assert!(e.contains(&format!("byte offset {bin_at}")), "{e}");
    // BIN chunk shorter than the buffer it holds.
    let mut bad = glb.clone();
    let short = u32::from_le_bytes(glb[bin_at..bin_at + 4].try_into().unwrap()) - 8;
    bad[bin_at..bin_at + 4].copy_from_slice(&short.to_le_bytes());
    bad.truncate(glb.len() - 8);
    bad[8..12].copy_from_slice(&(glb.len() as u32 - 8).to_le_bytes());
    let e = err_of(&bad);
    assert!(e.contains("buffer 0 declares"), "{e}");
    // Wrong version.
    let mut bad = glb.clone();
    bad[4] = 1;
    assert!(err_of(&bad).contains("byte offset 4: GLB version 1"));
    // Broken JSON.
    let mut bad = glb.clone();
    bad[20] = b'[';
    assert!(err_of(&bad).contains("invalid glTF JSON"));
}

#[test]
fn malformed_content() {
    // Index out of range.
    let text = hand_made(r#""nodes":[]"#, 4, &[0, 1, 9]);
    let e = parse_gltf("t", text.as_bytes()).unwrap_err().to_string();
    assert!(
        e.contains("mesh 0 primitive 0 indices") && e.contains("is 9"),
        "{e}"
    );
    // Accessor larger than its view.
    let text = hand_made(r#""nodes":[]"#, 4, &[0, 1, 2]).replace(
        r#""count":4,"type":"VEC3","min""#,
        r#""count":5,"type":"VEC3","min""#,
    );
    let e = parse_gltf("t", text.as_bytes()).unwrap_err().to_string();
    assert!(
        e.contains("POSITION (accessor 0)") && e.contains("need 60 bytes"),
        "{e}"
    );
    // External buffer without a folder to resolve it.
    let text = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":4,"uri":"x.bin"}]}"#;
    let e = parse_gltf("t", text.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("external file 'x.bin'"), "{e}");
    // Node cycle.
    let text = r#"{"asset":{"version":"2.0"},"nodes":[{"children":[1]},{"children":[0]}],"scenes":[{"nodes":[0]}]}"#;
    let e = parse_gltf("t", text.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("node 0 is reached twice"), "{e}");
}

#[test]
fn every_number_replaced_never_panics() {
    // Each integer in a valid document (indices, offsets, lengths,
    // counts, component types, modes) replaced by extreme values: the
    // reader returns a mesh or an error, never panics or over-allocates.
    let nodes = r#""nodes":[{"mesh":0,"translation":[10,0,0],"children":[1]},{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0"#;
    let text = hand_made(nodes, 4, &[0, 1, 2, 2, 1, 3]);
    let json_start = text.find("\"bufferViews\"").unwrap();
    let bytes = text.as_bytes();
    let mut tried = 0;
    let mut i = json_start;
    while i < bytes.len() {
        if bytes[i].is_ascii_digit() && !bytes[i - 1].is_ascii_alphanumeric() {
            let end = i + bytes[i..].iter().take_while(|b| b.is_ascii_digit()).count();
            for rep in [
                "0",
                "1",
                "3",
                "7",
                "5121",
                "4294967295",
                "18446744073709551615",
                "-1",
            ] {
                let t = format!("{}{rep}{}", &text[..i], &text[end..]);
                if let Err(e) = parse_gltf("t.gltf", t.as_bytes()) {
                    assert!(e.to_string().starts_with("t.gltf: "), "{e}");
                }
                tried += 1;
            }
            i = end;
        } else {
            i += 1;
        }
    }
    assert!(tried > 200, "only {tried} variants");
    // The panic gltf-json would raise on a bad POSITION accessor index.
    let t = text.replace(r#""POSITION":0,"COLOR_0""#, r#""POSITION":9,"COLOR_0""#);
    let e = parse_gltf("t.gltf", t.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("accessor 9 does not exist"), "{e}");
}

#[test]
fn external_buffer_file() {
    let dir = tempfile::tempdir().unwrap();
    let bin: Vec<u8> = [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    std::fs::write(dir.path().join("my data.bin"), &bin).unwrap();
    let text = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"my%20data.bin"}],
            "bufferViews":[{"buffer":0,"byteLength":36}],
            "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
            "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#;
    let p = dir.path().join("m.gltf");
    std::fs::write(&p, text).unwrap();
    let m = read_gltf(&p).unwrap();
    assert_eq!(m.faces, vec![[0, 1, 2]]);
    assert_eq!(m.vertices[1], [1.0, 0.0, 0.0]);
}

/// Found by `examples/fuzz_readers.rs`: a GLB whose header declares fewer
/// bytes than the file holds, with a chunk header straddling that length,
/// is an error naming the offset (it used to slice out of range).
#[test]
fn chunk_header_past_the_declared_length_is_an_error() {
    let mesh = Mesh::new(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    let mut glb = Vec::new();
    write_gltf(&mut glb, &mesh, &GltfWriteOptions::default()).unwrap();
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    // Declared length ends 4 bytes into the BIN chunk's header.
    let cut = 12 + 8 + json_len + 4;
    glb[8..12].copy_from_slice(&(cut as u32).to_le_bytes());
    let e = parse_gltf("cut.glb", &glb).unwrap_err().to_string();
    assert!(e.starts_with("cut.glb") && e.contains("byte offset"), "{e}");
}

/// sRGB OETF to an 8-bit code, written out here from IEC 61966-2-1 for the
/// tests (the code under test has its own).
fn oetf8(l: f64) -> u8 {
    let v = if l <= 0.0031308 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    (v * 255.0).round() as u8
}

/// The f32 values of accessor `i` of a `.gltf` document.
fn accessor_f32(root: &serde_json::Value, bin: &[u8], i: usize) -> Vec<f32> {
    let acc = &root["accessors"][i];
    let view = &root["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let off = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    let len = view["byteLength"].as_u64().unwrap() as usize;
    bin[off..off + len]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect()
}

fn gltf_json_and_bin(mesh: &Mesh, opts: &GltfWriteOptions) -> (serde_json::Value, Vec<u8>) {
    let mut out = Vec::new();
    let opts = GltfWriteOptions {
        container: GltfContainer::Gltf,
        ..*opts
    };
    write_gltf(&mut out, mesh, &opts).unwrap();
    let root: serde_json::Value = serde_json::from_slice(&out).unwrap();
    let uri = root["buffers"][0]["uri"].as_str().unwrap();
    let bin = base64_decode(uri.split_once(";base64,").unwrap().1).unwrap();
    (root, bin)
}

/// Every 8-bit sRGB code is written as its linear value (f32, exact sRGB
/// EOTF, checked against the formula evaluated here in f64 to 1e-7, the
/// f32 rounding; a 2.2 power would be off by up to 0.0085, at code 191) and
/// read back to the same code.
#[test]
fn colour_0_is_linear_and_round_trips_every_code() {
    let n = 256;
    let mesh = Mesh {
        vertices: (0..n).map(|i| [i as f32, 0.0, 0.0]).collect(),
        faces: (0..n as u32 - 2).map(|i| [i, i + 1, i + 2]).collect(),
        vertex_colors: Some(
            (0..n)
                .map(|i| [i as u8, 255 - i as u8, (i * 7 % 256) as u8, 255])
                .collect(),
        ),
        ..Default::default()
    };
    let (root, bin) = gltf_json_and_bin(&mesh, &GltfWriteOptions::default());
    let prim = &root["meshes"][0]["primitives"][0];
    let ci = prim["attributes"]["COLOR_0"].as_u64().unwrap() as usize;
    assert_eq!(root["accessors"][ci]["componentType"], 5126, "f32");
    assert_eq!(root["accessors"][ci]["type"], "VEC4");
    let lin = accessor_f32(&root, &bin, ci);
    let eotf = |c: u8| {
        let c = f64::from(c) / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    for (i, c) in mesh.vertex_colors.as_ref().unwrap().iter().enumerate() {
        for k in 0..3 {
            let got = f64::from(lin[4 * i + k]);
            assert!(
                (got - eotf(c[k])).abs() < 1e-7,
                "vertex {i} channel {k}: {got}"
            );
        }
        assert_eq!(lin[4 * i + 3], 1.0);
    }
    // Code 128: 0.21586 linear (a 2.2 power gives 0.21953).
    assert!((f64::from(lin[4 * 128]) - 0.2158605).abs() < 1e-6);
    assert_eq!(
        parse_gltf("t", &write(&mesh, GltfContainer::Glb)).unwrap(),
        mesh
    );
    // Opaque colours: an OPAQUE material whose colour is COLOR_0 alone.
    let m = &root["materials"][0];
    assert_eq!(prim["material"], 0);
    assert_eq!(m["alphaMode"], "OPAQUE");
    assert_eq!(
        m["pbrMetallicRoughness"]["baseColorFactor"],
        serde_json::json!([1.0, 1.0, 1.0, 1.0])
    );
    assert_eq!(m["pbrMetallicRoughness"]["metallicFactor"], 0.0);
    assert!(m["pbrMetallicRoughness"].get("baseColorTexture").is_none());
    assert_eq!(m["doubleSided"], false);
}

/// Alpha below 255, or `blend`, gives a BLEND material; alpha is stored
/// linearly (`a / 255`) and read back exactly; no colours, no material.
#[test]
fn alpha_gives_a_blend_material() {
    let mut mesh = sample();
    let (root, bin) = gltf_json_and_bin(&mesh, &GltfWriteOptions::default());
    assert_eq!(root["materials"][0]["alphaMode"], "BLEND");
    let ci = root["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"]
        .as_u64()
        .unwrap() as usize;
    let lin = accessor_f32(&root, &bin, ci);
    assert_eq!(lin[15], 128.0 / 255.0);
    assert_eq!(
        parse_gltf("t", &write(&mesh, GltfContainer::Glb)).unwrap(),
        mesh
    );

    for c in mesh.vertex_colors.as_mut().unwrap() {
        c[3] = 255;
    }
    let opts = GltfWriteOptions {
        blend: true,
        double_sided: true,
        ..Default::default()
    };
    let (root, _) = gltf_json_and_bin(&mesh, &opts);
    assert_eq!(root["materials"][0]["alphaMode"], "BLEND");
    assert_eq!(root["materials"][0]["doubleSided"], true);
    let (root, _) = gltf_json_and_bin(&mesh, &GltfWriteOptions::default());
    assert_eq!(root["materials"][0]["alphaMode"], "OPAQUE");

    mesh.vertex_colors = None;
    let (root, _) = gltf_json_and_bin(&mesh, &opts);
    assert!(root.get("materials").is_none());
    assert!(root["meshes"][0]["primitives"][0].get("material").is_none());
}

/// Normalised u16 and f32 COLOR_0 written by other tools: linear, encoded
/// to sRGB on reading; alpha unchanged.
#[test]
fn u16_and_float_colours_are_read_as_linear() {
    let mut bin = Vec::new();
    for p in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for x in p {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    // u16 RGBA: linear 0.5, 0.0031308 (the knee), 1.0, alpha 0.5.
    let u16s: [[u16; 4]; 3] = [[32768, 205, 65535, 32768]; 3];
    for c in u16s {
        for x in c {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    let f32s: [[f32; 3]; 3] = [[0.215_860_5, 2.0, -1.0]; 3];
    for c in f32s {
        for x in c {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},
            "buffers":[{{"byteLength":{len},"uri":"data:application/octet-stream;base64,{b64}"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},
                           {{"buffer":0,"byteOffset":36,"byteLength":24}},
                           {{"buffer":0,"byteOffset":60,"byteLength":36}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5123,"normalized":true,"count":3,"type":"VEC4"}},
                         {{"bufferView":2,"componentType":5126,"count":3,"type":"VEC3"}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"COLOR_0":1}}}},
                                      {{"attributes":{{"POSITION":0,"COLOR_0":2}}}}]}}]}}"#,
        len = bin.len(),
        b64 = base64_encode(&bin),
    );
    let m = parse_gltf("t.gltf", text.as_bytes()).unwrap();
    let c = m.vertex_colors.unwrap();
    let want_u16 = [oetf8(32768.0 / 65535.0), oetf8(205.0 / 65535.0), 255, 128];
    assert_eq!(want_u16[..2], [188, 10]);
    assert_eq!(c[0], want_u16);
    assert_eq!(c[3], [128, 255, 0, 255]);
}

/// `inventory`: attributes over all primitives, materials with their
/// alphaMode (default OPAQUE), users and texture slots, and image files
/// resolved against the folder (present or not) or embedded.
#[test]
fn inventory_lists_attributes_materials_and_images() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("albedo map.png"), b"x").unwrap();
    let text = r#"{"asset":{"version":"2.0"},
        "meshes":[{"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1},"material":0},
                                 {"attributes":{"POSITION":0,"NORMAL":2},"material":0},
                                 {"attributes":{"POSITION":0},"material":1}]}],
        "materials":[{"name":"skin","alphaMode":"MASK",
                      "pbrMetallicRoughness":{"baseColorTexture":{"index":0}},
                      "normalTexture":{"index":1}},
                     {}],
        "textures":[{"source":0},{"source":1}],
        "images":[{"uri":"albedo%20map.png"},{"bufferView":3,"mimeType":"image/jpeg"},{"uri":"gone.png"}]}"#;
    let inv = inventory("t.gltf", text.as_bytes(), Some(dir.path())).unwrap();
    assert_eq!(inv.attributes, ["NORMAL", "POSITION", "TEXCOORD_0"]);
    assert_eq!(inv.materials.len(), 2);
    let m = &inv.materials[0];
    assert_eq!(
        (m.name.as_str(), m.alpha_mode.as_deref(), m.used_by),
        ("skin", Some("MASK"), 2)
    );
    let albedo = dir.path().join("albedo map.png").display().to_string();
    assert_eq!(m.textures[0].slot, "baseColorTexture");
    assert_eq!(m.textures[0].file, albedo);
    assert_eq!(m.textures[1].slot, "normalTexture");
    assert_eq!(m.textures[1].file, "embedded image 1 (image/jpeg)");
    let m = &inv.materials[1];
    assert_eq!(
        (m.name.as_str(), m.alpha_mode.as_deref(), m.used_by),
        ("material 1", Some("OPAQUE"), 1)
    );
    assert_eq!(inv.textures.len(), 2, "unused images are not listed");
    assert_eq!(
        (inv.textures[0].file.as_str(), inv.textures[0].exists),
        (albedo.as_str(), true)
    );
    assert!(inv.textures[1].exists);
    // A referenced image that is absent.
    let text = text.replace(r#""source":0"#, r#""source":2"#);
    let inv = inventory("t.gltf", text.as_bytes(), Some(dir.path())).unwrap();
    assert!(!inv.textures[0].exists);
    assert!(inv.textures[0].file.ends_with("gone.png"));
    // Our own GLB: its colour material.
    let glb = write(&sample(), GltfContainer::Glb);
    let inv = inventory("t.glb", &glb, None).unwrap();
    assert_eq!(inv.attributes, ["COLOR_0", "NORMAL", "POSITION"]);
    assert_eq!(inv.materials[0].alpha_mode.as_deref(), Some("BLEND"));
    assert!(inv.textures.is_empty());
    assert!(
        inventory("t.gltf", b"{", None)
            .unwrap_err()
            .to_string()
            .contains("t.gltf")
    );
}
