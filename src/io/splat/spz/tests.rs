use super::*;
use rand::RngExt;

/// `n` Gaussians of SH degree `d` with values well inside SPZ's and SOG's
/// ranges (positions within ±`extent`), from a fixed seed.
pub(crate) fn random_gaussians(n: usize, d: usize, extent: f32, seed: u64) -> Gaussians {
    let mut r = crate::model::rng::seeded(seed);
    let k = (d + 1) * (d + 1) - 1;
    let mut u = |a: f32, b: f32| r.random_range(a..b);
    let means = (0..n)
        .map(|_| [u(-extent, extent), u(-extent, extent), u(-extent, extent)])
        .collect();
    let sh_dc = (0..n)
        .map(|_| [u(-2.0, 2.0), u(-2.0, 2.0), u(-2.0, 2.0)])
        .collect();
    let sh_rest = (0..n * k * 3).map(|_| u(-0.9, 0.9)).collect();
    let opacity_logits = (0..n).map(|_| u(-6.0, 6.0)).collect();
    let log_scales = (0..n)
        .map(|_| [u(-9.0, 1.0), u(-9.0, 1.0), u(-9.0, 1.0)])
        .collect();
    let rotations = (0..n)
        .map(|_| [u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0)])
        .collect();
    Gaussians {
        means,
        normals: None,
        sh_degree: d,
        sh_dc,
        sh_rest,
        opacity_logits,
        log_scales,
        rotations,
        extras: Default::default(),
    }
}

/// Angle (radians) between the rotations of two (w, x, y, z) quaternions.
pub(crate) fn quat_angle(a: [f32; 4], b: [f32; 4]) -> f32 {
    let na = a.iter().map(|v| v * v).sum::<f32>().sqrt();
    let nb = b.iter().map(|v| v * v).sum::<f32>().sqrt();
    let d: f32 = a.iter().zip(b).map(|(x, y)| x * y).sum::<f32>() / (na * nb);
    2.0 * d.abs().min(1.0).acos()
}

/// write → read keeps every value within its quantisation step:
/// positions 2^-12/2, log-scales 1/32, colours 0.5/(0.15·255), alpha 0.5/255,
/// SH band 1 (bucket 8) 4.5/128, bands 2–3 (bucket 16) 8.5/128, rotations
/// within the smallest-three step (3 components × √½/511/2 → < 0.003 rad).
#[test]
fn round_trip_within_quantisation() {
    let g = random_gaussians(500, 3, 100.0, 7);
    let bytes = write("rt.spz", &g, false).unwrap();
    assert!(sniff(&bytes));
    assert_eq!(&bytes[0..4], b"NGSP");
    assert_eq!(u32_at(&bytes, 4), 4);
    let h = read("rt.spz", &bytes).unwrap();
    h.validate().unwrap();
    assert_eq!(h.len(), g.len());
    assert_eq!(h.sh_degree, 3);
    let mut worst = [0f32; 7];
    for i in 0..g.len() {
        for j in 0..3 {
            worst[0] = worst[0].max((g.means[i][j] - h.means[i][j]).abs());
            worst[1] = worst[1].max((g.log_scales[i][j] - h.log_scales[i][j]).abs());
            worst[2] = worst[2].max((g.sh_dc[i][j] - h.sh_dc[i][j]).abs());
        }
        worst[3] = worst[3].max((g.opacity(i) - h.opacity(i)).abs());
        worst[4] = worst[4].max(quat_angle(g.rotations[i], h.rotations[i]));
        for kk in 0..15 {
            for c in 0..3 {
                let idx = (i * 15 + kk) * 3 + c;
                let e = (g.sh_rest[idx] - h.sh_rest[idx]).abs();
                let slot = if kk < 3 { 5 } else { 6 };
                worst[slot] = worst[slot].max(e);
            }
        }
    }
    let tol = [
        0.5 / 4096.0 + 1e-5,
        1.0 / 32.0 + 1e-5,
        0.5 / (0.15 * 255.0) + 1e-5,
        0.5 / 255.0 + 1e-6,
        0.003,
        4.5 / 128.0 + 1e-6,
        8.5 / 128.0 + 1e-6,
    ];
    for (j, (w, t)) in worst.iter().zip(tol).enumerate() {
        assert!(w <= &t, "field {j}: worst error {w} above {t}");
    }
    // the same errors are not all zero: the format does quantise
    assert!(worst[0] > 0.0 && worst[6] > 0.01);
}

