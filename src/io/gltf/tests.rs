use crate::model::Mesh;

use super::*;

fn write(mesh: &Mesh, container: GltfContainer) -> Vec<u8> {
    let mut out = Vec::new();
    write_gltf(&mut out, mesh, &GltfWriteOptions { container }).unwrap();
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
    let c = m.vertex_colors.unwrap();
    assert_eq!(c.len(), 8);
    assert_eq!(c[1], [10, 20, 30, 255]);
    assert_eq!(c[7], [30, 20, 30, 255]);
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
