//! antimatter15 `.splat` ↔ [`Gaussians`].
//!
//! No header: the file is N records of 32 bytes, little-endian:
//! `f32 x y z`, `f32 sx sy sz` (linear standard deviations, exp of the 3DGS
//! log scale), `u8 r g b a` (r = 0.5 + C0·f_dc_0 …, a = sigmoid(opacity),
//! each ·255), `u8 q0 q1 q2 q3` (the normalised quaternion in 3DGS order
//! w, x, y, z, each as q·128 + 128, clamped to 0..255). It has no magic
//! bytes, so a `.splat` is recognised by its extension and a length that is
//! a multiple of 32; through stdin it needs `--format splat` where a command
//! offers it.
//!
//! Reading follows splat-transform's `read-splat.ts` for colour
//! ((u/255 − 0.5)/C0), scale (ln) and opacity (logit of u/255 clamped to
//! 1e−6..1−1e−6), and antimatter15's viewer (`main.js`) for the rotation,
//! (u − 128)/128 (splat-transform uses u/255·2 − 1; both are normalised
//! before use). The rotation is kept as decoded (unnormalised, as 3DGS
//! stores quaternions).
//!
//! Writing follows antimatter15's viewer export (`main.js`, through a
//! `Uint8ClampedArray`): bytes are rounded to nearest (ties to even) and
//! clamped; `convert.py` and splat-transform truncate instead, which biases
//! every colour down by half a step. The exporters also sort by
//! exp(Σ log scale)·sigmoid(opacity), largest first; splatkit keeps the
//! input order (the viewer sorts by depth itself). SH above degree 0 and
//! normals are not stored.

use super::{Capacity, SH_C0, check_lossless, sigmoid64};
use crate::model::Gaussians;
use crate::{Error, Result};

/// Bytes per record.
pub const RECORD: usize = 32;

/// What `.splat` holds without clamping or dropping: colour in 0..1, no SH
/// above the DC term, scales whose exp is a finite non-zero f32.
pub const CAPACITY: Capacity = Capacity {
    format: ".splat",
    sh_degree: 0,
    colour: Some((0.0, 1.0)),
    log_scale: Some((-87.0, 88.0)),
    sh_rest: None,
};

/// A `.splat` has no header: only its length (a multiple of 32) can be
/// checked.
pub fn sniff(bytes: &[u8]) -> bool {
    bytes.len().is_multiple_of(RECORD)
}

/// Parses a `.splat` (`name` for errors). SH degree 0, no normals.
pub fn read(name: &str, bytes: &[u8]) -> Result<Gaussians> {
    if !bytes.len().is_multiple_of(RECORD) {
        return Err(Error::format(
            name,
            format!(
                "a .splat is a sequence of 32-byte records, and this file has {} bytes \
                 ({} left over after record {})",
                bytes.len(),
                bytes.len() % RECORD,
                bytes.len() / RECORD
            ),
        ));
    }
    let n = bytes.len() / RECORD;
    crate::io::budget::check(
        &format!("{name}: {n} Gaussians"),
        (n as u64).saturating_mul(60),
    )?;
    let mut g = Gaussians {
        means: Vec::with_capacity(n),
        sh_dc: Vec::with_capacity(n),
        opacity_logits: Vec::with_capacity(n),
        log_scales: Vec::with_capacity(n),
        rotations: Vec::with_capacity(n),
        ..Default::default()
    };
    let f = |r: &[u8], o: usize| f32::from_le_bytes(r[o..o + 4].try_into().expect("4 bytes"));
    for r in bytes.chunks_exact(RECORD) {
        g.means.push([f(r, 0), f(r, 4), f(r, 8)]);
        g.log_scales
            .push([12, 16, 20].map(|o| (f(r, o) as f64).ln() as f32));
        g.sh_dc
            .push([24, 25, 26].map(|o| ((r[o] as f64 / 255.0 - 0.5) / SH_C0) as f32));
        let a = (r[27] as f64 / 255.0).clamp(1e-6, 1.0 - 1e-6);
        g.opacity_logits.push((a / (1.0 - a)).ln() as f32);
        g.rotations
            .push([28, 29, 30, 31].map(|o| (r[o] as f32 - 128.0) / 128.0));
    }
    Ok(g)
}

#[inline]
fn byte(v: f64) -> u8 {
    // Uint8ClampedArray: clamp, then round half to even; NaN → 0
    if v.is_nan() {
        0
    } else {
        v.clamp(0.0, 255.0).round_ties_even() as u8
    }
}

