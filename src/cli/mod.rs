//! Conventions shared by every command (docs/ARCHITECTURE.md, "CLI conventions"):
//! `-` for stdin/stdout, `--json`, `--quiet`, `--threads`, progress bars on
//! stderr that stay silent when stderr is not a terminal, exit codes
//! 0 (success) / 1 (error) / 2 (usage error, from clap).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

pub mod filter2d;
pub mod memory;
pub mod model_folder;
pub mod orbit;

pub use crate::io::source::shown;

/// See [`Common::loop_bar`].
pub struct LoopBar {
    common: Common,
    label: &'static str,
    bar: Option<ProgressBar>,
}

impl LoopBar {
    /// The loop runs `len` iterations.
    pub fn start(&mut self, len: u64) {
        self.bar = Some(self.common.progress(len, self.label));
    }

    /// One iteration done; every 10th iteration the bar shows `status()`.
    pub fn step(&self, iteration: u64, status: impl FnOnce() -> String) {
        if let Some(b) = &self.bar {
            b.inc(1);
            if iteration.is_multiple_of(10) {
                b.set_message(status());
            }
        }
    }

    /// Prints `line` on stderr above the bar (or plainly when the bar is
    /// hidden or not started).
    pub fn println(&self, line: &str) {
        match &self.bar {
            Some(b) if !b.is_hidden() => b.println(line),
            _ => eprintln!("{line}"),
        }
    }

    /// Clears the bar.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// Options every command accepts.
#[derive(Args, Debug, Clone, Default)]
pub struct Common {
    /// Write the machine-readable result as JSON: `--json` prints it on stdout,
    /// `--json=FILE` writes FILE (use that when stdout carries the data).
    #[arg(long, value_name = "FILE", num_args = 0..=1, require_equals = true, default_missing_value = "-")]
    pub json: Option<PathBuf>,
    /// No progress bars or summaries on stderr (errors are still printed).
    #[arg(short, long)]
    pub quiet: bool,
    /// Worker threads, 1 to 512 (default: all cores). Results do not depend on it.
    #[arg(short = 'j', long, value_name = "N",
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=MAX_THREADS as u64))]
    pub threads: Option<usize>,
}

/// The most worker threads `--threads` accepts: far above any core count
/// this CPU tool is run on, and low enough that thread stacks (2 MB each by
/// default) cannot exhaust memory on their own.
pub const MAX_THREADS: usize = 512;

impl Common {
    /// Applies `--threads` to the global rayon pool and checks that a
    /// `--json=FILE` can be written (before any work, so a bad path never
    /// leaves the command's other outputs replaced).
    pub fn init(&self) -> anyhow::Result<()> {
        if let Some(p) = &self.json {
            check_output_file(p, "--json")?;
        }
        if let Some(n) = self.threads {
            if n == 0 || n > MAX_THREADS {
                anyhow::bail!("--threads must be between 1 and {MAX_THREADS} (got {n})");
            }
            if let Err(e) = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build_global()
            {
                // A pool set up earlier in this process with the same size is fine.
                if rayon::current_num_threads() != n {
                    anyhow::bail!("--threads {n}: cannot start the worker threads: {e}");
                }
            }
        }
        Ok(())
    }

