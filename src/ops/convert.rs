//! `convert`: Gaussian splats from any format splatkit reads to any format
//! it writes ([`crate::io::splat::SplatFormat`]), refusing what the target
//! would clamp or drop unless `--lossy`, and reporting the error the target
//! introduces by reading back the bytes it wrote.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde_json::json;

use crate::cli::{Common, declare_inputs, shown, usage};
use crate::eval::splat_error::{SplatError, splat_error};
use crate::io::any;
use crate::io::splat::{self, SplatFormat};
use crate::io::{read_input, write_output};
use crate::model::{Gaussians, Scene, SceneKind};

/// Arguments of `convert`.
#[derive(Args, Debug, Clone)]
#[command(
    after_help = "Formats (--format / --input-format names and output extensions):
  ply             .ply             graphdeco 3DGS PLY (keeps everything)
  compressed-ply  .compressed.ply  SuperSplat / PlayCanvas compressed PLY
                                   (SH up to degree 3)
  spz             .spz             Niantic SPZ version 4 (SH up to degree 3;
                                   reads versions 1-4)
  splat           .splat           antimatter15 .splat (no SH above DC,
                                   colour clamped to 0..1)
  ksplat          .ksplat          GaussianSplats3D KSPLAT (read only)
The input format is detected from the content, then the extension; a .splat
has no header, so through stdin it needs --input-format splat.

Examples:
  # refuses values it would clamp
  convert scene.ply -o scene.compressed.ply
  convert scene.ply -o scene.splat --lossy --json=err.json
  convert scene.spz -o scene.compressed.ply
  # decompress
  convert scene.compressed.ply -o scene.ply
  cat scene.splat | convert - --input-format splat --format ply -o - \\
      > scene.ply"
)]
pub struct ConvertArgs {
    /// Input Gaussians (any format splatkit reads); `-` = stdin.
    pub input: PathBuf,
    /// Output file; `-` = stdout (then --format is required).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output format (default: from the output's extension).
    #[arg(long, value_parser = parse_format)]
    pub format: Option<SplatFormat>,
    /// Input format, for inputs the content does not tell (a `.splat` on
    /// stdin).
    #[arg(long, value_parser = parse_format)]
    pub input_format: Option<SplatFormat>,
    /// Write even when the target format clamps or drops values (SH above
    /// its degree, values out of its range, normals, extra properties,
    /// non-finite values); the report says how much was lost.
    #[arg(long)]
    pub lossy: bool,
    /// Bake a Mip-Splatting / GOF `filter_3D` property into plain 3DGS
    /// scales and opacities (`get_scaling_with_3D_filter`,
    /// `get_opacity_with_3D_filter`) and drop the column; the errors are
    /// then measured against the baked values.
    #[arg(long)]
    pub bake_filter_3d: bool,
    #[command(flatten)]
    pub common: Common,
}

fn parse_format(s: &str) -> Result<SplatFormat, String> {
    SplatFormat::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = SplatFormat::ALL.iter().map(|f| f.name()).collect();
        format!("unknown format {s:?} (one of {})", names.join(", "))
    })
}

/// What `convert` did, as `--json` reports it.
#[derive(Clone, Debug)]
pub struct ConvertReport {
    pub gaussians: usize,
    pub input_format: SplatFormat,
    pub output_format: SplatFormat,
    pub sh_degree_in: usize,
    pub sh_degree_out: usize,
    pub bytes: usize,
    /// The output read back with splatkit's reader against the input.
    pub error: SplatError,
}

