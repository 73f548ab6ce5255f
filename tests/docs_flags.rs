//! Every flag on its page (issue 28): each long flag that a command's
//! `--help` lists is named on the command's page, `docs/<command>.md`
//! (`train triangles` and `train gaussians` on `docs/train.md`), and a flag
//! that clap gives a default value has at least one page line that names the
//! flag and states that default (`--depth 8`, "`--depth` (default 8)").
//!
//! So a flag added to a command without a word on its page, a flag renamed
//! in the code but not on the page, or a default changed in the code while
//! the page still gives the old one, fails here with the command, the flag
//! and the page.

use std::path::PathBuf;

use clap::{ArgAction, CommandFactory};
use splatkit::app::Cli;

/// Commands without a page of their own: `demo` is described in README.md
/// (its flags are a fixed recipe of the other commands'). Any other command
/// without a page fails [`every_command_has_a_page`].
const NO_PAGE: [&str; 1] = ["demo"];

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A long flag as `--help` lists it: its name and the default clap prints
/// (`None` for a switch or a flag without one).
struct Flag {
    long: String,
    default: Option<String>,
}

/// One command: its name path (`["poisson"]`, `["train", "gaussians"]`),
/// its page and its flags.
struct Entry {
    path: Vec<String>,
    page: PathBuf,
    flags: Vec<Flag>,
}

/// The flags `--help` shows for `c`: long ones, not hidden, not
/// `--help` / `--version`; switches (set-true, set-false, count) have no
/// default worth stating.
fn flags(c: &clap::Command) -> Vec<Flag> {
    c.get_arguments()
        .filter(|a| !a.is_hide_set())
        .filter_map(|a| {
            let long = a.get_long()?.to_string();
            if long == "help" || long == "version" {
                return None;
            }
            let switch = matches!(
                a.get_action(),
                ArgAction::SetTrue | ArgAction::SetFalse | ArgAction::Count
            );
            let d: Vec<String> = a
                .get_default_values()
                .iter()
                .map(|v| v.to_string_lossy().into_owned())
                .collect();
            let default = (!switch && !d.is_empty()).then(|| d.join(","));
            Some(Flag { long, default })
        })
        .collect()
}

/// Every command with a page, its subcommands included (a command with
/// subcommands and no flags of its own, like `train`, is listed through
/// them).
fn entries() -> Vec<Entry> {
    fn walk(c: &clap::Command, path: Vec<String>, out: &mut Vec<Entry>) {
        if !path.is_empty() {
            let page = repo().join("docs").join(format!("{}.md", path[0]));
            out.push(Entry {
                path: path.clone(),
                page,
                flags: flags(c),
            });
        }
        for s in c.get_subcommands() {
            if s.get_name() == "help" || (path.is_empty() && NO_PAGE.contains(&s.get_name())) {
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

/// True when `text` holds `word` not as part of a longer word: the
/// characters around it are not letters, digits, `_`, `-` (so `--near` is
/// not found in `--near-plane`), nor a `.` that continues a number (so `8`
/// is not found in `0.8` or `8.5`).
fn has_word(text: &str, word: &str) -> bool {
    let word_char = |c: char| c.is_alphanumeric() || c == '_' || c == '-';
    let mut from = 0;
    while let Some(k) = text[from..].find(word) {
        let start = from + k;
        let end = start + word.len();
        let before = text[..start].chars().next_back();
        let mut after = text[end..].chars();
        let a1 = after.next();
        let a2 = after.next();
        let before_ok = match before {
            None => true,
            Some('.') => !text[..start - 1].ends_with(|c: char| c.is_ascii_digit()),
            Some(c) => !word_char(c),
        };
        let after_ok = match a1 {
            None => true,
            Some('.') => !a2.is_some_and(|c| c.is_ascii_digit()),
            Some(c) => !word_char(c),
        };
        if before_ok && after_ok {
            return true;
        }
        from = start + word.chars().next().map_or(1, char::len_utf8);
    }
    false
}

#[test]
fn the_word_finder_finds_whole_words_only() {
    assert!(has_word("[--near 0.2]", "--near"));
    assert!(!has_word("[--near-plane 0.2]", "--near"));
    assert!(has_word("`--depth 8`", "8"));
    assert!(has_word("(default 8).", "8"));
    assert!(!has_word("--ratio 0.8", "8"));
    assert!(!has_word("--ratio 8.5", "8"));
    assert!(!has_word("depth 18", "8"));
    assert!(has_word("--format=ply,", "ply"));
    assert!(!has_word("--format compressed-ply", "ply"));
}

/// Every command clap knows (but the [`NO_PAGE`] ones) has its page.
#[test]
fn every_command_has_a_page() {
    let all = entries();
    // 16 commands with a page, `train` and its two models
    assert!(all.len() >= 18, "{} commands", all.len());
    for e in &all {
        assert!(
            e.page.exists(),
            "splatkit {} has no page {}",
            e.path.join(" "),
            e.page.display()
        );
    }
}

/// The failures of one check, gathered over every command so one run
/// lists them all.
fn report(what: &str, missing: Vec<String>) {
    assert!(
        missing.is_empty(),
        "{} {what}:\n  {}",
        missing.len(),
        missing.join("\n  ")
    );
}

fn page_text(e: &Entry) -> String {
    std::fs::read_to_string(&e.page).unwrap_or_else(|err| panic!("{}: {err}", e.page.display()))
}

fn page_name(e: &Entry) -> String {
    e.page
        .strip_prefix(repo())
        .unwrap_or(&e.page)
        .display()
        .to_string()
}

/// Every long flag of every command's `--help` is named on its page.
#[test]
fn every_flag_is_on_its_page() {
    let mut missing = Vec::new();
    let mut checked = 0;
    for e in entries().iter().filter(|e| e.page.exists()) {
        let text = page_text(e);
        for f in &e.flags {
            checked += 1;
            if !has_word(&text, &format!("--{}", f.long)) {
                missing.push(format!(
                    "{}: `splatkit {}` --{}",
                    page_name(e),
                    e.path.join(" "),
                    f.long
                ));
            }
        }
    }
    assert!(checked >= 200, "{checked} flags checked");
    report("flags missing from their page", missing);
}

/// Every flag with a clap default has a page line that names the flag and
/// states the default as `--help` prints it.
#[test]
fn every_default_is_stated_beside_its_flag() {
    let mut wrong = Vec::new();
    let mut checked = 0;
    for e in entries().iter().filter(|e| e.page.exists()) {
        let text = page_text(e);
        for f in &e.flags {
            let Some(d) = &f.default else { continue };
            checked += 1;
            let flag = format!("--{}", f.long);
            let stated = text.lines().any(|l| has_word(l, &flag) && has_word(l, d));
            if !stated {
                wrong.push(format!(
                    "{}: `splatkit {}` {flag}: no line names it with its default {d}",
                    page_name(e),
                    e.path.join(" ")
                ));
            }
        }
    }
    assert!(checked >= 80, "{checked} defaults checked");
    report("defaults not stated beside their flag", wrong);
}