    /// A progress bar on stderr for `len` steps; hidden with `--quiet` or when
    /// stderr is not a terminal (so pipes and logs stay clean).
    pub fn progress(&self, len: u64, msg: &'static str) -> ProgressBar {
        if self.quiet || !std::io::stderr().is_terminal() {
            return ProgressBar::hidden();
        }
        let pb = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
        pb.set_style(
            ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {eta}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        pb.set_message(msg);
        pb
    }

    /// A progress bar for an iterative loop whose length is known only when
    /// it starts (a training session's `Start` event); hidden like
    /// [`Common::progress`].
    pub fn loop_bar(&self, label: &'static str) -> LoopBar {
        LoopBar {
            common: self.clone(),
            label,
            bar: None,
        }
    }

    /// Prints a human summary line on stderr unless `--quiet`.
    pub fn say(&self, line: impl AsRef<str>) {
        if !self.quiet {
            eprintln!("{}", line.as_ref());
        }
    }

    /// True when the JSON result goes to stdout.
    pub fn json_to_stdout(&self) -> bool {
        self.json.as_ref().is_some_and(|p| p.as_os_str() == "-")
    }

    /// The pre-check of a command's data output `-o PATH`, before any work:
    /// [`check_output_file`] (its folder exists and takes a staging file;
    /// it is not a folder, nor one of the run's inputs), stdout not also
    /// wanted by `--json`, and, for a `binary` format, stdout not a
    /// terminal.
    pub fn check_output(&self, path: &Path, binary: bool) -> anyhow::Result<()> {
        check_output_file(path, "-o")?;
        self.check_stdout_free(path)?;
        if binary {
            check_binary_stdout(path)?;
        }
        Ok(())
    }

    /// Fails (usage) when both the data output and `--json` want stdout.
    pub fn check_stdout_free(&self, output: &Path) -> anyhow::Result<()> {
        if output.as_os_str() == "-" && self.json_to_stdout() {
            anyhow::bail!("the output goes to stdout, so the JSON report cannot: use --json=FILE");
        }
        Ok(())
    }

    /// Writes `value` as pretty JSON where `--json` asked (stdout or a file,
    /// the file atomically); nothing without `--json`.
    pub fn emit_json(&self, value: &serde_json::Value) -> anyhow::Result<()> {
        let Some(path) = &self.json else {
            return Ok(());
        };
        let text = serde_json::to_string_pretty(value)?;
        if path.as_os_str() == "-" {
            // Held until the run's outputs are committed: a report on
            // stdout never claims a run whose files then failed to land.
            if let Err(text) = crate::io::transaction::defer_stdout(text) {
                crate::io::source::print_stdout(&format!("{text}\n"));
            }
        } else {
            crate::io::write_output(path, |w| {
                writeln!(w, "{text}").map_err(crate::io::source::werr)
            })?;
        }
        Ok(())
    }
}

/// A usage error found after argument parsing (a combination of flags or
/// inputs that cannot work): the command exits with 2, as clap does for the
/// errors it finds itself.
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// `Err(UsageError(msg))` as an `anyhow::Error`.
pub fn usage(msg: impl Into<String>) -> anyhow::Error {
    UsageError(msg.into()).into()
}

/// A flag value that must be a finite number greater than zero (clap value
/// parser: a bad value is a usage error, exit 2).
pub fn positive_f64(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{s} must be a finite number greater than zero"))
    }
}

/// `--min-inradius` of `train triangles` and `render` (clap value parser):
/// a pixel count in (0, 1] (above 1 would cull triangles the reference's
/// kernel draws; see `RasterSettings::min_inradius`).
pub fn min_inradius_arg(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number of pixels"))?;
    if v > 0.0 && v <= 1.0 {
        Ok(v)
    } else {
        Err(format!(
            "{s}: the smallest drawn inradius must lie in (0, 1] pixels"
        ))
    }
}

/// A flag value that must be a finite number ≥ 0 (clap value parser).
pub fn nonneg_f64(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("{s} must be a finite number of at least zero"))
    }
}

/// A flag value that must be a fraction in [0, 1) (clap value parser).
pub fn fraction_f64(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if (0.0..1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{s} must be a fraction in [0, 1)"))
    }
}

/// A flag value that must lie in [0, 1], both ends included (clap value
/// parser): blend weights such as `--depth-ratio`.
pub fn unit_f64(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{s} must be a number in [0, 1]"))
    }
}

/// A hold-out period N (clap value parser): every N-th view is held out, 0
/// holds out none; 1 would hold out every view and leave nothing, so it is
/// refused at parse (exit 2).
pub fn holdout_every(s: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a whole number"))?;
    if n == 1 {
        Err("1 would hold out every view: give 0 (none) or 2 or more".into())
    } else {
        Ok(n)
    }
}

/// [`fraction_f64`] as f32.
pub fn fraction_f32(s: &str) -> Result<f32, String> {
    fraction_f64(s).map(|v| v as f32)
}