/// Encodes `g` as `format` and measures the encoding by decoding it again:
/// the bytes and the report. `out` names the output in errors.
pub fn encode(
    g: &Gaussians,
    input_format: SplatFormat,
    format: SplatFormat,
    out: &str,
    lossy: bool,
) -> crate::Result<(Vec<u8>, ConvertReport)> {
    let bytes = splat::write(format, out, g, lossy)?;
    let back = splat::read(format, out, &bytes, std::path::Path::new("."))
        .map_err(|e| crate::Error::invalid(format!("reading back what was written: {e}")))?;
    let order = splat::write_order(format, g);
    let original = if order.iter().enumerate().all(|(j, &i)| i == j) {
        std::borrow::Cow::Borrowed(g)
    } else {
        std::borrow::Cow::Owned(g.gather(&order))
    };
    let error = splat_error(&original, &back).ok_or_else(|| {
        crate::Error::invalid(format!(
            "{out}: read back {} Gaussians of the {} written",
            back.len(),
            g.len()
        ))
    })?;
    let report = ConvertReport {
        gaussians: g.len(),
        input_format,
        output_format: format,
        sh_degree_in: g.sh_degree,
        sh_degree_out: back.sh_degree,
        bytes: bytes.len(),
        error,
    };
    Ok((bytes, report))
}

fn load(args: &ConvertArgs) -> anyhow::Result<(Gaussians, SplatFormat)> {
    if let Some(f) = args.input_format {
        let input = read_input(&args.input)?;
        let base = match args.input.parent() {
            Some(p) if !p.as_os_str().is_empty() && !input.is_stdin() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let g = splat::read(f, &input.name, &input, &base)?;
        return Ok((g, f));
    }
    let opened = any::open(&args.input)?;
    let format = SplatFormat::detect(&args.input, &opened.input).unwrap_or(SplatFormat::Ply);
    let Scene::Gaussians(g) = opened.decode_kinds("convert", &[SceneKind::Gaussians])? else {
        unreachable!("decode_kinds returns an accepted kind")
    };
    Ok((g, format))
}

/// `convert` entry point.
pub fn run(args: ConvertArgs) -> anyhow::Result<()> {
    args.common.init()?;
    declare_inputs(&[Some(&args.input)])?;
    args.common.check_output(&args.output, true)?;
    let out_name = shown(&args.output, true);
    let format = match (args.format, args.output.as_os_str() == "-") {
        (Some(f), _) => f,
        (None, true) => return Err(usage("writing to stdout needs --format")),
        (None, false) => SplatFormat::from_path(&args.output).ok_or_else(|| {
            usage(format!(
                "{}: cannot tell the output format from the extension (.ply, \
                 .compressed.ply, .spz, .sog, .splat); give --format",
                args.output.display()
            ))
        })?,
    };
    if !format.writable() {
        return Err(usage(format!("splatkit does not write {}", format.name())));
    }
    let (g, input_format) =
        load(&args).with_context(|| format!("reading {}", shown(&args.input, false)))?;
    let g = if args.bake_filter_3d {
        crate::model::filter3d::bake_filter_3d(&g)
            .map_err(|e| e.in_file(shown(&args.input, false)))?
    } else {
        g
    };
    let (bytes, report) = encode(&g, input_format, format, &out_name, args.lossy)?;
    write_output(&args.output, |w| {
        w.write_all(&bytes).map_err(crate::io::source::werr)
    })?;
    let e = &report.error;
    args.common.say(format!(
        "convert: {} Gaussians, {} → {} ({}, {} bytes); read back: position max {:.3e} rms \
         {:.3e}, colour max {:.3e} rms {:.3e}, opacity max {:.3e} rms {:.3e}, log-scale max \
         {:.3e} rms {:.3e}, rotation max {:.3}°, SH rest max {:.3e}",
        crate::io::describe::thousands(report.gaussians),
        report.input_format.name(),
        report.output_format.name(),
        out_name,
        report.bytes,
        e.position.max,
        e.position.rms,
        e.colour.max,
        e.colour.rms,
        e.opacity.max,
        e.opacity.rms,
        e.log_scale.max,
        e.log_scale.rms,
        e.rotation_max_deg,
        e.sh_rest_max
    ));
    args.common.emit_json(&json!({
        "input": shown(&args.input, false),
        "output": out_name,
        "input_format": report.input_format.name(),
        "format": report.output_format.name(),
        "gaussians": report.gaussians,
        "sh_degree_in": report.sh_degree_in,
        "sh_degree_out": report.sh_degree_out,
        "bytes": report.bytes,
        "lossy": args.lossy,
        "error": report.error,
    }))?;
    Ok(())
}
