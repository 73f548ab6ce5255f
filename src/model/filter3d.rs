//! The 3-D smoothing filter of Mip-Splatting and Gaussian Opacity Fields.
//!
//! Both save a per-Gaussian `filter_3D` value in their PLY (a world-space
//! standard deviation, ≥ 0, from the training cameras' sampling rate:
//! `compute_3D_filter`, distance / focal · √0.2). Their renderers never
//! draw the stored scales and opacity as they are: every Gaussian is
//! convolved with an isotropic 3-D Gaussian of that standard deviation f,
//! with its opacity scaled so that its integral is kept
//! (`get_scaling_with_3D_filter`, `get_opacity_with_3D_filter` of
//! `scene/gaussian_model.py`):
//!
//! - scales s'ᵢ = √(sᵢ² + f²), sᵢ = exp(stored log scale);
//! - opacity α' = α · √(Πᵢ sᵢ² / Πᵢ (sᵢ² + f²)), α = sigmoid(stored logit).
//!
//! Our reader keeps `filter_3D` as an extra property
//! ([`super::Extras::item`]); [`filter_3d`] reads and checks it and
//! [`bake_filter_3d`] turns such Gaussians into plain 3DGS values that any
//! 3DGS renderer draws the same way, as Mip-Splatting's `save_fused_ply`
//! (`create_fused_ply.py`) does. Their 2-D screen filter (the rasteriser's
//! `kernel_size`) is a separate thing: see
//! `splatkit_render::gaussian::Filter2d`.
//!
//! Arithmetic is f64 (the reference runs in f32 on the GPU); the ratio is
//! taken axis by axis, Πᵢ sᵢ/√(sᵢ² + f²), so that it does not underflow for
//! tiny scales where the reference's product of squares would reach 0 in
//! f32 (scales below about e⁻¹⁵): there the reference draws nothing, and
//! the baked opacity is the (tiny) true value instead.

use splatkit_render::gaussian::Filter2d;

use super::Gaussians;
use crate::Error;

/// The PLY property name Mip-Splatting and GOF write.
pub const FILTER_3D: &str = "filter_3D";

/// Whether `g` carries a `filter_3D` column (not checked: see
/// [`filter_3d`]).
pub fn has_filter_3d(g: &Gaussians) -> bool {
    g.extras.item.iter().any(|p| p.name == FILTER_3D)
}

/// The `filter_3D` value of every Gaussian (world units, a standard
/// deviation), or `None` when `g` has no such column. Any scalar type is
/// read (converted to f32; Mip-Splatting writes `float`).
///
/// Errors: a list property of that name, or a value that is NaN, infinite
/// or negative (the error names the Gaussian and the value).
pub fn filter_3d(g: &Gaussians) -> crate::Result<Option<Vec<f32>>> {
    let Some(p) = g.extras.item.iter().find(|p| p.name == FILTER_3D) else {
        return Ok(None);
    };
    let Some(col) = p.data.as_scalar() else {
        return Err(Error::invalid(format!(
            "{FILTER_3D} is a list property; Mip-Splatting writes one float per Gaussian"
        )));
    };
    if col.len() != g.len() {
        return Err(Error::invalid(format!(
            "{FILTER_3D} has {} values, expected {}",
            col.len(),
            g.len()
        )));
    }
    let v = col.to_f32();
    if let Some((i, x)) = v
        .iter()
        .enumerate()
        .find(|(_, x)| !(x.is_finite() && **x >= 0.0))
    {
        return Err(Error::invalid(format!(
            "Gaussian {i}: {FILTER_3D} is {x}, expected a finite value >= 0"
        )));
    }
    Ok(Some(v))
}

/// The 3-D filter of one Gaussian applied to its stored values: the log
/// scales of √(s² + f²) and the opacity logit of α·√(Π s² / Π (s² + f²)),
/// in f64. NaN in, NaN out; a zero scale gives opacity 0 (logit −∞), as the
/// reference's ratio does.
fn bake_one(log_scales: [f32; 3], logit: f32, f: f32) -> ([f32; 3], f32) {
    let f2 = f64::from(f) * f64::from(f);
    let mut coef = 1.0f64;
    let ls = log_scales.map(|v| {
        let s = f64::from(v).exp();
        let s2 = s * s + f2;
        coef *= if s2 > 0.0 { s / s2.sqrt() } else { 1.0 };
        (0.5 * s2.ln()) as f32
    });
    // α·coef with the sigmoid in f64 (in f32 it rounds to 1 above ~17);
    // then logit = ln(a / (1 − a)), the reference's inverse_sigmoid
    let a = coef / (1.0 + (-f64::from(logit)).exp());
    (ls, (a / (1.0 - a)).ln() as f32)
}