/// Runs one command inside an output transaction
/// ([`crate::io::transaction`]): everything it writes is committed together
/// when it returns `Ok`, and removed when it fails; then exits as
/// [`exit_with`] says.
pub fn run_command(f: impl FnOnce() -> anyhow::Result<()>) -> ! {
    let tx = crate::io::transaction::Transaction::begin();
    let result = f();
    let result = match result {
        Ok(()) => tx.commit().map_err(anyhow::Error::from),
        Err(e) => {
            drop(tx);
            Err(e)
        }
    };
    exit_with(result)
}

/// True when `e` (or an error it wraps) is a usage error: a [`UsageError`]
/// or a library [`crate::Error::Usage`].
pub fn is_usage(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<UsageError>().is_some()
            || matches!(
                c.downcast_ref::<crate::Error>(),
                Some(crate::Error::Usage(_))
            )
    })
}

/// Turns a command's result into the process exit code: 0 on success, 2
/// for a usage error ([`is_usage`]), 1 otherwise, with `error: …` (and its
/// causes) on stderr.
pub fn exit_with(result: anyhow::Result<()>) -> ! {
    match result {
        Ok(()) => std::process::exit(0),
        Err(e) => {
            // A closed stdout (`| head`) is not worth a message.
            if is_broken_pipe(&e) {
                std::process::exit(0);
            }
            if is_usage(&e) {
                eprintln!("error: {e}");
                for cause in e.chain().skip(1) {
                    eprintln!("  caused by: {cause}");
                }
                std::process::exit(2);
            }
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            std::process::exit(1);
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Checks, before any work, that an output file can be created: `-` is
/// stdout; otherwise its folder must exist, the path must not be a folder,
/// a staging file can be created in that folder (created and removed
/// again), and the path is not one of the run's inputs (declared with
/// [`crate::io::transaction::note_output`]: an output that resolves to an
/// input file or lies in an input folder is a usage error, exit 2). `what`
/// names the flag in the message.
pub fn check_output_file(path: &Path, what: &str) -> anyhow::Result<()> {
    if path.as_os_str() == "-" {
        return Ok(());
    }
    crate::io::transaction::note_output(path, what)?;
    if path.is_dir() {
        anyhow::bail!(
            "{what} {}: is a folder, expected a file path",
            path.display()
        );
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        anyhow::bail!(
            "{what} {}: the folder {} does not exist",
            path.display(),
            dir.display()
        );
    }
    crate::io::transaction::probe_writable(path)
        .map_err(|e| anyhow::anyhow!("{what} {}: cannot write there: {e}", path.display()))?;
    Ok(())
}

pub use crate::io::budget::memory_budget;

/// Records paths named on the command line as inputs of the run before any
/// work, whether or not the run ends up reading them (a `--cameras` that
/// `--thickness` makes unused is still the user's file): folders with
/// [`crate::io::transaction::note_input_dir`], files with `note_input`.
/// An output already declared over one of them is a usage error.
pub fn declare_inputs(paths: &[Option<&Path>]) -> anyhow::Result<()> {
    for p in paths.iter().flatten() {
        if p.is_dir() {
            crate::io::transaction::note_input_dir(p)?;
        } else if p.exists() {
            crate::io::transaction::note_input(p)?;
        }
    }
    Ok(())
}

/// Refuses to write binary data to a terminal.
pub fn check_binary_stdout(path: &Path) -> anyhow::Result<()> {
    if path.as_os_str() == "-" && std::io::stdout().is_terminal() {
        anyhow::bail!(
            "refusing to write binary output to a terminal: redirect stdout or give -o FILE"
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    /// `--min-inradius` takes a pixel count in (0, 1]: zero, negatives,
    /// values above the kernel's 1 px, NaN and words are refused with the
    /// value named.
    #[test]
    fn min_inradius_range() {
        for ok in ["1", "0.5", "1e-3"] {
            assert!(super::min_inradius_arg(ok).is_ok(), "{ok}");
        }
        // surrounding blanks are trimmed, as positive_f64 does
        assert_eq!(super::min_inradius_arg(" 0.5 "), Ok(0.5));
        for bad in ["0", "-0.5", "1.5", "NaN", "inf", "px"] {
            let e = super::min_inradius_arg(bad).unwrap_err();
            assert!(e.contains(bad), "{bad}: {e}");
        }
    }
}