/// Axes: a Gaussian at an off-axis point with an off-axis rotation is stored
/// in RUB (y and z negated, quaternion y and z negated) and comes back in RDF.
#[test]
fn stores_rub_and_reads_rdf() {
    let mut g = random_gaussians(1, 1, 1.0, 3);
    g.means[0] = [1.5, 2.25, -3.0];
    let half = 0.3f32;
    // rotation about the axis (1, 2, 3)/√14 by 0.6 rad: (w, x, y, z)
    let s = half.sin() / 14f32.sqrt();
    g.rotations[0] = [half.cos(), s, 2.0 * s, 3.0 * s];
    g.sh_rest = vec![0.25, 0.0, 0.0, 0.5, 0.0, 0.0, 0.75, 0.0, 0.0];
    let bytes = write("a.spz", &g, false).unwrap();
    let p = parse_v4("a.spz", &bytes).unwrap();
    let fixed = |j: usize| {
        i32::from_le_bytes([
            p.positions[3 * j],
            p.positions[3 * j + 1],
            p.positions[3 * j + 2],
            0,
        ]) << 8
            >> 8
    };
    assert_eq!(p.fractional_bits, 12);
    assert_eq!([fixed(0), fixed(1), fixed(2)], [6144, -9216, 12288]);
    let q = unpack_smallest_three(&p.rotations);
    let want = [s, -2.0 * s, -3.0 * s, half.cos()];
    for j in 0..4 {
        assert!((q[j] - want[j]).abs() < 2e-3, "{q:?} vs {want:?}");
    }
    // band 1 in RUB: coefficient 0 (∝ y) and 1 (∝ z) flip, 2 (∝ x) keeps
    let sh: Vec<f32> = p.sh.iter().map(|&b| (b as f32 - 128.0) / 128.0).collect();
    assert_eq!([sh[0], sh[3], sh[6]], [-0.25, -0.5, 0.75]);
    let h = read("a.spz", &bytes).unwrap();
    assert_eq!(h.means[0], [1.5, 2.25, -3.0]);
    assert!(quat_angle(h.rotations[0], g.rotations[0]) < 3e-3);
    assert_eq!(&h.sh_rest[..9], &g.sh_rest[..]);
}