/// Encodes `g` as `.splat` records in input order. Unless `lossy`, refuses
/// what the format would clamp or drop ([`CAPACITY`]); `name` is the
/// output, for errors. A zero quaternion is written as the identity.
pub fn write(name: &str, g: &Gaussians, lossy: bool) -> Result<Vec<u8>> {
    g.validate()
        .map_err(|e| Error::invalid(format!("{name}: cannot write Gaussians: {e}")))?;
    if !lossy {
        check_lossless(name, g, &CAPACITY)?;
    }
    crate::io::budget::check(
        &format!("{name}: the .splat output"),
        (g.len() as u64).saturating_mul(RECORD as u64),
    )?;
    let mut out = Vec::with_capacity(g.len() * RECORD);
    for i in 0..g.len() {
        for v in g.means[i] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in g.log_scales[i] {
            out.extend_from_slice(&((v as f64).exp() as f32).to_le_bytes());
        }
        for d in g.sh_dc[i] {
            out.push(byte((0.5 + SH_C0 * d as f64) * 255.0));
        }
        out.push(byte(sigmoid64(g.opacity_logits[i]) * 255.0));
        let q = g.rotations[i].map(|v| v as f64);
        let len = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        let q = if len > 0.0 && len.is_finite() {
            q.map(|v| v / len)
        } else {
            [1.0, 0.0, 0.0, 0.0]
        };
        for v in q {
            out.push(byte(v * 128.0 + 128.0));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One record built by hand from the layout.
    #[test]
    fn decodes_a_hand_made_record() {
        let mut r = Vec::new();
        for v in [1.0f32, -2.0, 3.5, 1.0, 0.5, 2.0] {
            r.extend_from_slice(&v.to_le_bytes());
        }
        r.extend_from_slice(&[255, 0, 128, 255, 255, 128, 128, 0]);
        let g = read("a.splat", &r).unwrap();
        assert_eq!(g.means[0], [1.0, -2.0, 3.5]);
        assert_eq!(g.log_scales[0], [0.0, 0.5f32.ln(), 2.0f32.ln()]);
        assert!((g.sh_dc[0][0] as f64 - 0.5 / SH_C0).abs() < 1e-6);
        assert!((g.sh_dc[0][1] as f64 + 0.5 / SH_C0).abs() < 1e-6);
        assert!((g.opacity(0) - (1.0 - 1e-6)).abs() < 1e-6);
        assert_eq!(g.rotations[0], [127.0 / 128.0, 0.0, 0.0, -1.0]);
        let e = read("a.splat", &r[..31]).unwrap_err().to_string();
        assert!(e.starts_with("a.splat: ") && e.contains("31 bytes"), "{e}");
    }

    /// Write then read: positions exact, scales to f32 exp/ln precision,
    /// colour and opacity within half a step of 1/255, rotation within the
    /// 1/128 step.
    #[test]
    fn round_trip() {
        let mut g = super::super::compressed_ply::tests::random_gaussians(200, 0, 9);
        g.sh_dc.iter_mut().flatten().for_each(|d| *d *= 0.9);
        let bytes = write("t.splat", &g, false).unwrap();
        assert_eq!(bytes.len(), 200 * 32);
        let b = read("t.splat", &bytes).unwrap();
        assert_eq!(b.means, g.means);
        for i in 0..200 {
            for a in 0..3 {
                assert!((b.log_scales[i][a] - g.log_scales[i][a]).abs() < 1e-6);
                let c = |d: f32| 0.5 + SH_C0 * d as f64;
                assert!((c(b.sh_dc[i][a]) - c(g.sh_dc[i][a])).abs() <= 0.5 / 255.0 + 1e-7);
            }
            assert!((b.opacity(i) - g.opacity(i)).abs() <= 0.5 / 255.0 + 1e-6);
            let angle = 2.0 * g.quat(i).dot(b.quat(i)).abs().min(1.0).acos().to_degrees();
            assert!(angle < 1.0, "{i}: {angle}");
        }
    }

    #[test]
    fn refuses_clamped_colour_and_dropped_sh() {
        let mut g = super::super::compressed_ply::tests::random_gaussians(5, 1, 3);
        let e = write("o.splat", &g, false).unwrap_err().to_string();
        assert!(
            e.contains("Gaussian 0 has f_rest_") && e.contains("SH degree 1"),
            "{e}"
        );
        g.sh_rest.iter_mut().for_each(|v| *v = 0.0);
        g.sh_dc[0] = [0.0; 3];
        g.sh_dc[3][2] = 2.0;
        let e = write("o.splat", &g, false).unwrap_err().to_string();
        assert!(e.contains("Gaussian 3 has f_dc_2 = 2"), "{e}");
        let w = write("o.splat", &g, true).unwrap();
        assert_eq!(w[3 * 32 + 26], 255);
    }
}
