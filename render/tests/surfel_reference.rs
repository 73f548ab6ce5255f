//! Test (c) of the surfel rasteriser: equality with an independent NumPy
//! re-implementation of 2DGS's CUDA forward rules
//! (`scripts/compare/surfel_reference.py`, which wrote
//! `tests/data/surfel_reference.txt`: 80 random surfels, SH degree 1, on a
//! 40×30 image from a rotated camera, background (0.1, 0.2, 0.3); NumPy
//! 2.4.6, Python 3.11.7, seed 0).
//!
//! Tolerances: colour within 2/255 and alpha within 1e-3 on every pixel;
//! expected and median depth within 1e-4 relative and the accumulated
//! normal within 1e-3 where α > 0.5. Both sides blend in f32 with the
//! kernel's operations, but they build T differently (the script: f32
//! through the NDC matrices, integer pixel centres; ours: f64 from the
//! intrinsics, centres at +0.5), so the rounding differs and a contribution
//! right at the 1/255 threshold may fall on either side: that moves a
//! colour by at most ~1/255.

use glam::{DMat3, DVec3};
use splatkit_render::Camera;
use splatkit_render::surfel::{SurfelSettings, Surfels2, rasterize};

struct Fixture {
    cam: Camera,
    settings: SurfelSettings,
    surfels: Surfels2,
    /// Per pixel: r g b alpha expected median nsum(3).
    pixels: Vec<[f64; 9]>,
}

fn parse() -> Fixture {
    let text = include_str!("data/surfel_reference.txt");
    let mut lines = text.lines();
    let mut nums = |key: &str| -> Vec<f64> {
        let line = lines.next().expect("line");
        let mut it = line.split_whitespace();
        assert_eq!(it.next(), Some(key), "{line}");
        it.map(|v| v.parse().expect("number")).collect()
    };
    let c = nums("camera");
    let r = nums("rotation");
    let t = nums("translation");
    let bg = nums("background");
    let sd = nums("surfels");
    let rot = DMat3::from_cols_array(&[r[0], r[3], r[6], r[1], r[4], r[7], r[2], r[5], r[8]]);
    let cam = Camera::pinhole(
        "ref",
        c[0] as u32,
        c[1] as u32,
        c[2],
        c[3],
        c[4],
        c[5],
        rot,
        DVec3::new(t[0], t[1], t[2]),
    );
    let (n, deg) = (sd[0] as usize, sd[1] as usize);
    let k = (deg + 1) * (deg + 1);
    let mut sf = Surfels2 {
        sh_degree: deg,
        ..Default::default()
    };
    for _ in 0..n {
        let v: Vec<f32> = lines
            .next()
            .expect("surfel line")
            .split_whitespace()
            .map(|v| v.parse().expect("number"))
            .collect();
        assert_eq!(v.len(), 10 + 3 * k);
        sf.means.push([v[0], v[1], v[2]]);
        sf.scales.push([v[3], v[4]]);
        sf.rotations.push([v[5], v[6], v[7], v[8]]);
        sf.opacities.push(v[9]);
        for j in 0..k {
            sf.sh.push([v[10 + 3 * j], v[11 + 3 * j], v[12 + 3 * j]]);
        }
    }
    assert_eq!(lines.next(), Some("pixels"));
    let pixels: Vec<[f64; 9]> = lines
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|v| v.parse().unwrap()).collect();
            v.try_into().expect("nine values")
        })
        .collect();
    assert_eq!(pixels.len(), (c[0] * c[1]) as usize);
    Fixture {
        cam,
        settings: SurfelSettings {
            background: [bg[0] as f32, bg[1] as f32, bg[2] as f32],
            ..Default::default()
        },
        surfels: sf,
        pixels,
    }
}

#[test]
fn surfel_forward_matches_the_numpy_reference() {
    let f = parse();
    let (img, _) = rasterize(&f.surfels, &f.cam, &f.settings);
    let w = f.cam.width as usize;
    let (mut opaque, mut worst_c, mut worst_d) = (0, 0.0f64, 0.0f64);
    for (o, want) in f.pixels.iter().enumerate() {
        let at = (o % w, o / w);
        for k in 0..3 {
            let e = (img.rgb[o][k] as f64 - want[k]).abs();
            worst_c = worst_c.max(e);
            assert!(e <= 2.0 / 255.0, "{at:?} rgb {:?} vs {want:?}", img.rgb[o]);
        }
        assert!((img.alpha[o] as f64 - want[3]).abs() < 1e-3, "{at:?} alpha");
        if want[3] > 0.5 {
            opaque += 1;
            for (name, got, r) in [
                ("expected", img.expected_depth[o], want[4]),
                ("median", img.median_depth[o], want[5]),
            ] {
                let e = (got as f64 - r).abs() / r;
                worst_d = worst_d.max(e);
                assert!(e < 1e-4, "{at:?} {name} depth {got} vs {r}");
            }
            for k in 0..3 {
                let e = (img.normal_sum[o][k] as f64 - want[6 + k]).abs();
                assert!(
                    e < 1e-3,
                    "{at:?} normal {:?} vs {want:?}",
                    img.normal_sum[o]
                );
            }
        }
    }
    assert!(opaque > 400, "only {opaque} pixels with alpha > 0.5");
    eprintln!("worst colour error {worst_c:.2e}, worst relative depth error {worst_d:.2e}");
}
