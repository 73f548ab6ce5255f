//! Issue 25 hostile cases: the Gaussian-splat readers (compressed PLY,
//! `.splat`, `.ksplat`) and `convert`. Each input is a few hundred bytes
//! declaring more than it holds, or malformed; every run must end with exit
//! 1 naming the file, no panic, no output.

use super::common::{fails, run, s};

fn ksplat_header(sections: u32, splats: u32, level: u16) -> Vec<u8> {
    let mut b = vec![0u8; 4096];
    b[1] = 1;
    b[4..8].copy_from_slice(&sections.to_le_bytes());
    b[16..20].copy_from_slice(&splats.to_le_bytes());
    b[20..22].copy_from_slice(&level.to_le_bytes());
    b
}

#[test]
fn splat_readers_refuse_what_is_not_there() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.ply");
    let mut cases: Vec<(&str, Vec<u8>, &str)> = Vec::new();
    // a compressed PLY declaring 4 billion Gaussians in a few bytes
    let mut cp = b"ply\nformat binary_little_endian 1.0\nelement chunk 16777216\n".to_vec();
    for p in ["min_x", "min_y", "min_z", "max_x", "max_y", "max_z"] {
        cp.extend_from_slice(format!("property float {p}\n").as_bytes());
    }
    for p in [
        "min_scale_x",
        "min_scale_y",
        "min_scale_z",
        "max_scale_x",
        "max_scale_y",
    ] {
        cp.extend_from_slice(format!("property float {p}\n").as_bytes());
    }
    cp.extend_from_slice(b"property float max_scale_z\nelement vertex 4294967295\n");
    for p in [
        "packed_position",
        "packed_rotation",
        "packed_scale",
        "packed_color",
    ] {
        cp.extend_from_slice(format!("property uint {p}\n").as_bytes());
    }
    cp.extend_from_slice(b"end_header\n");
    cp.extend_from_slice(&[7u8; 64]);
    cases.push((
        "huge.compressed.ply",
        cp.clone(),
        "element 'chunk' declares",
    ));
    // ... and one whose chunk count does not match its Gaussians
    let small = String::from_utf8_lossy(&cp)
        .replace("element chunk 16777216", "element chunk 2")
        .replace("element vertex 4294967295", "element vertex 1")
        .into_bytes();
    let mut small = small[..small.len() - 64].to_vec();
    small.extend_from_slice(&[0u8; 2 * 48 + 16]);
    cases.push(("chunks.compressed.ply", small, "need 1"));
    // a .splat with a partial record
    cases.push(("cut.splat", vec![0u8; 33], "32-byte records"));
    // .ksplat: sections and splats that are not there, a bad level
    cases.push(("sections.ksplat", ksplat_header(u32::MAX, 1, 1), "sections"));
    let mut k = ksplat_header(1, 4_000_000_000, 1);
    k.extend_from_slice(&[0u8; 1024]);
    k[4096..4100].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    k[4100..4104].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    cases.push(("splats.ksplat", k, "section 0"));
    let mut k = ksplat_header(1, 0, 9);
    k.extend_from_slice(&[0u8; 1024]);
    cases.push(("level.ksplat", k, "compression level 9"));
    for (name, bytes, needle) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        let o = run("convert", &[s(&p), "-o", s(&out)], None);
        fails(&o, 1, &[name, needle]);
        assert!(!out.exists(), "{name}");
        let o = run("info", &[s(&p)], None);
        fails(&o, 1, &[name]);
    }
}

/// `convert` refuses a lossy target without --lossy and leaves an existing
/// output as it was.
#[test]
fn refused_conversion_keeps_the_old_output() {
    let dir = tempfile::tempdir().unwrap();
    let mut g = splatkit::model::Gaussians {
        means: vec![[0.0; 3]],
        sh_dc: vec![[9.0, 0.0, 0.0]],
        opacity_logits: vec![0.0],
        log_scales: vec![[-3.0; 3]],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]],
        ..Default::default()
    };
    g.sh_degree = 0;
    let input = dir.path().join("in.ply");
    splatkit::io::any::save_gaussians(&input, &g).unwrap();
    let out = dir.path().join("old.splat");
    std::fs::write(&out, b"keep me").unwrap();
    let o = run("convert", &[s(&input), "-o", s(&out)], None);
    fails(&o, 1, &["old.splat", "Gaussian 0 has f_dc_0 = 9"]);
    assert_eq!(std::fs::read(&out).unwrap(), b"keep me");
}
