//! `convert`: round trips through every format it writes, the refusals of
//! what a format would clamp or drop, `--lossy` and its report, and
//! stdin/stdout.

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use rand::RngExt;
use serde_json::Value;
use splatkit::io::any::{load_gaussians, save_gaussians};
use splatkit::model::Gaussians;

/// `n` Gaussians of SH degree `degree` with values inside every format's
/// range (colour 0.5 + C0·dc within 0.1..0.9, SH rest within ±0.5).
fn scene(n: usize, degree: usize, seed: u64) -> Gaussians {
    let mut r = splatkit::model::rng::seeded(seed);
    let k = (degree + 1) * (degree + 1) - 1;
    let mut u = |lo: f32, hi: f32| lo + (hi - lo) * r.random::<f32>();
    let mut g = Gaussians {
        sh_degree: degree,
        ..Default::default()
    };
    for _ in 0..n {
        g.means.push([u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0)]);
        g.sh_dc.push([u(-1.4, 1.4), u(-1.4, 1.4), u(-1.4, 1.4)]);
        for _ in 0..3 * k {
            g.sh_rest.push(u(-0.5, 0.5));
        }
        g.opacity_logits.push(u(-3.0, 3.0));
        g.log_scales
            .push([u(-5.0, -2.0), u(-5.0, -2.0), u(-5.0, -2.0)]);
        g.rotations
            .push([u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0)]);
    }
    g
}

fn write(dir: &Path, name: &str, g: &Gaussians) -> PathBuf {
    let p = dir.join(name);
    save_gaussians(&p, g).unwrap();
    p
}

