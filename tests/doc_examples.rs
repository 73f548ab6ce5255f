//! Documentation that runs (issue 28): the fenced blocks of README.md and
//! docs/*.md, by their info string.
//!
//! - ```` ```console ````: a session. Lines `$ COMMAND` (continued with a
//!   trailing `\`) are run with bash in a folder holding the example kit
//!   below, with the built commands first on PATH; the lines after a command
//!   are what it prints (stdout and stderr together, as in a terminal without
//!   progress bars). `...` alone on a line stands for any number of lines,
//!   `[..]` inside a line for any text; a last line `[exit N]` says the
//!   command exits with N (else it must succeed). The blocks of one page run
//!   in order in one folder, so a page's examples can build on each other.
//! - ```` ```sh ````: commands shown, not run (they name the user's data):
//!   every splatkit command in them must parse with that command's arguments.
//! - ```` ```text ````, `json`, `make`, `python`: synopses, outputs, recipes;
//!   a `text` block may not hold a `$ ` line (a session must be `console`).
//!
//! Every block has an info string, so an example cannot slip past the tests.
//!
//! The example kit (what a console block may read), made once per run by
//! `splatkit demo` at a small size plus a render of its views:
//! `scene.ply` (3DGS Gaussians, torus), `cameras.json` (6 views, 64×64),
//! `points.ply` (oriented points from `splat2points`), `mesh.ply` (Poisson
//! mesh), `truth.ply` (the exact torus), `bound.ply` / `refined_bound.ply`
//! (SuGaR-bound Gaussians), `scene.pt` / `scene_soup.ply` (a Triangle
//! Splatting checkpoint and its soup), `solid.pt` / `solid.off` /
//! `solid.glb` (pruned and exported), `images/` (the views as PNG photos),
//! and `../shared/data` when the shared data sets are present.

mod common;

use std::path::{Path, PathBuf};

