use super::*;
use crate::io::splat::spz::tests::{quat_angle, random_gaussians};

/// `g` in the texel order the writer uses (the order a SOG reads back in).
fn in_texel_order(g: &Gaussians) -> Gaussians {
    let order: Vec<usize> = write::morton_order(&g.means)
        .into_iter()
        .map(|i| i as usize)
        .collect();
    g.gather(&order)
}

fn nearest_error(codebook: &[f32], v: f32) -> f32 {
    codebook
        .iter()
        .map(|c| (c - v).abs())
        .fold(f32::INFINITY, f32::min)
}

fn meta_of(bytes: &[u8]) -> serde_json::Value {
    let mut z = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
    let mut s = String::new();
    z.by_name("meta.json")
        .unwrap()
        .read_to_string(&mut s)
        .unwrap();
    serde_json::from_str(&s).unwrap()
}

fn codebook(meta: &serde_json::Value, key: &str) -> Vec<f32> {
    meta[key]["codebook"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() as f32)
        .collect()
}

/// write → read with n = 1024 (the palette then holds every SH vector, so
/// only its byte codebook quantises): every value within its step.
/// Positions: half a 16-bit step of the log-transformed range, mapped back
/// (|Δx| ≤ (|x|+1)·span/65535/2); rotations: 8 bits per component, half a
/// code is (1/255)/√2 per stored component, three of them plus the
/// renormalised largest give < 0.015 rad (0.0125 measured); opacity 0.5/255; log-scales, DC and SH rest: exactly the nearest
/// codebook entry.
#[test]
#[allow(clippy::needless_range_loop)]
fn round_trip_within_quantisation() {
    let g = random_gaussians(1024, 3, 50.0, 21);
    let bytes = write("rt.sog", &g, false).unwrap();
    assert!(sniff_zip(&bytes));
    let meta = meta_of(&bytes);
    assert_eq!(meta["version"], 2);
    assert_eq!(meta["count"], 1024);
    assert_eq!(meta["shN"]["count"], 1024);
    let h = read("rt.sog", &bytes, Path::new("/nonexistent")).unwrap();
    assert_eq!((h.len(), h.sh_degree), (1024, 3));
    let g = in_texel_order(&g);
    let (mins, maxs) = (&meta["means"]["mins"], &meta["means"]["maxs"]);
    let span: Vec<f32> = (0..3)
        .map(|a| (maxs[a].as_f64().unwrap() - mins[a].as_f64().unwrap()) as f32)
        .collect();
    let sc = codebook(&meta, "scales");
    let cc = codebook(&meta, "sh0");
    let rc = codebook(&meta, "shN");
    let mut worst = [0f32; 6];
    for i in 0..g.len() {
        for a in 0..3 {
            let x = g.means[i][a];
            let bound = (x.abs() + 1.0) * span[a] / 65535.0 * 0.5 * 1.001 + 1e-5;
            let e = (x - h.means[i][a]).abs();
            assert!(e <= bound, "Gaussian {i} axis {a}: {e} > {bound}");
            worst[0] = worst[0].max(e);
            let e = (g.log_scales[i][a] - h.log_scales[i][a]).abs();
            assert!((e - nearest_error(&sc, g.log_scales[i][a])).abs() < 1e-6);
            worst[1] = worst[1].max(e);
            let e = (g.sh_dc[i][a] - h.sh_dc[i][a]).abs();
            assert!((e - nearest_error(&cc, g.sh_dc[i][a])).abs() < 1e-6);
            worst[2] = worst[2].max(e);
        }
        worst[3] = worst[3].max((g.opacity(i) - h.opacity(i)).abs());
        worst[4] = worst[4].max(quat_angle(g.rotations[i], h.rotations[i]));
        for j in 0..45 {
            let (a, b) = (g.sh_rest[i * 45 + j], h.sh_rest[i * 45 + j]);
            assert!(((a - b).abs() - nearest_error(&rc, a)).abs() < 1e-6);
            worst[5] = worst[5].max((a - b).abs());
        }
    }
    eprintln!("SOG round trip worst errors (pos, log-scale, dc, alpha, rot rad, sh): {worst:?}");
    assert!(worst[3] <= 0.5 / 255.0 + 1e-6);
    assert!(worst[4] < 0.015);
    // 256-entry codebooks over these ranges: far below the range/256
    assert!(worst[1] < 10.0 / 256.0 && worst[2] < 4.0 / 256.0 && worst[5] < 1.8 / 256.0);
}