/// A hand-made legacy file (gzip, 16-byte header) of version 2 (first-three
/// quaternions) and 3 (smallest three) decodes by the official rules.
#[test]
fn reads_legacy_gzip_versions() {
    for version in [2u32, 3] {
        let mut raw = Vec::new();
        raw.extend_from_slice(b"NGSP");
        raw.extend_from_slice(&version.to_le_bytes());
        raw.extend_from_slice(&1u32.to_le_bytes());
        raw.extend_from_slice(&[0, 10, 0, 0]); // degree 0, 10 fractional bits
        // position (1024, -2048, 512) / 1024 = (1, -2, 0.5) in RUB
        for v in [1024i32, -2048, 512] {
            raw.extend_from_slice(&v.to_le_bytes()[..3]);
        }
        raw.push(255); // alpha
        raw.extend_from_slice(&[128, 0, 255]); // colour
        raw.extend_from_slice(&[160, 0, 255]); // scales: 0, -10, 5.9375
        if version == 2 {
            raw.extend_from_slice(&[128, 128, 255]); // xyz ≈ (0, 0, 1), w ≈ 0
        } else {
            // largest = w (index 3), x = y = z = 0
            raw.extend_from_slice(&(3u32 << 30).to_le_bytes());
        }
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        std::io::Write::write_all(&mut gz, &raw).unwrap();
        let bytes = gz.finish().unwrap();
        assert!(sniff(&bytes));
        let g = read("legacy.spz", &bytes).unwrap();
        assert_eq!(g.means[0], [1.0, 2.0, -0.5]);
        assert_eq!(g.log_scales[0], [0.0, -10.0, 5.9375]);
        assert!((g.opacity_logits[0] - 13.8155).abs() < 1e-3);
        assert!((g.sh_dc[0][0] - (128.0 / 255.0 - 0.5) / 0.15).abs() < 1e-6);
        assert!((g.sh_dc[0][1] + 0.5 / 0.15).abs() < 1e-6);
        let q = g.rotations[0];
        if version == 2 {
            // (x, y, z) ≈ (0.0039, 0.0039, 1) in RUB → z negated in RDF
            assert!(q[0].abs() < 0.01 && (q[3] + 1.0).abs() < 1e-4, "{q:?}");
        } else {
            assert_eq!(q, [1.0, 0.0, -0.0, -0.0]);
        }
    }
}

fn err(r: Result<impl std::fmt::Debug>) -> String {
    r.unwrap_err().to_string()
}

/// lossy = false refuses values SPZ would clamp, naming the output, the
/// Gaussian and the value; lossy = true writes them clamped.
#[test]
fn refuses_clamped_values_unless_lossy() {
    let base = random_gaussians(4, 1, 1.0, 5);
    let mut g = base.clone();
    g.log_scales[2][1] = -12.4; // a SuGaR-bound thin Gaussian
    let e = err(write("out.spz", &g, false));
    assert!(
        e.contains("out.spz") && e.contains("Gaussian 2") && e.contains("-12.4"),
        "{e}"
    );
    let h = read("out.spz", &write("out.spz", &g, true).unwrap()).unwrap();
    assert_eq!(h.log_scales[2][1], -10.0);

    let mut g = base.clone();
    g.means[1][0] = f32::NAN;
    let e = err(write("o.spz", &g, false));
    assert!(e.contains("Gaussian 1") && e.contains("NaN"), "{e}");
    assert!(write("o.spz", &g, true).is_ok());

    let mut g = base.clone();
    g.sh_rest[3 * 3 * 3 + 2] = 1.5; // Gaussian 3, coefficient 0, blue
    let e = err(write("o.spz", &g, false));
    assert!(e.contains("Gaussian 3") && e.contains("1.5"), "{e}");

    let mut g = base.clone();
    g.sh_dc[0][0] = 4.0;
    assert!(err(write("o.spz", &g, false)).contains("Gaussian 0"));

    let mut g = base.clone();
    g.rotations[1] = [0.0; 4];
    assert!(err(write("o.spz", &g, false)).contains("Gaussian 1"));
    let h = read("o.spz", &write("o.spz", &g, true).unwrap()).unwrap();
    assert_eq!(h.rotations[1], [1.0, 0.0, -0.0, -0.0]);

    let e = err(write("o.spz", &Gaussians::default(), true));
    assert!(e.contains("zero Gaussians"), "{e}");
}

/// Positions beyond ±2048 lower the fractional bits instead of wrapping.
#[test]
fn large_scenes_use_fewer_fractional_bits() {
    let mut g = random_gaussians(3, 0, 1.0, 9);
    g.means[1] = [5000.0, -70000.0, 0.001];
    let bytes = write("big.spz", &g, false).unwrap();
    assert_eq!(bytes[13], 6); // 70000·2^6 < 2^23 ≤ 70000·2^7
    let h = read("big.spz", &bytes).unwrap();
    for j in 0..3 {
        assert!((h.means[1][j] - g.means[1][j]).abs() <= 0.5 / 64.0);
    }
    g.means[2][2] = 1e7;
    assert!(err(write("big.spz", &g, false)).contains("position[2]"));
}