/// A fenced block: file, 1-based line of its opening fence, info string,
/// body lines.
struct Block {
    file: PathBuf,
    line: usize,
    info: String,
    body: Vec<String>,
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and every docs/*.md, sorted.
fn pages() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(repo().join("docs"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    v.sort();
    v.insert(0, repo().join("README.md"));
    v
}

fn blocks(page: &Path) -> Vec<Block> {
    let text = std::fs::read_to_string(page).unwrap();
    let mut out = Vec::new();
    let mut cur: Option<Block> = None;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        if let Some(rest) = t.strip_prefix("```") {
            match cur.take() {
                Some(b) => out.push(b),
                None => {
                    cur = Some(Block {
                        file: page.to_path_buf(),
                        line: i + 1,
                        info: rest.trim().to_string(),
                        body: Vec::new(),
                    })
                }
            }
        } else if let Some(b) = cur.as_mut() {
            b.body.push(line.to_string());
        }
    }
    assert!(cur.is_none(), "{}: a fence is not closed", page.display());
    out
}

fn at(b: &Block) -> String {
    format!(
        "{}:{}",
        b.file.strip_prefix(repo()).unwrap_or(&b.file).display(),
        b.line
    )
}

/// Every block says what it is, and sessions are `console` blocks.
#[test]
fn every_block_is_tagged() {
    let allowed = ["console", "sh", "text", "json", "make", "python"];
    let mut n = 0;
    for page in pages() {
        for b in blocks(&page) {
            n += 1;
            assert!(
                allowed.contains(&b.info.as_str()),
                "{}: a fenced block needs one of {allowed:?} as its info string, not {:?}",
                at(&b),
                b.info
            );
            if b.info != "console" {
                assert!(
                    !b.body.iter().any(|l| l.starts_with("$ ")),
                    "{}: a block with `$ ` lines is a session: tag it `console`",
                    at(&b)
                );
            }
        }
    }
    assert!(n >= 30, "{n} blocks");
}

/// The command lines of a `sh` block: continuations joined, comments and
/// blank lines dropped.
fn sh_commands(b: &Block) -> Vec<String> {
    common::examples::join_commands(b.body.iter().map(String::as_str))
        .unwrap_or_else(|cur| panic!("{}: ends with a continuation: {cur}", at(b)))
}

/// Programs a `sh` block may run besides splatkit's commands (not parsed).
const OTHER_PROGRAMS: [&str; 10] = [
    "cat", "make", "bash", "python3", "pip", "git", "cd", "mkdir", "ls", "open3d",
];

/// Every splatkit command in a `sh` block parses (`cargo run … -- ARGS`
/// is parsed as `splatkit ARGS`); other programs must be known ones.
#[test]
fn sh_examples_parse() {
    let skip =
        |w: &str| w.starts_with("scripts/") || w.contains('=') || OTHER_PROGRAMS.contains(&w);
    let mut checked = 0;
    for page in pages() {
        for b in blocks(&page).iter().filter(|b| b.info == "sh") {
            for cmd in sh_commands(b) {
                match common::examples::parse_splatkit_line(&cmd, skip) {
                    Ok(n) => checked += n,
                    Err(e) => panic!("{}: does not parse: {cmd}\n{e}", at(b)),
                }
            }
        }
    }
    assert!(checked >= 20, "{checked} commands checked");
}

/// One `$` command of a console block and the output shown after it.
struct Step {
    command: String,
    expected: Vec<String>,
    exit: i32,
}

fn steps(b: &Block) -> Vec<Step> {
    let mut out: Vec<Step> = Vec::new();
    let mut lines = b.body.iter().peekable();
    while let Some(line) = lines.next() {
        if let Some(c) = line.strip_prefix("$ ") {
            let mut command = c.to_string();
            // keep the backslash: bash joins the lines, as in a terminal
            while command.ends_with('\\') {
                command.push('\n');
                command.push_str(lines.next().map(|s| s.as_str()).unwrap_or(""));
            }
            out.push(Step {
                command,
                expected: Vec::new(),
                exit: 0,
            });
        } else {
            let s = out
                .last_mut()
                .unwrap_or_else(|| panic!("{}: output before any `$ ` line", at(b)));
            if let Some(code) = line
                .trim()
                .strip_prefix("[exit ")
                .and_then(|r| r.strip_suffix(']'))
            {
                s.exit = code.parse().expect("[exit N]");
            } else {
                s.expected.push(line.clone());
            }
        }
    }
    out
}

/// `line` against one expected line where `[..]` matches any text.
fn line_matches(expected: &str, line: &str) -> bool {
    let parts: Vec<&str> = expected.split("[..]").collect();
    if parts.len() == 1 {
        return expected == line;
    }
    let mut rest = line;
    for (i, p) in parts.iter().enumerate() {
        if i == 0 {
            let Some(r) = rest.strip_prefix(p) else {
                return false;
            };
            rest = r;
        } else if i == parts.len() - 1 {
            return rest.ends_with(p);
        } else {
            match rest.find(p) {
                Some(k) => rest = &rest[k + p.len()..],
                None => return false,
            }
        }
    }
    true
}

/// The printed lines against the expected ones (`...` = any number of
/// lines), trailing blanks ignored.
fn output_matches(expected: &[String], got: &[&str]) -> bool {
    fn go(e: &[String], g: &[&str]) -> bool {
        match e.first() {
            None => g.is_empty(),
            Some(x) if x.trim() == "..." => (0..=g.len()).any(|k| go(&e[1..], &g[k..])),
            Some(x) => {
                !g.is_empty() && line_matches(x.trim_end(), g[0].trim_end()) && go(&e[1..], &g[1..])
            }
        }
    }
    let trim = |v: &[&str]| -> usize {
        v.len() - v.iter().rev().take_while(|l| l.trim().is_empty()).count()
    };
    let e: Vec<String> =
        expected[..trim(&expected.iter().map(|s| s.as_str()).collect::<Vec<_>>())].to_vec();
    go(&e, &got[..trim(got)])
}

#[test]
fn the_output_matcher_matches_what_it_should() {
    let e = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert!(output_matches(
        &e(&["a [..] c", "..."]),
        &["a b c", "x", "y"]
    ));
    assert!(output_matches(&e(&["...", "end"]), &["end"]));
    assert!(!output_matches(&e(&["a [..] c"]), &["a b d"]));
    assert!(!output_matches(&e(&["a"]), &["a", "b"]));
    assert!(output_matches(
        &e(&["vertices: [..]", ""]),
        &["vertices: 12", ""]
    ));
}

/// A fresh copy of the kit for one page, at `ROOT/repo` with `ROOT/shared`
/// pointing at the shared data, so `../shared/data/...` resolves as from a
/// checkout.
fn page_dir(kit: &Path, root: &Path) -> PathBuf {
    let d = root.join("repo");
    let (code, out) =
        common::examples::sh(root, &format!("cp -r {} {}", kit.display(), d.display()));
    assert_eq!(code, 0, "{out}");
    let shared = repo().join("../shared");
    if shared.exists() {
        std::os::unix::fs::symlink(&shared, root.join("shared")).unwrap();
    }
    d
}

/// Every `console` block runs, exits as shown and prints what the page shows.
#[test]
fn console_examples_run_and_print_what_the_page_shows() {
    let kit_root = tempfile::tempdir().unwrap();
    let kit = kit_root.path().join("kit");
    common::examples::make_kit(&kit);
    let mut ran = 0;
    let shared_present = repo().join("../shared/data").exists();
    for page in pages() {
        let sessions: Vec<Block> = blocks(&page)
            .into_iter()
            .filter(|b| b.info == "console")
            .collect();
        if sessions.is_empty() {
            continue;
        }
        let root = tempfile::tempdir().unwrap();
        let dir = page_dir(&kit, root.path());
        for b in &sessions {
            for s in steps(b) {
                if s.command.contains("../shared/data") && !shared_present {
                    if std::env::var("SPLATKIT_REQUIRE_SHARED").as_deref() == Ok("1") {
                        panic!("{}: ../shared/data is missing", at(b));
                    }
                    eprintln!("skipped (no ../shared/data): {}", s.command);
                    continue;
                }
                let (code, out) = common::examples::sh(&dir, &s.command);
                let got: Vec<&str> = out.lines().collect();
                assert_eq!(
                    code,
                    s.exit,
                    "{}: `{}` exited {code}, the page says {}:\n{out}",
                    at(b),
                    s.command,
                    s.exit
                );
                assert!(
                    output_matches(&s.expected, &got),
                    "{}: `{}` printed\n{out}\nbut the page shows\n{}",
                    at(b),
                    s.command,
                    s.expected.join("\n")
                );
                ran += 1;
            }
        }
    }
    assert!(ran >= 3, "{ran} console commands ran");
}