/// `g` with its `filter_3D` baked in: plain 3DGS Gaussians that a 3DGS
/// renderer draws with the effective scales and opacities of Mip-Splatting
/// and GOF (see the module docs), and the `filter_3D` column removed.
/// Everything else (means, rotations, SH, normals, other extra properties,
/// elements, comments) is kept. Gaussians without the column come back
/// unchanged.
///
/// Errors: as [`filter_3d`] (a bad column names the Gaussian).
pub fn bake_filter_3d(g: &Gaussians) -> crate::Result<Gaussians> {
    let Some(f) = filter_3d(g)? else {
        return Ok(g.clone());
    };
    let mut out = g.clone();
    out.extras.item.retain(|p| p.name != FILTER_3D);
    for (i, &fi) in f.iter().enumerate() {
        let (ls, logit) = bake_one(g.log_scales[i], g.opacity_logits[i], fi);
        out.log_scales[i] = ls;
        out.opacity_logits[i] = logit;
    }
    Ok(out)
}

/// `g` ready to render: [`bake_filter_3d`] when it carries `filter_3D`,
/// with `true` (the caller then picks the 2-D Mip filter by default);
/// `g` itself and `false` otherwise.
pub fn baked_for_rendering(g: Gaussians) -> crate::Result<(Gaussians, bool)> {
    if has_filter_3d(&g) {
        Ok((bake_filter_3d(&g)?, true))
    } else {
        Ok((g, false))
    }
}

/// An error when `g` carries `filter_3D`, for a command that would change
/// or carry the Gaussians on without it (`command` names it in the
/// message): the filter would be lost or left out of date. The caller adds
/// the file name ([`crate::Error::in_file`]).
pub fn refuse_filter_3d(g: &Gaussians, command: &str) -> crate::Result<()> {
    if has_filter_3d(g) {
        return Err(Error::invalid(format!(
            "has Mip-Splatting's {FILTER_3D} property, which {command} does not apply and would \
             lose; bake it into plain 3DGS values first (convert --bake-filter-3d)"
        )));
    }
    Ok(())
}

/// Which 2-D (screen) filter a command renders Gaussians with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter2dChoice {
    /// The Mip filter for Gaussians that carried `filter_3D` (Mip-Splatting
    /// / GOF models), 3DGS's dilation for the rest.
    Auto,
    /// 3DGS's 0.3 px² dilation.
    Dilate,
    /// The 2-D Mip filter.
    Mip,
}

/// Mip-Splatting's default `kernel_size` (pixels², `arguments/__init__.py`
/// and its scripts' `--kernel_size 0.1`). Gaussian Opacity Fields keeps
/// the same rasteriser with a default of 0.0.
pub const MIP_KERNEL_SIZE: f64 = 0.1;

/// The rasteriser's 2-D filter for `choice`, with `kernel_size` (pixels²)
/// for the Mip filter; `filtered` says whether the Gaussians carried
/// `filter_3D` (what [`Filter2dChoice::Auto`] goes by).
pub fn choose_filter_2d(choice: Filter2dChoice, kernel_size: f64, filtered: bool) -> Filter2d {
    match (choice, filtered) {
        (Filter2dChoice::Mip, _) | (Filter2dChoice::Auto, true) => Filter2d::Mip { kernel_size },
        _ => Filter2d::default(),
    }
}

