//! `prune-triangles`: keep the solid, opaque triangles of a triangle-splat
//! soup. The criteria and their order are those of [`crate::geom::mesh_ops::prune`].

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use crate::cli::{Common, shown};
use crate::geom::mesh_ops::prune::{PruneParams, prune};
use crate::io::any::{load_soup, output_format, save_soup};
use crate::io::detect::FileFormat;

/// Command-line arguments of `prune-triangles`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  prune-triangles point_cloud_state_dict.pt --min-opacity 0.5 -o pruned.ply
  prune-triangles scene.pt --game-engine -o solid.pt
  prune-triangles scene.pt --max-count 500000 -o - | export-off - -o scene.off")]
pub struct PruneTrianglesArgs {
    /// Input soup: Triangle Splatting checkpoint (.pt) or splatkit soup PLY; `-` = stdin.
    pub input: PathBuf,
    /// Output file (.ply soup or .pt checkpoint); `-` = stdout (soup PLY unless --format).
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// Output format, overriding the extension.
    #[arg(long, value_parser = ["ply", "pt"])]
    pub format: Option<String>,
    /// Remove triangles with activated opacity ≤ T (0–1). Off by default;
    /// --game-engine sets 0.7.
    #[arg(long, value_name = "T", value_parser = unit_f32)]
    pub min_opacity: Option<f32>,
    /// Remove triangles with activated sigma ≥ S (σ = 0.01 + exp(raw)). Off
    /// by default; --game-engine sets 1.
    #[arg(long, value_name = "S", value_parser = positive_f32)]
    pub max_sigma: Option<f32>,
    /// Keep at most N triangles, the most opaque. Off by default (no cap).
    #[arg(long, value_name = "N")]
    pub max_count: Option<usize>,
    /// Write the output even when no triangle is kept (an empty soup),
    /// instead of failing with exit 1: for batch jobs where a scene may
    /// hold nothing above the thresholds (`export-off --allow-empty` takes it).
    #[arg(long)]
    pub allow_empty: bool,
    /// Make survivors hard and opaque (opacity 1, sigma 0), as for game engines.
    #[arg(long)]
    pub solidify: bool,
    /// The paper's game-engine conversion: --min-opacity 0.7 --max-sigma 1 --solidify
    /// (explicit thresholds override these).
    #[arg(long)]
    pub game_engine: bool,
    #[command(flatten)]
    pub common: Common,
}

/// A value in [0, 1] as f32 (clap value parser: a bad value is exit 2).
fn unit_f32(s: &str) -> Result<f32, String> {
    crate::cli::unit_f64(s).map(|v| v as f32)
}

/// A finite value > 0 that stays > 0 as f32 (clap value parser).
fn positive_f32(s: &str) -> Result<f32, String> {
    let v = crate::cli::positive_f64(s)? as f32;
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{s} is out of the range of a 32-bit float"))
    }
}

impl PruneTrianglesArgs {
    /// The thresholds these arguments ask for.
    pub fn params(&self) -> anyhow::Result<PruneParams> {
        let mut p = PruneParams {
            min_opacity: self.min_opacity,
            max_sigma: self.max_sigma,
            max_count: self.max_count,
            solidify: self.solidify,
        };
        if self.game_engine {
            p.min_opacity = p.min_opacity.or(Some(0.7));
            p.max_sigma = p.max_sigma.or(Some(1.0));
            p.solidify = true;
        }
        if let Some(t) = p.min_opacity
            && !(0.0..=1.0).contains(&t)
        {
            anyhow::bail!("--min-opacity must be in [0, 1], got {t}");
        }
        if let Some(s) = p.max_sigma
            && (s.is_nan() || s <= 0.0)
        {
            anyhow::bail!("--max-sigma must be positive, got {s}");
        }
        Ok(p)
    }
}

/// Why `prune` kept nothing, naming the flags that removed triangles
/// (`game_engine`: whether `--game-engine` supplied the default thresholds).
fn empty_cause(
    r: &crate::geom::mesh_ops::prune::PruneReport,
    p: &PruneParams,
    game_engine: bool,
) -> String {
    if r.total == 0 {
        return "the input holds no triangles".into();
    }
    let mut parts = Vec::new();
    if r.removed_invalid + r.removed_degenerate > 0 {
        parts.push(format!(
            "{} invalid or degenerate",
            r.removed_invalid + r.removed_degenerate
        ));
    }
    if let Some(t) = p.min_opacity.filter(|_| r.removed_opacity > 0) {
        parts.push(format!("{} by --min-opacity {t}", r.removed_opacity));
    }
    if let Some(s) = p.max_sigma.filter(|_| r.removed_sigma > 0) {
        parts.push(format!("{} by --max-sigma {s}", r.removed_sigma));
    }
    if let Some(n) = p.max_count.filter(|_| r.removed_count > 0) {
        parts.push(format!("{} by --max-count {n}", r.removed_count));
    }
    format!(
        "all {} removed: {}{}",
        r.total,
        parts.join(", "),
        if game_engine {
            " (thresholds from --game-engine unless given)"
        } else {
            ""
        }
    )
}

/// Runs the command.
pub fn run(args: PruneTrianglesArgs) -> anyhow::Result<()> {
    args.common.init()?;
    crate::cli::check_output_file(&args.output, "-o")?;
    args.common.check_stdout_free(&args.output)?;
    let params = args.params()?;
    let format = output_format(
        &args.output,
        args.format.as_deref().map(|f| {
            if f == "pt" {
                FileFormat::TorchPt
            } else {
                FileFormat::Ply
            }
        }),
        FileFormat::Ply,
    )?;
    if !matches!(format, FileFormat::Ply | FileFormat::TorchPt) {
        anyhow::bail!("prune-triangles writes .ply or .pt, not .{}", format.name());
    }
    crate::cli::check_binary_stdout(&args.output)?;
    if params.max_count == Some(0) && !args.allow_empty {
        anyhow::bail!(
            "--max-count 0 keeps no triangle: the output would be an empty soup; nothing \
             written (--allow-empty writes it)"
        );
    }
    let soup = load_soup(&args.input, "prune-triangles")?;
    let (out, report) = prune(&soup, &params);
    if out.is_empty() && !args.allow_empty {
        anyhow::bail!(
            "{}: no triangle is kept ({}); nothing written (--allow-empty writes the empty soup)",
            shown(&args.input, false),
            empty_cause(&report, &params, args.game_engine)
        );
    }
    save_soup(&args.output, &out, format)
        .with_context(|| format!("writing {}", shown(&args.output, true)))?;
    args.common.say(format!(
        "prune-triangles: kept {} of {} triangles (removed: {} by opacity, {} by sigma, {} by count, {} invalid, {} degenerate){}",
        report.kept,
        report.total,
        report.removed_opacity,
        report.removed_sigma,
        report.removed_count,
        report.removed_invalid,
        report.removed_degenerate,
        if report.solidified { "; solidified" } else { "" }
    ));
    let mut json = serde_json::to_value(&report)?;
    json["input"] = shown(&args.input, false).into();
    json["output"] = shown(&args.output, true).into();
    args.common.emit_json(&json)
}
