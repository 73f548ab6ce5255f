//! Outputs other clients read correctly: `export-off`'s glTF colours are
//! linear (what a spec-following viewer shows equals the OBJ of the same
//! run), alpha comes with a BLEND material, the `compatible` OFF layout
//! carries colours on the vertices (what Open3D requires of `COFF`), the
//! reported counts equal what the written file holds, and `info` lists a
//! glTF's materials. The clients themselves run in `scripts/compare/`.

mod common;

use std::path::Path;

use common::{run, s, succeeds};
use splatkit::geom::scenes::synthetic::demo_soup;
use splatkit::io::ply::{Format, soup::write_soup};

fn soup_file(dir: &Path) -> std::path::PathBuf {
    let (soup, _) = demo_soup(1, 8);
    let p = dir.join("soup.ply");
    let mut b = Vec::new();
    write_soup(&mut b, &soup, Format::BinaryLittleEndian).unwrap();
    std::fs::write(&p, b).unwrap();
    p
}

fn json(out: &std::process::Output) -> serde_json::Value {
    succeeds(out);
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The sRGB EOTF (IEC 61966-2-1), written out for the test.
fn eotf(c: u8) -> f64 {
    let c = f64::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The `.gltf` JSON and its decoded buffer.
fn gltf_parts(p: &Path) -> (serde_json::Value, Vec<u8>) {
    use base64::Engine;
    let root: serde_json::Value = serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
    let uri = root["buffers"][0]["uri"].as_str().unwrap().to_string();
    let bin = base64::engine::general_purpose::STANDARD
        .decode(uri.split_once(";base64,").unwrap().1)
        .unwrap();
    (root, bin)
}

/// For every output format and layout flag, the `--json` counts and the
/// human summary equal the counts of the file read back (the issue: 4,608
/// reported for a GLB that holds 27,648).
#[test]
fn export_off_reports_what_the_file_holds() {
    let dir = tempfile::tempdir().unwrap();
    let input = soup_file(dir.path());
    let flag_sets: [&[&str]; 4] = [&[], &["--no-dedup"], &["--per-vertex-colors"], &["--alpha"]];
    let mut unshared = 0;
    for ext in ["off", "ply", "obj", "glb", "gltf"] {
        for (k, flags) in flag_sets.iter().enumerate() {
            let out = dir.path().join(format!("o{k}.{ext}"));
            let mut args = vec![s(&input), "-o", s(&out), "--json"];
            args.extend_from_slice(flags);
            let o = run("export-off", &args, None);
            let r = json(&o);
            let m = splatkit::io::any::load_mesh(&out, "test").unwrap();
            let what = format!("{ext} {flags:?}");
            assert_eq!(r["vertices"], m.vertices.len(), "{what}");
            assert_eq!(r["faces"], m.faces.len(), "{what}");
            if m.vertices.len() == 3 * m.faces.len() && flags.is_empty() {
                unshared += 1;
            }
            let text = String::from_utf8_lossy(&o.stderr);
            assert!(
                text.contains(&format!("wrote {} vertices", m.vertices.len())),
                "{what}: {text}"
            );
        }
    }
    // Default flags: OBJ, GLB and glTF un-share the merged vertices.
    assert!(unshared >= 3, "{unshared}");
}

/// A spec-following glTF client decodes nothing: COLOR_0 is linear, so it
/// displays sRGB(COLOR_0), which must equal the OBJ's colour. Here COLOR_0
/// equals the sRGB EOTF of the OBJ's 8-bit colours (to 1e-6: f32), and our
/// reader gives the OBJ's colours back.
#[test]
fn gltf_colours_are_the_obj_colours_in_linear() {
    let dir = tempfile::tempdir().unwrap();
    let input = soup_file(dir.path());
    let (obj, gltf) = (dir.path().join("o.obj"), dir.path().join("o.gltf"));
    succeeds(&run("export-off", &[s(&input), "-o", s(&obj), "-q"], None));
    succeeds(&run("export-off", &[s(&input), "-o", s(&gltf), "-q"], None));
    let from_obj = splatkit::io::any::load_mesh(&obj, "test").unwrap();
    let from_gltf = splatkit::io::any::load_mesh(&gltf, "test").unwrap();
    let want = from_obj.vertex_colors.as_ref().unwrap();
    assert_eq!(from_gltf.vertex_colors.as_ref().unwrap(), want);
    let (root, bin) = gltf_parts(&gltf);
    let prim = &root["meshes"][0]["primitives"][0];
    let acc = &root["accessors"][prim["attributes"]["COLOR_0"].as_u64().unwrap() as usize];
    assert_eq!(acc["componentType"], 5126);
    let view = &root["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let off = view["byteOffset"].as_u64().unwrap() as usize;
    let lin: Vec<f32> = bin[off..off + 16 * want.len()]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    let mut max_err = 0f64;
    for (i, c) in want.iter().enumerate() {
        for k in 0..3 {
            max_err = max_err.max((f64::from(lin[4 * i + k]) - eotf(c[k])).abs());
        }
    }
    assert!(max_err < 1e-6, "{max_err}");
    // Opaque soup: an OPAQUE, double-sided material using COLOR_0 alone.
    let mat = &root["materials"][prim["material"].as_u64().unwrap() as usize];
    assert_eq!(mat["alphaMode"], "OPAQUE");
    assert_eq!(mat["doubleSided"], true);
}

/// `--alpha`: the alpha values are kept and a BLEND material makes clients
/// use them; `info` reports the material.
#[test]
fn alpha_comes_with_a_blend_material_that_info_lists() {
    let dir = tempfile::tempdir().unwrap();
    let input = soup_file(dir.path());
    let glb = dir.path().join("a.glb");
    let gltf = dir.path().join("a.gltf");
    for p in [&glb, &gltf] {
        succeeds(&run(
            "export-off",
            &[s(&input), "-o", s(p), "--alpha", "-q"],
            None,
        ));
    }
    let (root, _) = gltf_parts(&gltf);
    assert_eq!(root["materials"][0]["alphaMode"], "BLEND");
    assert_eq!(
        root["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"],
        serde_json::json!([1.0, 1.0, 1.0, 1.0])
    );
    let m = splatkit::io::any::load_mesh(&glb, "test").unwrap();
    let off = dir.path().join("a.off");
    succeeds(&run(
        "export-off",
        &[
            s(&input),
            "-o",
            s(&off),
            "--alpha",
            "--per-vertex-colors",
            "-q",
        ],
        None,
    ));
    let m_off = splatkit::io::any::load_mesh(&off, "test").unwrap();
    assert_eq!(
        m.vertex_colors, m_off.vertex_colors,
        "alpha survives exactly"
    );
    assert!(m.vertex_colors.unwrap().iter().any(|c| c[3] < 255));
    let r = json(&run("info", &[s(&glb), "--json"], None));
    let i = &r[0];
    assert!(
        i["attributes"]
            .as_array()
            .unwrap()
            .contains(&"vertex-colors".into())
    );
    assert_eq!(i["materials"][0]["alpha_mode"], "BLEND");
    assert_eq!(i["materials"][0]["used_by"], 1);
    let text = run("info", &[s(&glb)], None);
    succeeds(&text);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(text.contains("alphaMode BLEND"), "{text}");
}

/// Vertex lines of an OFF file: (coordinates, colour) token counts.
fn off_lines(p: &Path) -> (String, Vec<usize>, Vec<usize>) {
    let t = std::fs::read_to_string(p).unwrap();
    let lines: Vec<&str> = t.lines().collect();
    let counts: Vec<usize> = lines[1]
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    let (nv, nf) = (counts[0], counts[1]);
    let toks = |l: &str| l.split_whitespace().count();
    (
        lines[0].to_string(),
        lines[2..2 + nv].iter().map(|l| toks(l)).collect(),
        lines[2 + nv..2 + nv + nf].iter().map(|l| toks(l)).collect(),
    )
}

/// The default OFF stays create_off.py's (COFF, bare vertices, coloured
/// faces: Open3D refuses it); `--off-layout compatible` writes COFF with
/// `r g b a` on every vertex and bare faces (what Open3D's reader needs),
/// the corner colours equal to the default file's face colours, from a
/// soup and from a mesh with face colours.
#[test]
fn compatible_off_layout_puts_colours_on_vertices() {
    let dir = tempfile::tempdir().unwrap();
    let input = soup_file(dir.path());
    let ts = dir.path().join("ts.off");
    let compat = dir.path().join("compat.off");
    succeeds(&run("export-off", &[s(&input), "-o", s(&ts), "-q"], None));
    succeeds(&run(
        "export-off",
        &[
            s(&input),
            "-o",
            s(&compat),
            "--off-layout",
            "compatible",
            "-q",
        ],
        None,
    ));
    let (h, v, f) = off_lines(&ts);
    assert_eq!(h, "COFF");
    assert!(v.iter().all(|&n| n == 3) && f.iter().all(|&n| n == 8));
    let (h, v, f) = off_lines(&compat);
    assert_eq!(h, "COFF");
    assert!(v.iter().all(|&n| n == 7) && f.iter().all(|&n| n == 4));
    let a = splatkit::io::any::load_mesh(&ts, "test").unwrap();
    let b = splatkit::io::any::load_mesh(&compat, "test").unwrap();
    let check = |b: &splatkit::model::Mesh| {
        assert_eq!(b.faces.len(), a.faces.len());
        let vc = b.vertex_colors.as_ref().unwrap();
        for (i, fc) in a.face_colors.as_ref().unwrap().iter().enumerate() {
            for k in 0..3 {
                assert_eq!(vc[b.faces[i][k] as usize], *fc, "face {i}");
                assert_eq!(
                    b.vertices[b.faces[i][k] as usize],
                    a.vertices[a.faces[i][k] as usize]
                );
            }
        }
    };
    check(&b);
    // A mesh input with face colours (the default OFF itself).
    let again = dir.path().join("again.off");
    succeeds(&run(
        "export-off",
        &[s(&ts), "-o", s(&again), "--off-layout", "compatible", "-q"],
        None,
    ));
    let (h, v, f) = off_lines(&again);
    assert_eq!(h, "COFF");
    assert!(v.iter().all(|&n| n == 7) && f.iter().all(|&n| n == 4));
    check(&splatkit::io::any::load_mesh(&again, "test").unwrap());
    // The flag is for OFF output only.
    let o = run(
        "export-off",
        &[
            s(&input),
            "-o",
            s(&dir.path().join("x.glb")),
            "--off-layout",
            "compatible",
        ],
        None,
    );
    common::fails(&o, 2, &["--off-layout"]);
    let h = run("export-off", &["--help"], None);
    succeeds(&h);
    let help = String::from_utf8_lossy(&h.stdout);
    assert!(
        help.contains("Open3D") && help.contains("compatible"),
        "{help}"
    );
}