/// How a report names `f`: `"dilate 0.3"` or `"mip 0.1"` (the value in
/// pixels²).
pub fn filter_2d_label(f: Filter2d) -> String {
    match f {
        Filter2d::Dilate(v) => format!("dilate {v}"),
        Filter2d::Mip { kernel_size } => format!("mip {kernel_size}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::gaussians::{logit, sigmoid};
    use crate::model::{Column, Property, ScalarData};

    fn with_filter(log_scales: Vec<[f32; 3]>, logits: Vec<f32>, f: ScalarData) -> Gaussians {
        let n = log_scales.len();
        let mut g = Gaussians {
            means: vec![[0.0; 3]; n],
            sh_degree: 0,
            sh_dc: vec![[0.1, 0.2, 0.3]; n],
            opacity_logits: logits,
            log_scales,
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
            ..Default::default()
        };
        g.extras.item.push(Property {
            name: "keep_me".into(),
            data: Column::Scalar(ScalarData::U8(vec![7; n])),
        });
        g.extras.item.push(Property {
            name: FILTER_3D.into(),
            data: Column::Scalar(f),
        });
        g
    }

    /// One hand-made Gaussian: s = (0.03, 0.04, 0.12), α = 0.8, f = 0.05.
    /// By hand: s' = (√0.0034, √0.0041, √0.0169) = (0.0583095, 0.0640312,
    /// 0.13); det ratio = (0.0009·0.0016·0.0144)/(0.0034·0.0041·0.0169) =
    /// 2.0736e-8 / 2.35586e-7 = 0.0880188…, √ = 0.2966796…, α' =
    /// 0.2373437…; the baked values match to f32 rounding (1e-6 relative).
    /// The extra column `keep_me` stays; `filter_3D` goes.
    #[test]
    fn bake_matches_the_hand_computed_values() {
        let s = [0.03f64, 0.04, 0.12];
        let g = with_filter(
            vec![s.map(|v| v.ln() as f32)],
            vec![logit(0.8)],
            ScalarData::F32(vec![0.05]),
        );
        let b = bake_filter_3d(&g).unwrap();
        let want_s = [0.0034f64.sqrt(), 0.0041f64.sqrt(), 0.13];
        for (ls, want) in b.log_scales[0].iter().zip(want_s) {
            let got = f64::from(*ls).exp();
            assert!((got - want).abs() < 1e-6 * want, "{got}");
        }
        let ratio: f64 = 0.0009 * 0.0016 * 0.0144 / (0.0034 * 0.0041 * 0.0169);
        let want_a = 0.8 * ratio.sqrt();
        assert!((want_a - 0.237_343_7).abs() < 1e-6);
        let got_a = f64::from(sigmoid(b.opacity_logits[0]));
        assert!((got_a - want_a).abs() < 1e-6, "{got_a} vs {want_a}");
        assert!(!has_filter_3d(&b));
        assert_eq!(b.extras.item.len(), 1);
        assert_eq!(b.extras.item[0].name, "keep_me");
        assert_eq!((b.means.clone(), b.sh_dc.clone()), (g.means, g.sh_dc));
    }

    /// f = 0 changes nothing (to rounding); a double column is read; no
    /// column: returned as is.
    #[test]
    fn zero_filter_and_other_types() {
        let g = with_filter(
            vec![[-3.0, -2.0, -4.5]],
            vec![1.5],
            ScalarData::F64(vec![0.0]),
        );
        let b = bake_filter_3d(&g).unwrap();
        for k in 0..3 {
            assert!((b.log_scales[0][k] - g.log_scales[0][k]).abs() < 1e-6);
        }
        assert!((b.opacity_logits[0] - 1.5).abs() < 1e-5);
        let mut plain = g.clone();
        plain.extras.item.clear();
        assert_eq!(bake_filter_3d(&plain).unwrap(), plain);
        assert_eq!(filter_3d(&plain).unwrap(), None);
        let (same, filtered) = baked_for_rendering(plain.clone()).unwrap();
        assert!(!filtered);
        assert_eq!(same, plain);
    }

    /// NaN, infinite and negative filters are errors naming the Gaussian.
    #[test]
    fn bad_filters_name_the_gaussian() {
        for bad in [f32::NAN, f32::INFINITY, -0.01] {
            let g = with_filter(
                vec![[-3.0; 3]; 3],
                vec![0.0; 3],
                ScalarData::F32(vec![0.1, 0.2, bad]),
            );
            let e = bake_filter_3d(&g).unwrap_err().to_string();
            assert!(e.contains("Gaussian 2") && e.contains(FILTER_3D), "{e}");
        }
    }

    /// A large stored logit (α rounds to 1 in f32) still gets a finite
    /// baked logit: ln(coef/(1 − coef)) in the limit.
    #[test]
    fn opaque_gaussians_stay_finite() {
        let g = with_filter(
            vec![[(0.01f64).ln() as f32; 3]],
            vec![40.0],
            ScalarData::F32(vec![0.01]),
        );
        let b = bake_filter_3d(&g).unwrap();
        let coef = 0.5f64.powf(1.5); // (s/√(2s²))³
        let want = (coef / (1.0 - coef)).ln();
        assert!((f64::from(b.opacity_logits[0]) - want).abs() < 1e-5);
    }
}
