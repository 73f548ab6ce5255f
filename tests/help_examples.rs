//! `--help` that pastes (issue 28). Each command's text after its options
//! (examples and notes) is written at most 79 columns wide, so clap prints it
//! verbatim in a terminal of 80 columns and through a pipe (100): an example
//! wrapped in the middle of a command fails when pasted. And every example
//! line that runs a splatkit command parses with that command's arguments, so
//! a renamed or misspelt flag in an example fails here.

mod common;

use clap::CommandFactory;
use splatkit::app::Cli;

/// Every command's name path (`["chamfer"]`, `["train", "gaussians"]`, and
/// `[]` for `splatkit` itself) with its after-help text.
fn after_helps() -> Vec<(Vec<String>, String)> {
    fn walk(c: &clap::Command, path: Vec<String>, out: &mut Vec<(Vec<String>, String)>) {
        if let Some(t) = c.get_after_help() {
            out.push((path.clone(), t.to_string()));
        }
        for s in c.get_subcommands() {
            if s.get_name() == "help" {
                continue;
            }
            let mut p = path.clone();
            p.push(s.get_name().to_string());
            walk(s, p, out);
        }
    }
    let mut out = Vec::new();
    walk(&Cli::command(), Vec::new(), &mut out);
    out
}

/// The help clap prints for `splatkit PATH --help` at `width` columns.
fn help_at(path: &[String], width: usize) -> String {
    let mut argv = vec!["splatkit".to_string()];
    argv.extend(path.iter().cloned());
    argv.push("--help".into());
    let e = Cli::command()
        .term_width(width)
        .try_get_matches_from(argv)
        .expect_err("--help stops parsing");
    assert_eq!(e.kind(), clap::error::ErrorKind::DisplayHelp);
    e.to_string()
}

/// The check below is meaningful: at 80 columns clap does wrap a longer
/// after-help line (so a line that appears verbatim was not wrapped).
#[test]
fn clap_wraps_long_lines_at_80_columns() {
    let long = format!("  chamfer a.ply b.ply {}", "--json ".repeat(10));
    assert!(long.len() > 80);
    let mut c = clap::Command::new("x")
        .after_help(long.clone())
        .term_width(80);
    let h = c.render_help().to_string();
    assert!(!h.contains(long.trim_end()), "{h}");
}

/// Every command (the umbrella, each subcommand, `train`'s two) has an
/// after-help text of lines ≤ 79 columns that appears verbatim in its help at
/// 80 and at 100 columns.
#[test]
fn after_help_is_printed_verbatim_at_80_and_100_columns() {
    let all = after_helps();
    // the umbrella, 17 commands and train's two models at least
    assert!(all.len() >= 19, "{} commands with after-help", all.len());
    for (path, text) in &all {
        for (n, line) in text.lines().enumerate() {
            assert!(
                line.chars().count() <= 79,
                "splatkit {} --help, after-help line {}: {} columns: {line}",
                path.join(" "),
                n + 1,
                line.chars().count()
            );
        }
        for width in [80, 100] {
            let h = help_at(path, width);
            for line in text.lines() {
                assert!(
                    h.lines().any(|l| l.trim_end() == line.trim_end()),
                    "splatkit {} --help at {width} columns changes the line {line:?}:\n{h}",
                    path.join(" ")
                );
            }
        }
    }
}

/// The example command lines of an after-help text: lines of its
/// `Examples:` block with `\` continuations joined, comments (`# …`)
/// dropped.
fn example_commands(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut inside = false;
    for line in text.lines() {
        if line.starts_with("Examples:") {
            inside = true;
            continue;
        }
        if !inside {
            continue;
        }
        if line.trim().is_empty() || !line.starts_with("  ") {
            inside = false;
            continue;
        }
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
    assert!(cur.is_empty(), "an example ends with a continuation: {cur}");
    out
}

/// Every example in every `--help` parses: each command of a pipeline or
/// `&&` chain is a splatkit command (or `cat`) whose arguments clap accepts.
#[test]
fn every_help_example_parses() {
    let names: Vec<String> = Cli::command()
        .get_subcommands()
        .map(|s| s.get_name().to_string())
        .collect();
    let mut checked = 0;
    for (path, text) in after_helps() {
        let examples = example_commands(&text);
        if text.contains("Examples:") {
            assert!(
                !examples.is_empty(),
                "splatkit {}: no examples",
                path.join(" ")
            );
        }
        for ex in examples {
            assert!(
                !ex.contains(['"', '\'']),
                "quoting is not parsed here: {ex}"
            );
            for part in ex.split(['|', '&']).filter(|p| !p.trim().is_empty()) {
                // drop an output redirection
                let part = part.split('>').next().unwrap_or("");
                let words: Vec<&str> = part.split_whitespace().collect();
                let Some(first) = words.first() else { continue };
                let argv: Vec<&str> = match *first {
                    "cat" => continue,
                    "splatkit" => words.clone(),
                    w if names.iter().any(|n| n == w) => std::iter::once("splatkit")
                        .chain(words.iter().copied())
                        .collect(),
                    w => panic!("splatkit {}: example runs {w:?}: {ex}", path.join(" ")),
                };
                if let Err(e) = Cli::command().try_get_matches_from(&argv) {
                    panic!(
                        "splatkit {} example does not parse: {ex}\n{e}",
                        path.join(" ")
                    );
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 60, "{checked} example commands checked");
}

/// The single-command binaries print the same after-help verbatim at 80
/// columns (`COLUMNS=80`, which clap reads when the output is not a
/// terminal).
#[test]
fn binaries_print_examples_verbatim_at_80_columns() {
    for (path, text) in after_helps() {
        if path.len() != 1 || path[0] == "demo" || path[0] == "train" {
            continue;
        }
        let o = assert_cmd::Command::cargo_bin(&path[0])
            .unwrap()
            .arg("--help")
            .env("COLUMNS", "80")
            .output()
            .unwrap();
        common::succeeds(&o);
        let h = String::from_utf8_lossy(&o.stdout);
        for line in text.lines() {
            assert!(
                h.lines().any(|l| l.trim_end() == line.trim_end()),
                "{} --help at 80 columns changes the line {line:?}:\n{h}",
                path[0]
            );
        }
    }
}
