//! Conventions shared by every command (DESIGN.md "CLI conventions"):
//! `-` for stdin/stdout, `--json`, `--quiet`, `--threads`, progress bars on
//! stderr that stay silent when stderr is not a terminal, exit codes
//! 0 (success) / 1 (error) / 2 (usage error, from clap).

pub mod commands;

use std::io::IsTerminal;
use std::path::Path;

use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Options every command accepts.
#[derive(Args, Debug, Clone, Default)]
pub struct Common {
    /// Print the machine-readable result as JSON on stdout (human summary stays on stderr).
    #[arg(long)]
    pub json: bool,
    /// No progress bars or summaries on stderr (errors are still printed).
    #[arg(short, long)]
    pub quiet: bool,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(short = 'j', long, value_name = "N")]
    pub threads: Option<usize>,
}

impl Common {
    /// Applies `--threads` to the global rayon pool.
    pub fn init(&self) -> anyhow::Result<()> {
        if let Some(n) = self.threads {
            if n == 0 {
                anyhow::bail!("--threads must be at least 1");
            }
            // Only the first pool configuration of a process takes effect.
            let _ = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build_global();
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

    /// Prints a human summary line on stderr unless `--quiet`.
    pub fn say(&self, line: impl AsRef<str>) {
        if !self.quiet {
            eprintln!("{}", line.as_ref());
        }
    }

    /// Prints `value` as pretty JSON on stdout when `--json` was given.
    pub fn emit_json(&self, value: &serde_json::Value) -> anyhow::Result<()> {
        if self.json {
            println!("{}", serde_json::to_string_pretty(value)?);
        }
        Ok(())
    }
}

/// Turns a command's result into the process exit code: 0 on success, 1
/// with `error: …` (and its causes) on stderr.
pub fn exit_with(result: anyhow::Result<()>) -> ! {
    match result {
        Ok(()) => std::process::exit(0),
        Err(e) => {
            // A closed stdout (`| head`) is not worth a message.
            if is_broken_pipe(&e) {
                std::process::exit(0);
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

/// Display form of a path argument (`-` shown as `<stdin>` or `<stdout>`).
pub fn shown(path: &Path, stdout: bool) -> String {
    if path.as_os_str() == "-" {
        if stdout { "<stdout>" } else { "<stdin>" }.to_string()
    } else {
        path.display().to_string()
    }
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