/// Truncated files, bad TOCs and huge declared counts are errors, with no
/// panic and no large allocation.
#[test]
fn hostile_inputs_are_errors() {
    let g = random_gaussians(50, 2, 10.0, 11);
    let good = write("h.spz", &g, false).unwrap();
    for cut in [0, 3, 4, 20, 31, 32, 40, good.len() / 2, good.len() - 1] {
        assert!(read("h.spz", &good[..cut]).is_err(), "cut at {cut}");
    }
    let mut extra = good.clone();
    extra.push(0);
    assert!(err(read("h.spz", &extra)).contains("after the last stream"));
    let mut huge = good.clone();
    huge[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(err(read("h.spz", &huge)).contains("Gaussians"));
    let mut big = good.clone();
    big[8..12].copy_from_slice(&100_000u32.to_le_bytes());
    assert!(read("h.spz", &big).is_err());
    let mut deg = good.clone();
    deg[12] = 9;
    assert!(err(read("h.spz", &deg)).contains("SH degree"));
    let mut toc = good.clone();
    toc[16..20].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(err(read("h.spz", &toc)).contains("TOC"));
    let mut ns = good.clone();
    ns[15] = 200;
    assert!(read("h.spz", &ns).is_err());
    let mut sizes = good.clone();
    sizes[32..40].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(read("h.spz", &sizes).is_err());
    // the first stream (after the 32-byte header and 6 TOC entries) loses its zstd magic
    let mut body = good.clone();
    body[128..132].fill(0xAB);
    assert!(err(read("h.spz", &body)).contains("zstd"));
    // a gzip legacy header claiming many Gaussians in a tiny stream
    let mut raw = b"NGSP".to_vec();
    raw.extend_from_slice(&3u32.to_le_bytes());
    raw.extend_from_slice(&50_000_000u32.to_le_bytes());
    raw.extend_from_slice(&[0, 12, 0, 0]);
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    std::io::Write::write_all(&mut gz, &raw).unwrap();
    let tiny = gz.finish().unwrap();
    assert!(read("h.spz", &tiny).is_err());
    assert!(!sniff(b"PK\x03\x04"));
    assert!(read("h.spz", b"hello").is_err());
}

/// The coordinate-system extension: RDF stored data is read without flips;
/// a rotated system is refused.
#[test]
fn coordinate_system_extension() {
    let g = random_gaussians(2, 0, 1.0, 13);
    let good = write("e.spz", &g, false).unwrap();
    let with_ext = |system: u32| {
        let mut b = good[..32].to_vec();
        b[14] |= FLAG_HAS_EXTENSIONS;
        b[16..20].copy_from_slice(&44u32.to_le_bytes());
        b.extend_from_slice(&EXT_COORDINATE_SYSTEM.to_le_bytes());
        b.extend_from_slice(&4u32.to_le_bytes());
        b.extend_from_slice(&system.to_le_bytes());
        b.extend_from_slice(&good[32..]);
        b
    };
    let rub = read("e.spz", &good).unwrap();
    let rdf = read("e.spz", &with_ext(6)).unwrap();
    for i in 0..2 {
        assert_eq!(rdf.means[i][0], rub.means[i][0]);
        assert_eq!(rdf.means[i][1], -rub.means[i][1]);
        assert_eq!(rdf.means[i][2], -rub.means[i][2]);
    }
    assert_eq!(read("e.spz", &with_ext(4)).unwrap(), rub);
    assert!(err(read("e.spz", &with_ext(12))).contains("rotated"));
}

/// biker.spz (version 4, 152,746 Gaussians, written by PlayCanvas from the
/// same capture as biker.compressed.ply) against the standard PLY decoded from
/// that compressed PLY. The two are different quantisations (SuperSplat
/// packs positions to 11/10/11 bits of a chunk's box, log-scales likewise,
/// colour 8 bits), so per-value agreement is checked loosely: median
/// position difference below 1 mm-scale units and 99% of opacities within
/// 0.02; the axes must agree (RUB → RDF conversion).
#[test]
fn biker_spz_matches_the_decoded_ply() {
    let Some(spz) = crate::testing::shared_data("3dgs-playcanvas-biker/biker.spz") else {
        return;
    };
    let ply = crate::testing::shared_data("3dgs-playcanvas-biker/biker.decoded_sh0.ply").unwrap();
    let a = read("biker.spz", &std::fs::read(spz).unwrap()).unwrap();
    let b =
        crate::io::ply::gaussians::parse_gaussians("ply", &std::fs::read(ply).unwrap()).unwrap();
    assert_eq!(a.len(), 152_746);
    assert_eq!(a.len(), b.len());
    assert_eq!(a.sh_degree, 0);
    let mut dp: Vec<f32> = (0..a.len())
        .map(|i| {
            (0..3)
                .map(|j| (a.means[i][j] - b.means[i][j]).powi(2))
                .sum::<f32>()
                .sqrt()
        })
        .collect();
    dp.sort_by(f32::total_cmp);
    let median = dp[dp.len() / 2];
    let p99 = dp[dp.len() * 99 / 100];
    eprintln!("biker: position difference median {median}, p99 {p99}");
    assert!(median < 2e-3 && p99 < 1e-2, "median {median} p99 {p99}");
    let mut da: Vec<f32> = (0..a.len())
        .map(|i| (a.opacity(i) - b.opacity(i)).abs())
        .collect();
    da.sort_by(f32::total_cmp);
    assert!(
        da[da.len() * 99 / 100] < 0.02,
        "opacity p99 {}",
        da[da.len() * 99 / 100]
    );
    let mut ds: Vec<f32> = (0..a.len())
        .flat_map(|i| (0..3).map(move |j| (i, j)))
        .filter(|&(i, j)| b.log_scales[i][j] > -10.0)
        .map(|(i, j)| (a.log_scales[i][j] - b.log_scales[i][j]).abs())
        .collect();
    ds.sort_by(f32::total_cmp);
    assert!(
        ds[ds.len() / 2] < 0.1,
        "log-scale median {}",
        ds[ds.len() / 2]
    );
    let mut dq: Vec<f32> = (0..a.len())
        .map(|i| quat_angle(a.rotations[i], b.rotations[i]))
        .collect();
    dq.sort_by(f32::total_cmp);
    assert!(
        dq[dq.len() / 2] < 0.02,
        "rotation median {}",
        dq[dq.len() / 2]
    );
}

/// `testdata/splats/NAME` and its entry in `testdata/splats/expected.json`.
pub(crate) fn fixture(name: &str) -> (Vec<u8>, serde_json::Value) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/splats");
    let exp: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("expected.json")).unwrap()).unwrap();
    (std::fs::read(dir.join(name)).unwrap(), exp[name].clone())
}

