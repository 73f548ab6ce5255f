//! The layer table of DESIGN.md, enforced: data flows one way, and a module
//! imports only from the layers below it.
//!
//! Every `.rs` file under `src/` belongs to the layer of its top folder
//! (`src/io/…` is `io`, `src/app.rs` and `src/bin/…` are the top, `bin`).
//! Every `crate::…` path in its code (in `use` lines, including nested
//! `use crate::{a::b, c}` groups, and paths written inline) names the
//! top-level module it reaches into; that module's layer must be one the
//! table allows. Inside `src/ops/`, an op may also not reach into another
//! op (`crate::ops::other`): shared cores live in the layers below.
//! Comments and string literals are ignored. `crate::{Error, Result}`,
//! `crate::error` and the test-support module `crate::testing` are open to
//! every layer. The render crate may not depend on the main package at all.
//!
//! A failure names the file, the line and the forbidden import.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Layers of the main package that each layer may import (DESIGN.md).
fn allowed(layer: &str) -> &'static [&'static str] {
    match layer {
        "model" => &["model"],
        "io" => &["model", "io"],
        "geom" => &["model", "geom"],
        "eval" => &["model", "geom", "eval"],
        "train" => &["model", "geom", "train"],
        "cli" => &["model", "io", "cli"],
        "ops" => &["model", "io", "geom", "eval", "train", "cli", "ops"],
        "bin" => &["model", "io", "geom", "eval", "train", "cli", "ops", "bin"],
        other => panic!("unknown layer {other}"),
    }
}

/// Top-level modules open to every layer.
const ANY_LAYER: &[&str] = &["Error", "Result", "error", "testing"];

/// The layer a top-level module of the crate belongs to (`None`: not a
/// module of the table, e.g. a re-export open to all).
fn layer_of_module(m: &str) -> Option<&'static str> {
    Some(match m {
        "model" => "model",
        "io" => "io",
        "geom" => "geom",
        "eval" => "eval",
        "train" => "train",
        "cli" => "cli",
        "ops" => "ops",
        "app" => "bin",
        _ => return None,
    })
}

/// The layer of a source file, from its path relative to `src/`.
fn layer_of_file(rel: &Path) -> Option<&'static str> {
    let first = rel.components().next()?.as_os_str().to_str()?;
    let stem = first.strip_suffix(".rs").unwrap_or(first);
    match stem {
        "bin" => Some("bin"),
        // lib.rs only declares modules; error.rs and testing.rs are open to all.
        "lib" | "error" | "testing" => None,
        m => layer_of_module(m),
    }
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The source with comments and the contents of string and char literals
/// blanked (newlines kept, so line numbers stay right).
fn code_only(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    let blank = |out: &mut Vec<u8>, c: u8| out.push(if c == b'\n' { b'\n' } else { b' ' });
    while i < b.len() {
        let c = b[i];
        let next = b.get(i + 1).copied();
        if c == b'/' && next == Some(b'/') {
            while i < b.len() && b[i] != b'\n' {
                out.push(b' ');
                i += 1;
            }
        } else if c == b'/' && next == Some(b'*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                    depth += 1;
                    out.extend_from_slice(b"  ");
                    i += 2;
                } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                    depth -= 1;
                    out.extend_from_slice(b"  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, b[i]);
                    i += 1;
                }
            }
        } else if c == b'r' && (next == Some(b'"') || next == Some(b'#')) && !prev_ident(b, i) {
            // Raw string r"…" or r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&b'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&b'"') {
                out.push(c);
                i += 1;
                continue;
            }
            out.extend(std::iter::repeat_n(b' ', j + 1 - i));
            i = j + 1;
            while i < b.len() {
                if b[i] == b'"' && b[i + 1..].iter().take(hashes).all(|&h| h == b'#') {
                    out.extend(std::iter::repeat_n(b' ', hashes + 1));
                    i += hashes + 1;
                    break;
                }
                blank(&mut out, b[i]);
                i += 1;
            }
        } else if c == b'"' {
            out.push(b' ');
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    blank(&mut out, b[i]);
                    i += 1;
                }
                if i < b.len() {
                    blank(&mut out, b[i]);
                    i += 1;
                }
            }
            out.push(b' ');
            i += 1;
        } else if c == b'\'' && is_char_literal(b, i) {
            // 'x' or '\n' (lifetimes like 'a are left alone).
            let end = if next == Some(b'\\') {
                b[i + 2..]
                    .iter()
                    .position(|&x| x == b'\'')
                    .map(|p| i + 2 + p)
            } else {
                Some(i + 2)
            };
            let end = end.unwrap_or(i);
            out.extend(std::iter::repeat_n(b' ', end + 1 - i));
            i = end + 1;
        } else {
            out.push(c);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn prev_ident(b: &[u8], i: usize) -> bool {
    i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_')
}

fn is_char_literal(b: &[u8], i: usize) -> bool {
    match b.get(i + 1) {
        Some(b'\\') => true,
        Some(_) => {
            // 'x' closes right after one (possibly multi-byte) character.
            let rest = &b[i + 1..];
            let s = std::str::from_utf8(&rest[..rest.len().min(5)]).unwrap_or("");
            let mut chars = s.char_indices();
            chars.next();
            chars.next().is_some_and(|(k, ch)| ch == '\'' && k > 0)
                || (rest.len() >= 2 && rest[1] == b'\'')
        }
        None => false,
    }
}

/// Every module path reached through `crate::` in `code`: (line, path),
/// where path is the first two segments (`io::ply`, or `Error`). Nested
/// groups `crate::{a::b, c::{d, e}}` give one entry per first segment.
fn crate_paths(code: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    let b = code.as_bytes();
    let mut start = 0;
    while let Some(pos) = code[start..].find("crate::") {
        let at = start + pos;
        start = at + 7;
        // `$crate::` in macros and identifiers ending in "crate" are not ours.
        if at > 0 && (b[at - 1] == b'$' || b[at - 1].is_ascii_alphanumeric() || b[at - 1] == b'_') {
            continue;
        }
        let line = code[..at].matches('\n').count() + 1;
        let rest = &code[at + 7..];
        if rest.trim_start().starts_with('{') {
            let open = rest.find('{').unwrap();
            let group = matching_group(&rest[open..]);
            for item in top_level_items(group) {
                found.push((line, two_segments(item)));
            }
        } else {
            found.push((line, two_segments(rest)));
        }
    }
    found
}

/// The text inside the brace group that `s` starts with.
fn matching_group(s: &str) -> &str {
    let mut depth = 0;
    for (i, ch) in s.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return &s[1..i];
                }
            }
            _ => {}
        }
    }
    &s[1..]
}

