//! `prune-triangles`: keep the solid, opaque triangles of a triangle-splat
//! soup. The criteria and their order are those of [`crate::geom::prune`].

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use crate::cli::{Common, shown};
use crate::geom::prune::{PruneParams, prune};
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
    /// Remove triangles with activated opacity ≤ T (0–1).
    #[arg(long, value_name = "T")]
    pub min_opacity: Option<f32>,
    /// Remove triangles with activated sigma ≥ S (σ = 0.01 + exp(raw)).
    #[arg(long, value_name = "S")]
    pub max_sigma: Option<f32>,
    /// Keep at most N triangles, the most opaque.
    #[arg(long, value_name = "N")]
    pub max_count: Option<usize>,
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
    let soup = load_soup(&args.input, "prune-triangles")?;
    let (out, report) = prune(&soup, &params);
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