fn convert(args: &[&str]) -> std::process::Output {
    Command::cargo_bin("convert")
        .unwrap()
        .args(args)
        .output()
        .unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn ok(o: &std::process::Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn json(o: &std::process::Output) -> Value {
    ok(o);
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
}

/// PLY → each format → PLY: the report's errors are within each format's
/// quantisation (stated per format below), and converting the result back
/// to PLY and loading it gives what the report measured (the same count,
/// the same SH degree).
#[test]
fn round_trips_through_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let g = scene(600, 3, 1);
    let input = write(dir.path(), "in.ply", &g);
    // (extension, SH degree kept, bounds: position, colour, opacity, log
    // scale, rotation °, SH rest). compressed PLY: 11/10-bit positions over
    // a chunk of 256 Morton-sorted points (≤ 2/1023/2), colour 8 bits over
    // the chunk's range, opacity 8 bits (½/255), rotation 10 bits per
    // component (< 0.2°), SH 8 bits over ±4 (½·8/256 = 0.0157). .splat:
    // f32 position and scale (exact up to exp/ln), 8-bit colour/opacity
    // (½/255 rounded), rotation 1/128 per component (< 1°), SH dropped.
    // SPZ: 24-bit fixed-point positions (12 fractional bits: ½/4096),
    // colour dc·0.15·255 + 127.5 in 8 bits (½·C0/38.25 = 0.0037), opacity
    // ½/255, log scale (s + 10)·16 (½/16), smallest-three rotation, SH in
    // 5 bits (band 1) and 4 bits (bands 2–3) of x·128 + 128 (½·16/128, plus
    // the byte's own ½/128).
    // SOG: positions as 16 bits of a log-transformed coordinate over the
    // bounding box, DC / scale / SH rest through 256-entry codebooks (a
    // palette for SH), opacity 8 bits, smallest-three rotation 8 bits per
    // component. Measured on this scene (2026-11-26): position 2.0e-5,
    // colour 0.0021, opacity 0.0020 (½/255), log scale 0.0076, rotation
    // 0.81°, SH rest 0.57; the bounds are about 1.5–2× (opacity: the 8-bit
    // half step). The Morton reorder is undone by the report.
    // SH rest: splat-transform's palette has 1024·2^⌊log2(n/1024)⌋ = 512
    // entries for these 600 Gaussians, whose SH are independent random
    // values, so 88 of them take another's entry: up to the values' spread
    // (measured 0.57; the bound is that spread, 1.0).
    let cases: [(&str, u64, [f64; 6]); 4] = [
        ("sog", 3, [4e-5, 0.004, 0.5 / 255.0 + 1e-6, 0.015, 1.5, 1.0]),
        (
            "spz",
            3,
            [
                0.5 / 4096.0 + 1e-6,
                0.0038,
                0.5 / 255.0 + 1e-6,
                1.0 / 32.0 + 1e-6,
                0.5,
                0.0625 + 0.5 / 128.0 + 1e-6,
            ],
        ),
        (
            "compressed.ply",
            3,
            [
                2.0 / 1023.0 / 2.0,
                1.0 / 255.0,
                0.5 / 255.0 + 1e-6,
                3.0 / 1023.0,
                0.2,
                0.0157,
            ],
        ),
        (
            "splat",
            0,
            [0.0, 0.5 / 255.0 + 1e-7, 0.5 / 255.0 + 1e-6, 1e-6, 1.0, 0.5],
        ),
    ];
    for (ext, degree, bound) in cases {
        let out = dir.path().join(format!("out.{ext}"));
        let mut args = vec![s(&input), "-o", s(&out), "--json"];
        if ext == "splat" {
            // SH rest of degree 3 would be dropped: refused without --lossy
            let o = convert(&args);
            assert_eq!(o.status.code(), Some(1));
            assert!(!out.exists());
            args.push("--lossy");
        }
        let r = json(&convert(&args));
        assert_eq!(r["gaussians"], 600, "{ext}");
        assert_eq!(r["sh_degree_out"], degree, "{ext}");
        assert_eq!(
            r["bytes"].as_u64().unwrap(),
            std::fs::metadata(&out).unwrap().len()
        );
        let e = &r["error"];
        let got = [
            e["position"]["max"].as_f64().unwrap(),
            e["colour"]["max"].as_f64().unwrap(),
            e["opacity"]["max"].as_f64().unwrap(),
            e["log_scale"]["max"].as_f64().unwrap(),
            e["rotation_max_deg"].as_f64().unwrap(),
            e["sh_rest_max"].as_f64().unwrap(),
        ];
        eprintln!("{ext}: errors {got:?}");
        for (j, (got, want)) in got.iter().zip(bound).enumerate() {
            assert!(got <= &want, "{ext}: error {j} = {got} > {want}");
        }
        // an honest quantiser leaves some error
        assert!(got[1] > 0.0, "{ext}: colour error is 0");
        let back = dir.path().join(format!("back-{ext}.ply"));
        ok(&convert(&[s(&out), "-o", s(&back)]));
        let b = load_gaussians(&back, "test").unwrap();
        assert_eq!((b.len(), b.sh_degree as u64), (600, degree));
    }
    // PLY → PLY keeps every value
    let out = dir.path().join("same.ply");
    let r = json(&convert(&[s(&input), "-o", s(&out), "--json"]));
    assert_eq!(r["error"]["position"]["max"], 0.0);
    assert_eq!(
        load_gaussians(&out, "t").unwrap(),
        load_gaussians(&input, "t").unwrap()
    );
}

/// What a format would clamp or drop is refused (exit 1, the output not
/// written, a message naming the output, the Gaussian and the value), and
/// `--lossy` writes it and reports the loss.
#[test]
fn refusals_name_the_gaussian_and_lossy_writes() {
    let dir = tempfile::tempdir().unwrap();
    let mut g = scene(20, 0, 2);
    g.sh_dc[7][1] = 3.0; // colour 0.5 + C0·3 = 1.35: clamped by .splat
    let input = write(dir.path(), "bright.ply", &g);
    let out = dir.path().join("o.splat");
    let o = convert(&[s(&input), "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("o.splat") && err.contains("Gaussian 7 has f_dc_1 = 3"),
        "{err}"
    );
    assert!(err.contains("--lossy"), "{err}");
    assert!(!out.exists());
    let r = json(&convert(&[s(&input), "-o", s(&out), "--lossy", "--json"]));
    let c = r["error"]["colour"]["max"].as_f64().unwrap();
    assert!((c - (0.5 + 0.282_094_79 * 3.0 - 1.0)).abs() < 3e-3, "{c}");
    // the compressed PLY holds that colour (per-chunk bounds) but not a
    // log scale beyond ±20
    let cp = dir.path().join("o.compressed.ply");
    ok(&convert(&[s(&input), "-o", s(&cp)]));
    g.log_scales[3][2] = 25.0;
    let input = write(dir.path(), "big.ply", &g);
    let o = convert(&[s(&input), "-o", s(&cp)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("Gaussian 3 has scale_2 = 25"));
    // non-finite values
    let mut h = scene(5, 0, 3);
    h.opacity_logits[4] = f32::NAN;
    let input = write(dir.path(), "nan.ply", &h);
    let o = convert(&[s(&input), "-o", s(&cp)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("Gaussian 4 has opacity = NaN"));
    // normals that are not zero, and extra properties
    let mut h = scene(5, 0, 4);
    h.normals = Some(vec![[0.0, 0.0, 1.0]; 5]);
    let input = write(dir.path(), "normals.ply", &h);
    let o = convert(&[s(&input), "-o", s(&cp)]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("Gaussian 0 has normal"));
    let mut h = scene(5, 0, 5);
    h.extras.item.push(splatkit::model::Property {
        name: "filter_3D".into(),
        data: splatkit::model::Column::Scalar(splatkit::model::ScalarData::F32(vec![0.25; 5])),
    });
    let input = write(dir.path(), "filter.ply", &h);
    let o = convert(&[s(&input), "-o", s(&cp)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("filter_3D") && err.contains("0.25"), "{err}");
    // ... which a PLY keeps
    ok(&convert(&[s(&input), "-o", s(&dir.path().join("f.ply"))]));
}

/// `-` for stdin and stdout; a `.splat` on stdin needs --input-format;
/// stdout needs --format.
#[test]
fn stdin_and_stdout() {
    let dir = tempfile::tempdir().unwrap();
    let g = scene(50, 0, 6);
    let input = write(dir.path(), "in.ply", &g);
    let o = Command::cargo_bin("convert")
        .unwrap()
        .args(["-", "--format", "splat", "-o", "-"])
        .pipe_stdin(&input)
        .unwrap()
        .output()
        .unwrap();
    ok(&o);
    assert_eq!(o.stdout.len(), 50 * 32);
    let splat = dir.path().join("in.splat");
    std::fs::write(&splat, &o.stdout).unwrap();
    let o = Command::cargo_bin("convert")
        .unwrap()
        .args([
            "-",
            "--input-format",
            "splat",
            "--format",
            "compressed-ply",
            "-o",
            "-",
        ])
        .pipe_stdin(&splat)
        .unwrap()
        .output()
        .unwrap();
    ok(&o);
    assert!(o.stdout.starts_with(b"ply\n"));
    // no --format for stdout: usage error
    let o = convert(&[s(&input), "-o", "-"]);
    assert_eq!(o.status.code(), Some(2));
    // unknown output extension: usage error naming --format
    let o = convert(&[s(&input), "-o", s(&dir.path().join("x.obj"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--format"));
    // --json to stdout while the data goes there too: refused
    let o = convert(&[s(&input), "--format", "ply", "-o", "-", "--json"]);
    assert!(!o.status.success());
    assert!(o.stdout.is_empty());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--json=FILE"));
}

/// `info` and the other commands read the new formats through the one
/// loader.
#[test]
fn info_reads_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let g = scene(300, 1, 7);
    let input = write(dir.path(), "in.ply", &g);
    for (ext, kind, degree) in [
        ("compressed.ply", "gaussians-compressed", 1),
        ("splat", "gaussians", 0),
        ("spz", "gaussians", 1),
        ("sog", "gaussians", 1),
    ] {
        let out = dir.path().join(format!("x.{ext}"));
        ok(&convert(&[s(&input), "-o", s(&out), "--lossy"]));
        let o = Command::cargo_bin("info")
            .unwrap()
            .args([s(&out), "--json"])
            .output()
            .unwrap();
        let v = json(&o);
        let v = if v.is_array() { v[0].clone() } else { v };
        assert_eq!(v["kind"], kind, "{v}");
        assert_eq!(v["gaussians"], 300, "{v}");
        assert_eq!(v["sh_degree"], degree, "{v}");
    }
}