/// The comma-separated items of a group, ignoring commas of nested groups.
fn top_level_items(group: &str) -> Vec<&str> {
    let mut items = Vec::new();
    let mut depth = 0;
    let mut from = 0;
    for (i, ch) in group.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(group[from..i].trim());
                from = i + 1;
            }
            _ => {}
        }
    }
    items.push(group[from..].trim());
    items.into_iter().filter(|s| !s.is_empty()).collect()
}

/// `io::ply::Header` → `io::ply`; `Error` → `Error`; `ops::{a, b}` → `ops`.
fn two_segments(path: &str) -> String {
    let ident = |s: &str| -> String {
        s.trim_start()
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let first = ident(path);
    let after = path.trim_start()[first.len()..].trim_start();
    match after.strip_prefix("::") {
        Some(r) if !r.trim_start().starts_with('{') => format!("{first}::{}", ident(r)),
        _ => first,
    }
}

/// The op a file under `src/ops/` is (`ops/chamfer.rs` and
/// `ops/chamfer/x.rs` are both `chamfer`).
fn op_of(rel: &Path) -> Option<String> {
    let mut c = rel.components();
    if c.next()?.as_os_str() != "ops" {
        return None;
    }
    let name = c.next()?.as_os_str().to_str()?;
    Some(name.strip_suffix(".rs").unwrap_or(name).to_string())
}

/// Exported macros (`macro_rules! name` under `src/`) and the layer of the
/// file that defines each: `#[macro_export]` puts them at the crate root,
/// so `crate::name!` is judged by where the macro really lives.
fn macro_layers(src_root: &Path, files: &[PathBuf]) -> Vec<(String, &'static str)> {
    let mut out = Vec::new();
    for f in files {
        let Some(layer) = layer_of_file(f.strip_prefix(src_root).unwrap()) else {
            continue;
        };
        let code = code_only(&std::fs::read_to_string(f).unwrap());
        for (i, _) in code.match_indices("macro_rules!") {
            let name: String = code[i + 12..]
                .trim_start()
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            out.push((name, layer));
        }
    }
    out
}

/// Every forbidden import under `src_root`, as `file:line: message`.
fn violations(src_root: &Path) -> Vec<String> {
    let mut files = Vec::new();
    rust_files(src_root, &mut files);
    files.sort();
    let macros = macro_layers(src_root, &files);
    let mut bad = Vec::new();
    for file in files {
        let rel = file.strip_prefix(src_root).unwrap();
        let Some(layer) = layer_of_file(rel) else {
            continue;
        };
        let code = code_only(&std::fs::read_to_string(&file).unwrap());
        let this_op = op_of(rel);
        for (line, path) in crate_paths(&code) {
            let first = path.split("::").next().unwrap();
            if ANY_LAYER.contains(&first) {
                continue;
            }
            let shown = format!("src/{}:{line}: `crate::{path}`", rel.display());
            let by_macro = macros.iter().find(|(m, _)| m == first).map(|(_, l)| *l);
            let Some(target) = layer_of_module(first).or(by_macro) else {
                bad.push(format!("{shown} is not a module of the layer table"));
                continue;
            };
            if !allowed(layer).contains(&target) {
                bad.push(format!(
                    "{shown}: layer `{layer}` may not import `{target}` (DESIGN.md: {layer} imports only {})",
                    allowed(layer).join(", ")
                ));
                continue;
            }
            if let (Some(me), "ops") = (&this_op, target) {
                let op = path.split("::").nth(1).unwrap_or("");
                if !op.is_empty() && op != me && op != "mod" {
                    bad.push(format!(
                        "{shown}: op `{me}` reaches into op `{op}` (shared cores belong in a layer below ops)"
                    ));
                }
            }
        }
    }
    bad
}

#[test]
fn main_package_follows_the_layer_table() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let bad = violations(&root);
    assert!(
        bad.is_empty(),
        "{} imports against the layer table:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn render_crate_depends_on_no_part_of_the_main_package() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("render");
    let manifest = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
    let deps: BTreeSet<&str> = manifest
        .split("\n[")
        .filter(|s| s.starts_with("dependencies]"))
        .flat_map(|s| s.lines().skip(1))
        .filter_map(|l| l.split(['=', '.']).next())
        .map(str::trim)
        .filter(|n| !n.is_empty() && !n.starts_with('#'))
        .collect();
    assert!(
        !deps.contains("splatkit"),
        "render/Cargo.toml depends on the main package"
    );
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    for f in files {
        let code = code_only(&std::fs::read_to_string(&f).unwrap());
        assert!(
            !code.contains("splatkit::"),
            "{} names the main package",
            f.display()
        );
    }
}

/// The checker itself: a tree with known wrong imports must be caught, with
/// the file and line named, and a clean one must pass. (This is the test
/// that shows the layer test can fail.)
#[test]
fn checker_catches_wrong_imports() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    let write = |rel: &str, text: &str| {
        let p = src.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    };
    write(
        "io/any.rs",
        "use crate::model::Mesh;\nuse crate::{Error, Result};\n// crate::ops in a comment\nlet s = \"crate::cli\";\nfn f() { crate::cli::shown(p, false); }\n",
    );
    write(
        "eval/dtu.rs",
        "use crate::geom::knn::NnIndex;\nuse crate::{\n    io::dtu::ObsMask,\n    model::Mesh,\n};\n",
    );
    write(
        "ops/splat2points.rs",
        "use crate::ops::render::OrbitArgs;\nuse crate::ops::splat2points::x;\nuse crate::cli::Common;\n",
    );
    write(
        "geom/levelset.rs",
        "#[cfg(test)]\nmod t { fn f() { crate::ops::render::orbit(); } }\n",
    );
    write(
        "model/mesh.rs",
        "use crate::geom::x;\nuse crate::testing::shared_data;\n",
    );
    write(
        "app.rs",
        "use crate::ops::{chamfer, clean};\nuse crate::cli::exit_with;\n",
    );
    let bad = violations(src);
    let want = [
        "src/io/any.rs:5: `crate::cli::shown`: layer `io` may not import `cli`",
        "src/eval/dtu.rs:2: `crate::io::dtu`: layer `eval` may not import `io`",
        "src/ops/splat2points.rs:1: `crate::ops::render`: op `splat2points` reaches into op `render`",
        "src/geom/levelset.rs:2: `crate::ops::render`: layer `geom` may not import `ops`",
        "src/model/mesh.rs:1: `crate::geom::x`: layer `model` may not import `geom`",
    ];
    for w in want {
        assert!(
            bad.iter().any(|b| b.starts_with(w)),
            "expected a violation starting with {w:?}, got:\n{}",
            bad.join("\n")
        );
    }
    assert_eq!(
        bad.len(),
        want.len(),
        "unexpected extra findings:\n{}",
        bad.join("\n")
    );
}

#[test]
fn comment_and_string_stripping_keeps_lines() {
    let src = "a // crate::x\n/* crate::y\n */ b \"crate::z\" 'c' r#\"crate::w\"# crate::io::q\n";
    let code = code_only(src);
    assert_eq!(code.lines().count(), src.lines().count());
    assert_eq!(crate_paths(&code), vec![(3, "io::q".to_string())]);
}