/// The fixture's source PLY (written by numpy).
pub(crate) fn fixture_source() -> Gaussians {
    let (bytes, _) = fixture("source.ply");
    crate::io::ply::gaussians::parse_gaussians("source.ply", &bytes).unwrap()
}

/// Our decode of the rows the writing tool decoded, field by field, within
/// `tol(value)`; `flip` multiplies the tool's (x, y, z) (positions, the
/// quaternion's vector part) to bring it to our axes.
pub(crate) fn check_against_tool(g: &Gaussians, exp: &serde_json::Value, tol: f32) {
    let rows: Vec<usize> = exp["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as usize)
        .collect();
    assert_eq!(g.len() as u64, exp["n"].as_u64().unwrap());
    let f = |v: &serde_json::Value| v.as_f64().unwrap() as f32;
    let close = |a: f32, b: f32, what: &str, i: usize| {
        assert!(
            (a - b).abs() <= tol * (1.0 + b.abs()),
            "row {i} {what}: ours {a}, tool {b}"
        );
    };
    for (r, &i) in rows.iter().enumerate() {
        for a in 0..3 {
            close(g.means[i][a], f(&exp["means"][r][a]), "position", i);
            close(
                g.log_scales[i][a],
                f(&exp["log_scales"][r][a]),
                "log-scale",
                i,
            );
            close(g.sh_dc[i][a], f(&exp["sh_dc"][r][a]), "DC", i);
        }
        close(
            g.opacity_logits[i],
            f(&exp["opacity_logits"][r]),
            "opacity",
            i,
        );
        let q: [f32; 4] = std::array::from_fn(|a| f(&exp["rotations_wxyz"][r][a]));
        assert!(
            quat_angle(g.rotations[i], q) < 1e-3,
            "row {i}: {:?} vs {q:?}",
            g.rotations[i]
        );
        let k3 = g.rest_per_channel() * 3;
        for j in 0..k3 {
            close(
                g.sh_rest[i * k3 + j],
                f(&exp["sh_rest_coefficient_major"][r][j]),
                "SH rest",
                i,
            );
        }
    }
}

/// Files written by the official library (v4 zstd and v3 gzip, packed from
/// RDF): our decode equals its decode to RDF (same arithmetic, f32 rounding
/// only), so the axes agree, including Gaussian 0's known off-axis pose.
#[test]
fn official_library_files_decode_as_it_does() {
    let src = fixture_source();
    for name in ["adobe_v4.spz", "adobe_v3.spz"] {
        let (bytes, exp) = fixture(name);
        assert!(sniff(&bytes));
        let g = read(name, &bytes).unwrap();
        check_against_tool(&g, &exp, 1e-6);
        for a in 0..3 {
            assert!(
                (g.means[0][a] - [1.5, 2.25, -3.0][a]).abs() < 1.3e-4,
                "{:?}",
                g.means[0]
            );
        }
        assert!(quat_angle(g.rotations[0], src.rotations[0]) < 3e-3);
    }
}

/// Our writer packs exactly as the official library: the decompressed
/// streams of our SPZ of source.ply equal those of its version-4 file.
#[test]
fn writer_matches_the_official_packing() {
    let src = fixture_source();
    let ours = write("ours.spz", &src, false).unwrap();
    let (theirs, _) = fixture("adobe_v4.spz");
    let (a, b) = (
        parse_v4("ours", &ours).unwrap(),
        parse_v4("theirs", &theirs).unwrap(),
    );
    assert_eq!(a.fractional_bits, b.fractional_bits);
    assert_eq!(a.positions, b.positions);
    assert_eq!(a.alphas, b.alphas);
    assert_eq!(a.colors, b.colors);
    assert_eq!(a.scales, b.scales);
    assert_eq!(a.rotations, b.rotations);
    assert_eq!(a.sh, b.sh);
}

/// splat-transform writes SPZ without the axis conversion (PLY axes stored
/// where SPZ means RUB): our decode is its decode with y and z negated
/// (positions, quaternion y/z and the odd SH coefficients).
#[test]
fn splat_transform_spz_differs_by_the_axis_flip() {
    let (bytes, exp) = fixture("splat_transform.spz");
    let g = read("splat_transform.spz", &bytes).unwrap();
    let mut flipped = g.clone();
    let sh = sh_flips(1.0, -1.0, -1.0);
    for i in 0..g.len() {
        flipped.means[i][1] *= -1.0;
        flipped.means[i][2] *= -1.0;
        flipped.rotations[i][2] *= -1.0;
        flipped.rotations[i][3] *= -1.0;
        for j in 0..45 {
            flipped.sh_rest[i * 45 + j] *= sh[j / 3];
        }
    }
    check_against_tool(&flipped, &exp, 1e-6);
}
