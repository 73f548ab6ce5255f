//! Gaussian-splat formats on real files (the shared data sets; skipped with
//! a reason when absent): SuperSplat compressed PLYs against the graphdeco
//! PLYs decoded from them when the data set was assembled (see their
//! SOURCE.md), value by value and rendered; antimatter15 `.splat` against
//! its exporter's rules.

use splatkit::io::any;
use splatkit::model::Gaussians;
use splatkit::testing::shared_data;

fn load(rel: &str) -> Option<Gaussians> {
    let p = shared_data(rel)?;
    Some(any::load_gaussians(&p, "test").unwrap_or_else(|e| panic!("{rel}: {e}")))
}

/// Largest |a − b| over a field, with the Gaussian where it happens.
fn max_abs(a: &[f32], b: &[f32]) -> (f32, usize) {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .enumerate()
        .map(|(i, (x, y))| ((x - y).abs(), i))
        .fold((0.0, 0), |m, x| if x.0 > m.0 { x } else { m })
}

/// The compressed file and its graphdeco decode hold the same values: the
/// decode was made with the engine's formulas (f64 arithmetic, stored as
/// f32, opacity ±40 at α = 0 and 1), which our reader follows, so every
/// value must be equal bit for bit (far below one quantisation step:
/// positions ≥ 4.9e-4 per chunk range, colours 1/255 of a chunk range).
fn compare_with_decode(compressed: &str, decoded: &str, n: usize) {
    let (Some(c), Some(d)) = (load(compressed), load(decoded)) else {
        eprintln!("skipped: {compressed} or {decoded} is not in the shared data");
        return;
    };
    assert_eq!((c.len(), d.len()), (n, n));
    assert_eq!((c.sh_degree, d.sh_degree), (0, 0));
    let fields: [(&str, &[f32], &[f32], f32); 5] = [
        (
            "position",
            c.means.as_flattened(),
            d.means.as_flattened(),
            0.0,
        ),
        (
            "log-scale",
            c.log_scales.as_flattened(),
            d.log_scales.as_flattened(),
            0.0,
        ),
        (
            "rotation",
            c.rotations.as_flattened(),
            d.rotations.as_flattened(),
            0.0,
        ),
        ("f_dc", c.sh_dc.as_flattened(), d.sh_dc.as_flattened(), 0.0),
        ("opacity", &c.opacity_logits, &d.opacity_logits, 0.0),
    ];
    for (what, a, b, tol) in fields {
        let (m, i) = max_abs(a, b);
        eprintln!("{compressed}: {what} max |ours − decoded| = {m:e} (value {i})");
        assert!(
            m <= tol,
            "{what}: {m} at {i} (ours {}, decoded {})",
            a[i],
            b[i]
        );
    }
}

#[test]
fn biker_compressed_ply_matches_its_decode() {
    compare_with_decode(
        "3dgs-playcanvas-biker/biker.compressed.ply",
        "3dgs-playcanvas-biker/biker.decoded_sh0.ply",
        152_746,
    );
}

#[test]
fn guitar_compressed_ply_matches_its_decode() {
    compare_with_decode(
        "3dgs-playcanvas-guitar/guitar.compressed.ply",
        "3dgs-playcanvas-guitar/guitar.decoded_sh0.ply",
        90_854,
    );
}

/// Renders `a` and `b` (shared-data paths) with our rasteriser (as `render`
/// does, black background) from six orbit cameras around `b` (up = −y, as
/// the biker is stored) and asserts PSNR ≥ `min_db` per view.
fn renders_alike(a: &str, b: &str, min_db: f64) {
    use splatkit::geom::scenes::orbit::orbit_rings;
    use splatkit::model::OrbitSpec;
    use splatkit_render::gaussian::{RasterSettings, render};
    let (Some(c), Some(d)) = (load(a), load(b)) else {
        eprintln!("skipped: the biker data set is not in the shared data");
        return;
    };
    let spec = OrbitSpec {
        views_per_ring: 3,
        width: 160,
        height: 120,
        fov_deg: 50.0,
        elevations_deg: vec![15.0, -30.0],
        radius: None,
        up: glam::DVec3::new(0.0, -1.0, 0.0),
    };
    let cams = orbit_rings(&d.means, &spec).unwrap();
    let (rc, rd) = (c.to_raster(), d.to_raster());
    let s = RasterSettings::default();
    for (v, cam) in cams.iter().enumerate() {
        let (x, y) = (render(&rc, cam, &s), render(&rd, cam, &s));
        let covered = y.alpha.iter().filter(|&&x| x > 0.5).count();
        assert!(
            covered > 160 * 120 / 20,
            "view {v} sees little of the scene"
        );
        let p = splatkit_render::loss::psnr(&x.rgb, &y.rgb);
        eprintln!("{a} view {v}: PSNR {p:.1} dB ({covered} covered pixels)");
        assert!(p >= min_db, "{a} view {v}: PSNR {p} dB < {min_db}");
    }
}

/// The compressed PLY and its decode give the same images: PSNR ≥ 50 dB
/// per view (both hold the same quantised values; what differs is f32
/// rounding).
#[test]
fn biker_compressed_ply_renders_like_its_decode() {
    renders_alike(
        "3dgs-playcanvas-biker/biker.compressed.ply",
        "3dgs-playcanvas-biker/biker.decoded_sh0.ply",
        50.0,
    );
}

/// biker.spz is the same capture quantised again by SPZ's rules (24-bit
/// positions, 8-bit colour, opacity, log scale and rotation), so it renders
/// close to, not equal to, the decoded PLY: PSNR ≥ 57 dB per view (measured
/// on 2026-11-26: 60.3–64.9 dB; the bound is the lowest view less 3 dB).
#[test]
fn biker_spz_renders_like_the_decoded_ply() {
    renders_alike(
        "3dgs-playcanvas-biker/biker.spz",
        "3dgs-playcanvas-biker/biker.decoded_sh0.ply",
        57.0,
    );
}

/// The kacytran `.splat` (22,764 records; an export of another iteration
/// than the PLY beside it, so not matched record by record) is in the order
/// of antimatter15's viewer export: exp(Σ log scale)·α largest first, with
/// α rounded to 8 bits (the viewer's Uint8ClampedArray). Read with our
/// reader, each key lies within ±½/255 of α of the stored one, so the
/// sequence may not rise by more than that interval allows; with truncated
/// bytes (convert.py) 2,380 steps would rise too far, with rounding none.
#[test]
fn kacytran_splat_follows_the_viewer_export_order() {
    let Some(g) = load("3dgs-kacytran-iter7000/model.splat") else {
        eprintln!("skipped: the kacytran data set is not in the shared data");
        return;
    };
    assert_eq!((g.len(), g.sh_degree), (22_764, 0));
    let bounds = |i: usize| {
        let v: f64 = g.log_scales[i].iter().map(|&s| s as f64).sum::<f64>().exp();
        let a = (g.opacity(i) as f64 * 255.0).round() / 255.0;
        (v * (a - 0.5 / 255.0), v * (a + 0.5 / 255.0))
    };
    let rises = (1..g.len())
        .filter(|&i| bounds(i).0 > bounds(i - 1).1 * (1.0 + 1e-6))
        .count();
    assert_eq!(rises, 0);
    // quaternions are unit length to the byte step
    for i in 0..g.len() {
        let n: f32 = g.rotations[i].iter().map(|x| x * x).sum::<f32>().sqrt();
        assert!((n - 1.0).abs() < 0.02, "record {i}: |q| = {n}");
    }
}