/// More Gaussians than palette entries: SH goes through k-means; the error
/// is bounded by the data's own spread and the rest is as before.
#[test]
fn clustered_sh_round_trip() {
    let mut g = random_gaussians(3000, 1, 5.0, 22);
    // SH made of 40 prototypes plus small noise: a palette of 2048 finds them
    let protos = random_gaussians(40, 1, 1.0, 23).sh_rest;
    for i in 0..g.len() {
        for j in 0..9 {
            g.sh_rest[i * 9 + j] = protos[(i % 40) * 9 + j] + ((i * 9 + j) % 7) as f32 * 1e-3;
        }
    }
    let bytes = write("c.sog", &g, false).unwrap();
    assert_eq!(meta_of(&bytes)["shN"]["count"], 2048);
    let h = read("c.sog", &bytes, Path::new(".")).unwrap();
    let g = in_texel_order(&g);
    let worst = g
        .sh_rest
        .iter()
        .zip(&h.sh_rest)
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    assert!(worst < 0.02, "worst SH error {worst}");
}

/// The unbundled form: meta.json with the images in a folder reads the same
/// as the bundle.
#[test]
fn reads_meta_json_with_folder() {
    let g = random_gaussians(100, 2, 3.0, 24);
    let bytes = write("b.sog", &g, true).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut z = zip::ZipArchive::new(std::io::Cursor::new(&bytes[..])).unwrap();
    z.extract(dir.path()).unwrap();
    let meta = std::fs::read(dir.path().join("meta.json")).unwrap();
    assert!(sniff_meta(&meta) && !sniff_zip(&meta) && !sniff_meta(&bytes));
    let a = read("meta.json", &meta, dir.path()).unwrap();
    let b = read("b.sog", &bytes, Path::new(".")).unwrap();
    assert_eq!(a, b);
    std::fs::remove_file(dir.path().join("quats.webp")).unwrap();
    let e = read("meta.json", &meta, dir.path())
        .unwrap_err()
        .to_string();
    assert!(e.contains("quats.webp"), "{e}");
}

/// lossy = false refuses what SOG cannot hold, naming the output, the
/// Gaussian and the value; lossy = true writes it.
#[test]
fn refuses_unless_lossy() {
    let base = random_gaussians(10, 0, 1.0, 25);
    let mut g = base.clone();
    g.log_scales[4][0] = f32::NEG_INFINITY;
    let e = write("o.sog", &g, false).unwrap_err().to_string();
    assert!(
        e.contains("o.sog") && e.contains("Gaussian 4") && e.contains("inf"),
        "{e}"
    );
    let h = read("o.sog", &write("o.sog", &g, true).unwrap(), Path::new(".")).unwrap();
    let t = write::morton_order(&g.means)
        .iter()
        .position(|&i| i == 4)
        .unwrap();
    assert!(h.log_scales[t][0] < -9.0 - 19.0, "{}", h.log_scales[t][0]);
    let mut g = base.clone();
    g.means[7][1] = f32::NAN;
    assert!(
        write("o.sog", &g, false)
            .unwrap_err()
            .to_string()
            .contains("Gaussian 7")
    );
    assert!(write("o.sog", &g, true).is_ok());
    let mut g = base.clone();
    g.normals = Some(vec![[0.0; 3]; 10]);
    assert!(write("o.sog", &g, false).is_ok());
    g.normals.as_mut().unwrap()[3] = [0.0, 1.0, 0.0];
    assert!(
        write("o.sog", &g, false)
            .unwrap_err()
            .to_string()
            .contains("Gaussian 3")
    );
    assert!(write("o.sog", &Gaussians::default(), true).is_err());
}

/// Broken bundles and metadata are errors, not panics or huge allocations.
#[test]
fn hostile_inputs_are_errors() {
    let g = random_gaussians(64, 1, 2.0, 26);
    let good = write("h.sog", &g, false).unwrap();
    let p = Path::new("/nonexistent");
    for cut in [0, 4, 100, good.len() / 2, good.len() - 1] {
        assert!(read("h.sog", &good[..cut], p).is_err(), "cut {cut}");
    }
    let dir = tempfile::tempdir().unwrap();
    let mut z = zip::ZipArchive::new(std::io::Cursor::new(&good[..])).unwrap();
    z.extract(dir.path()).unwrap();
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("meta.json")).unwrap()).unwrap();
    let try_meta = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut m = meta.clone();
        edit(&mut m);
        read("meta.json", &serde_json::to_vec(&m).unwrap(), dir.path())
            .unwrap_err()
            .to_string()
    };
    let e = try_meta(&|m| m["count"] = (1u64 << 40).into());
    assert!(e.contains("count"), "{e}");
    let e = try_meta(&|m| m["count"] = 100_000u64.into());
    assert!(e.contains("fewer than"), "{e}");
    let e = try_meta(&|m| m["quats"]["files"][0] = "../../etc/passwd".into());
    assert!(e.contains("plain relative"), "{e}");
    let e = try_meta(&|m| m["version"] = 7.into());
    assert!(e.contains("version 7"), "{e}");
    let e = try_meta(&|m| m["scales"]["codebook"] = serde_json::json!([1.0, 2.0]));
    assert!(e.contains("codebook"), "{e}");
    let e = try_meta(&|m| m["shN"]["bands"] = 5.into());
    assert!(e.contains("bands"), "{e}");
    let e = try_meta(&|m| {
        m.as_object_mut().unwrap().remove("means");
    });
    assert!(e.contains("means"), "{e}");
    // a corrupt image
    std::fs::write(dir.path().join("sh0.webp"), b"RIFF\x10\0\0\0WEBPVP8L").unwrap();
    let e = try_meta(&|_| {});
    assert!(e.contains("sh0.webp"), "{e}");
    assert!(!sniff_zip(b"PK\x03\x04garbage") && !sniff_meta(b"{\"a\": 1}"));
}

