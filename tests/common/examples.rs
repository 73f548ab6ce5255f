//! Example command lines checked against the command table: each splatkit
//! command in a line parses with that command's arguments (clap), so a
//! renamed or misspelt flag or command in an example fails the test that
//! reads it. Used by the `--help` and the documentation example tests.

use std::path::{Path, PathBuf};

use clap::CommandFactory;
use splatkit::app::Cli;

/// Parses every splatkit command of the shell line `line`: its pipeline,
/// `&&` and `;` parts are split, an output redirection (`> FILE`) dropped;
/// a part starting with `splatkit` or a command name is parsed, `cargo run
/// … -- ARGS` is parsed as `splatkit ARGS`, other cargo calls and parts
/// whose first word `skip` accepts are skipped, anything else is an error.
/// Quoting is not interpreted, so a quoted argument is an error too. Returns
/// the number of commands parsed.
pub fn parse_splatkit_line(line: &str, skip: impl Fn(&str) -> bool) -> Result<usize, String> {
    let names: Vec<String> = Cli::command()
        .get_subcommands()
        .map(|s| s.get_name().to_string())
        .collect();
    let mut parsed = 0;
    for part in line.split(['|', '&', ';']).filter(|p| !p.trim().is_empty()) {
        let part = part.split('>').next().unwrap_or("");
        let words: Vec<&str> = part.split_whitespace().collect();
        let Some(first) = words.first().copied() else {
            continue;
        };
        let argv: Vec<&str> = if first == "cargo" {
            match words.iter().position(|w| *w == "--") {
                Some(i) if words.contains(&"run") => std::iter::once("splatkit")
                    .chain(words[i + 1..].iter().copied())
                    .collect(),
                _ => continue,
            }
        } else if first == "splatkit" {
            words.clone()
        } else if names.iter().any(|n| n == first) {
            std::iter::once("splatkit")
                .chain(words.iter().copied())
                .collect()
        } else if skip(first) {
            continue;
        } else {
            return Err(format!("unknown program {first:?}"));
        };
        if part.contains(['"', '\'']) {
            return Err("quoting is not parsed here".into());
        }
        Cli::command()
            .try_get_matches_from(&argv)
            .map_err(|e| e.to_string())?;
        parsed += 1;
    }
    Ok(parsed)
}

/// The folder of the built commands.
pub fn bin_dir() -> PathBuf {
    Path::new(env!("CARGO_BIN_EXE_splatkit"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Runs `cmd` with bash in `dir`, the built commands first on PATH; exit
/// code and stdout + stderr.
pub fn sh(dir: &Path, cmd: &str) -> (i32, String) {
    let path = format!(
        "{}:{}",
        bin_dir().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let o = std::process::Command::new("bash")
        .arg("-c")
        .arg(format!("{{ {cmd}\n}} 2>&1"))
        .current_dir(dir)
        .env("PATH", path)
        .env_remove("SPLATKIT_BIN")
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into_owned(),
    )
}

/// Makes the example kit in `dir`: `splatkit demo` at a small size (scene.ply,
/// cameras.json, points.ply, mesh.ply, truth.ply, bound.ply,
/// refined_bound.ply, scene.pt, scene_soup.ply, solid.pt/.off/.glb) and
/// `images/`, the views rendered as photos (tests/doc_examples.rs lists
/// them for the pages).
pub fn make_kit(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let steps = [
        "splatkit demo -o . --views 6 --size 64 --depth 6 --refine-iterations 5 \\
         --bind-faces 500 --segments 8 -q",
        "splatkit render scene.ply --cameras cameras.json -o images --outputs rgb -q",
    ];
    for s in steps {
        let (code, out) = sh(dir, s);
        assert_eq!(code, 0, "example kit: {s}\n{out}");
    }
}

/// Shell lines to commands: a trailing `\` joins a line with the next, and
/// `# …` comments (whole lines, or after ` #`) and blank lines are dropped.
/// An error holding the unfinished command when the last line continues.
pub fn join_commands<'a>(lines: impl IntoIterator<Item = &'a str>) -> Result<Vec<String>, String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    for line in lines {
        let code = line.split(" #").next().unwrap_or("").trim();
        if code.starts_with('#') || code.is_empty() {
            continue;
        }
        if let Some(head) = code.strip_suffix('\\') {
            cur.push_str(head);
            cur.push(' ');
        } else {
            cur.push_str(code);
            out.push(std::mem::take(&mut cur));
        }
    }
    if cur.is_empty() { Ok(out) } else { Err(cur) }
}
