//! The 2-D Mip filter of the Gaussian rasteriser (`Filter2d::Mip`) against
//! the reference images of `scripts/compare/mip_filter_reference.py`, a
//! NumPy float32 transcription of the Mip-Splatting / GOF CUDA rasteriser's
//! rules (`testdata/render/mip_filter_reference.json`, 14 Gaussians from
//! sub-pixel, not drawn at all, to several pixels wide; kernel sizes 0.1,
//! Mip-Splatting's default, and 0.0, GOF's).

use glam::{DMat3, DVec3};
use serde_json::Value;
use splatkit::model::Camera;
use splatkit_render::gaussian::{Filter2d, Gaussians3, RasterSettings, render};

fn fixture() -> Value {
    let p = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/testdata/render/mip_filter_reference.json"
    );
    serde_json::from_str(&std::fs::read_to_string(p).expect("fixture")).expect("json")
}

fn f32s(v: &Value) -> Vec<f32> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number") as f32)
        .collect()
}

fn rows<const N: usize>(v: &Value) -> Vec<[f32; N]> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|r| {
            let r = f32s(r);
            std::array::from_fn(|k| r[k])
        })
        .collect()
}

fn scene(doc: &Value) -> (Gaussians3, Camera, [f32; 3]) {
    let g = &doc["gaussians"];
    let gs = Gaussians3 {
        means: rows::<3>(&g["means"]),
        scales: rows::<3>(&g["scales"]),
        rotations: rows::<4>(&g["rotations"]),
        opacities: f32s(&g["opacities"]),
        sh: rows::<3>(&g["sh_dc"]),
        sh_degree: 0,
    };
    let c = &doc["camera"];
    let num = |k: &str| c[k].as_f64().expect("number");
    let cam = Camera::pinhole(
        "ref",
        num("width") as u32,
        num("height") as u32,
        num("fx"),
        num("fy"),
        num("cx"),
        num("cy"),
        DMat3::IDENTITY,
        DVec3::ZERO,
    );
    let bg = f32s(&doc["background"]);
    (gs, cam, [bg[0], bg[1], bg[2]])
}

/// Every pixel's RGB and alpha within 1e-4 of the reference, for both
/// kernel sizes. The reference runs the projection in f32 like the CUDA
/// kernel, ours in f64 (rounded to f32 for the pixel loop), and the
/// reference was printed with 7 significant digits: differences of a few
/// 1e-6 are expected; 1e-4 leaves a margin and is still 40 times below
/// the smallest contribution a pixel can take (1/255). The render under
/// 3DGS's 0.3 dilation must differ from it by more than 0.02 somewhere
/// (the test can tell the filters apart).
#[test]
fn mip_filter_matches_the_numpy_reference() {
    let doc = fixture();
    let (g, cam, bg) = scene(&doc);
    for r in doc["renders"].as_array().expect("renders") {
        let k = r["kernel_size"].as_f64().expect("kernel_size");
        let (want_rgb, want_a) = (f32s(&r["rgb"]), f32s(&r["alpha"]));
        let s = RasterSettings {
            background: bg,
            filter_2d: Filter2d::Mip { kernel_size: k },
            ..Default::default()
        };
        let img = render(&g, &cam, &s);
        assert_eq!(img.alpha.len(), want_a.len());
        let mut worst = 0.0f32;
        for (i, (&a, &w)) in img.alpha.iter().zip(&want_a).enumerate() {
            worst = worst.max((a - w).abs());
            for c in 0..3 {
                worst = worst.max((img.rgb[i][c] - want_rgb[3 * i + c]).abs());
            }
        }
        assert!(worst < 1e-4, "kernel {k}: worst difference {worst}");
        let dilate = render(
            &g,
            &cam,
            &RasterSettings {
                background: bg,
                ..Default::default()
            },
        );
        let apart = dilate
            .alpha
            .iter()
            .zip(&want_a)
            .fold(0.0f32, |m, (a, w)| m.max((a - w).abs()));
        assert!(apart > 0.02, "kernel {k}: dilation differs by {apart} only");
    }
}