/// splat-transform's SOG of the fixture: our decode equals its decode bit
/// for bit (texel order; both do the arithmetic in f64 and round to f32
/// once; tolerance 0), and every Gaussian is
/// within splat-transform's quantisation of the source PLY's Gaussian at
/// the nearest position (it truncates: a full step per code).
#[test]
fn splat_transform_sog_decodes_as_it_does() {
    use crate::io::splat::spz::tests::{check_against_tool, fixture, fixture_source};
    let (bytes, exp) = fixture("splat_transform.sog");
    assert!(sniff_zip(&bytes));
    let g = read("splat_transform.sog", &bytes, Path::new(".")).unwrap();
    assert_eq!(g.sh_degree, 3);
    check_against_tool(&g, &exp, 0.0);
    let src = fixture_source();
    let mut worst = [0f32; 6];
    for i in 0..g.len() {
        let j = (0..src.len())
            .min_by(|&a, &b| {
                let d = |s: usize| {
                    (0..3)
                        .map(|x| (src.means[s][x] - g.means[i][x]).powi(2))
                        .sum::<f32>()
                };
                d(a).total_cmp(&d(b))
            })
            .unwrap();
        for a in 0..3 {
            worst[0] = worst[0].max((src.means[j][a] - g.means[i][a]).abs());
            worst[1] = worst[1].max((src.log_scales[j][a] - g.log_scales[i][a]).abs());
            worst[2] = worst[2].max((src.sh_dc[j][a] - g.sh_dc[i][a]).abs());
        }
        worst[3] = worst[3].max((src.opacity(j) - g.opacity(i)).abs());
        worst[4] = worst[4].max(quat_angle(src.rotations[j], g.rotations[i]));
        for k in 0..45 {
            worst[5] = worst[5].max((src.sh_rest[j * 45 + k] - g.sh_rest[i * 45 + k]).abs());
        }
    }
    eprintln!(
        "splat-transform SOG vs source worst (pos, log-scale, dc, alpha, rot, sh): {worst:?}"
    );
    // positions: (|x|+1)·span/65535 with |x| ≤ 3 and span ≈ 2.8 → 1.7e-4
    assert!(worst[0] < 2e-4);
    assert!(worst[1] < 0.05 && worst[2] < 0.03 && worst[5] < 0.01);
    assert!(worst[3] <= 1.0 / 255.0 + 1e-6);
    assert!(worst[4] < 0.03);
}

/// Our SOG of the fixture's source reads back within our own (rounded)
/// quantisation, and its layout matches splat-transform's bundle: the same
/// entry names and image sizes.
#[test]
fn our_bundle_has_splat_transforms_layout() {
    use crate::io::splat::spz::tests::{fixture, fixture_source};
    let src = fixture_source();
    let ours = write("ours.sog", &src, false).unwrap();
    let (theirs, _) = fixture("splat_transform.sog");
    let names = |b: &[u8]| {
        let z = zip::ZipArchive::new(std::io::Cursor::new(b.to_vec())).unwrap();
        let mut v: Vec<String> = z.file_names().flatten().map(|s| s.to_string()).collect();
        v.sort();
        v
    };
    assert_eq!(names(&ours), names(&theirs));
    let (mo, mt) = (meta_of(&ours), meta_of(&theirs));
    assert_eq!(mo["shN"]["count"], mt["shN"]["count"]);
    assert_eq!(mo["means"]["mins"].as_array().unwrap().len(), 3);
    let size = |b: &[u8], f: &str| {
        let mut z = zip::ZipArchive::new(std::io::Cursor::new(b.to_vec())).unwrap();
        let mut v = Vec::new();
        z.by_name(f).unwrap().read_to_end(&mut v).unwrap();
        let img = webp::decode(f, &v, 0, u64::MAX).unwrap();
        (img.width, img.height)
    };
    for f in [
        "means_l.webp",
        "quats.webp",
        "shN_centroids.webp",
        "shN_labels.webp",
    ] {
        assert_eq!(size(&ours, f), size(&theirs, f), "{f}");
    }
    let g = read("ours.sog", &ours, Path::new(".")).unwrap();
    assert_eq!(g.len(), src.len());
}
