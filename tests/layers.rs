//! The layer table of docs/ARCHITECTURE.md ("Layers"), enforced: data flows
//! one way, and a module imports only from the layers below it.
//!
//! Every `.rs` file under `src/` belongs to the layer of its top folder
//! (`src/io/…` is `io`, `src/app.rs` and `src/bin/…` are the top, `bin`).
//! Comments and string literals are ignored; every module path in the code
//! is checked, in `use` lines, nested `use crate::{a::b, c::{d, e}}` groups
//! and paths written inline:
//!
//! - A `crate::…` path names the top-level module it reaches into; that
//!   module's layer must be one the table allows. Inside `src/ops/`, an op
//!   may also not reach into another op (`crate::ops::other`): shared cores
//!   live in the layers below.
//! - A `super::…` path counts like the `crate::…` path it resolves to. The
//!   module path of a file comes from its place under `src/`
//!   (`src/geom/meshing/poisson/density.rs` is
//!   `crate::geom::meshing::poisson::density`, a
//!   `mod.rs` names its folder) plus the inline `mod name { … }` blocks
//!   around the path, so `use super::*;` in `#[cfg(test)] mod tests { … }`
//!   is the file's own module. A chain that climbs above the crate root is
//!   an error.
//! - Only the layers model, geom, train, ops and bin may use the render
//!   crate: a `splatkit_render…` path in io, eval or cli is an error.
//! - `crate::{Error, Result}` and `crate::error` are open to every layer.
//!   `crate::testing` (test support) is open to test code only: items and
//!   modules under `#[cfg(test)]`, and files whose `mod name;` line in the
//!   parent file is under `#[cfg(test)]`. `src/lib.rs` must declare
//!   `mod testing;` under a `cfg` naming `test`, so it never ships.
//! - The render crate may not depend on the main package at all.
//!
//! A failure names the file, the line and the forbidden path, e.g.
//! ``src/io/any.rs:5: `crate::cli::shown`: layer `io` may not import `cli` ``.
//! The self-tests at the bottom feed the checker known bad trees, so the
//! checker itself is tested.

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// Layers of the main package that each layer may import
/// (docs/ARCHITECTURE.md, "Layers").
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

/// Layers that may use the render crate `splatkit_render`
/// (docs/ARCHITECTURE.md, "Layers": io, eval and cli may not).
const RENDER_USERS: &[&str] = &["model", "geom", "train", "ops", "bin"];

/// Top-level modules open to every layer. (`testing` is not among them: it
/// is open to test code only.)
const ANY_LAYER: &[&str] = &["Error", "Result", "error"];

/// The test-support module, open to `#[cfg(test)]` code only.
const TESTING: &str = "testing";

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
        // lib.rs only declares modules; error.rs and testing.rs belong to
        // no layer.
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

fn is_ident_byte(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// The identifier `s` starts with (after leading whitespace).
fn ident(s: &str) -> &str {
    let s = s.trim_start();
    let starts = s
        .bytes()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == b'_');
    if !starts {
        return "";
    }
    let n = s.bytes().take_while(|&c| is_ident_byte(c)).count();
    &s[..n]
}

/// The 1-based line of byte offset `at`, given the offsets where lines start.
fn line_at(line_starts: &[usize], at: usize) -> usize {
    line_starts.partition_point(|&s| s <= at)
}

fn line_starts(code: &str) -> Vec<usize> {
    std::iter::once(0)
        .chain(code.match_indices('\n').map(|(i, _)| i + 1))
        .collect()
}

/// The text inside the bracket group that `s` starts with (`{…}`, `(…)`
/// or `[…]`; brackets of all kinds nest).
fn matching_group(s: &str) -> &str {
    match group_end(s.as_bytes(), 0) {
        Some(end) => &s[1..end],
        None => &s[1..],
    }
}

/// The offset of the bracket that closes the one at `open`.
fn group_end(b: &[u8], open: usize) -> Option<usize> {
    let mut depth = 0usize;
    for (i, &c) in b.iter().enumerate().skip(open) {
        match c {
            b'{' | b'(' | b'[' => depth += 1,
            b'}' | b')' | b']' => {
                depth = depth.checked_sub(1)?;
                if depth == 0 {
                    return Some(i);
                }
            }
            _ => {}
        }
    }
    None
}

/// The comma-separated items of a group, ignoring commas of nested groups.
fn top_level_items(group: &str) -> Vec<&str> {
    let mut items = Vec::new();
    let mut depth = 0i32;
    let mut from = 0;
    for (i, ch) in group.char_indices() {
        match ch {
            '{' | '(' | '[' => depth += 1,
            '}' | ')' | ']' => depth -= 1,
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

/// The module paths written at the start of `s` (the text after `head::`),
/// one per leaf of nested groups: `a::{b, c::{d, self}}` gives `a::b`,
/// `a::c::d` and `a::c`. A path ends where a segment is not followed by
/// `::` (`x as y`, `f(…)`, `::<T>`); a glob is the segment `*`.
fn expand(s: &str) -> Vec<Vec<String>> {
    let s = s.trim_start();
    if s.starts_with('{') {
        let out: Vec<_> = top_level_items(matching_group(s))
            .into_iter()
            .flat_map(expand)
            .collect();
        return if out.is_empty() { vec![vec![]] } else { out };
    }
    let name = ident(s);
    if name.is_empty() {
        return vec![if s.starts_with('*') {
            vec!["*".to_string()]
        } else {
            vec![]
        }];
    }
    let tails = match s[name.len()..].trim_start().strip_prefix("::") {
        Some(r) => expand(r),
        None => vec![vec![]],
    };
    tails
        .into_iter()
        .map(|mut t| {
            if name != "self" {
                t.insert(0, name.to_string());
            }
            t
        })
        .collect()
}

/// Every path in `code` that starts with the identifier `head`: (offset of
/// `head`, segments after it), one per leaf of nested groups. `$head` (macro
/// metavariables) and identifiers that merely contain `head` are not paths;
/// `bare` also counts `head` not followed by `::` (`use head as x;`).
fn paths_from(code: &str, head: &str, bare: bool) -> Vec<(usize, Vec<String>)> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    for (at, _) in code.match_indices(head) {
        if at > 0 && (b[at - 1] == b'$' || is_ident_byte(b[at - 1])) {
            continue;
        }
        let rest = &code[at + head.len()..];
        if rest.bytes().next().is_some_and(is_ident_byte) {
            continue;
        }
        match rest.trim_start().strip_prefix("::") {
            Some(r) => out.extend(expand(r).into_iter().map(|p| (at, p))),
            None if bare => out.push((at, vec![])),
            None => {}
        }
    }
    out
}

/// Every module path reached through `crate::` in `code`: (line, path),
/// where path is the first two segments (`io::ply`, or `Error`). Nested
/// groups give one entry per leaf.
fn crate_paths(code: &str) -> Vec<(usize, String)> {
    let starts = line_starts(code);
    paths_from(code, "crate", false)
        .into_iter()
        .map(|(at, p)| (line_at(&starts, at), two_segments(&p)))
        .collect()
}

/// `[io, ply, Header]` → `io::ply`; `[Error]` → `Error`.
fn two_segments(path: &[String]) -> String {
    path.iter().take(2).cloned().collect::<Vec<_>>().join("::")
}

/// A `super::` chain in the code.
struct SuperPath {
    /// Offset where the chain starts.
    at: usize,
    /// How many levels it climbs.
    up: usize,
    /// The chain as written (`super::super::`).
    chain: String,
    /// The paths after the chain, one per leaf of nested groups.
    tails: Vec<Vec<String>>,
}

/// Every `super::…` chain in `code` (also `self::super::…`). `pub(super)`
/// names no path and is skipped.
fn super_paths(code: &str) -> Vec<SuperPath> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    for (at, _) in code.match_indices("super") {
        if at > 0 && (b[at - 1] == b'$' || is_ident_byte(b[at - 1])) {
            continue;
        }
        if b.get(at + 5).is_some_and(|&c| is_ident_byte(c)) {
            continue;
        }
        let before = code[..at].trim_end();
        let mut chain = String::new();
        let mut start = at;
        if let Some(pre) = before.strip_suffix("::") {
            // Inside a chain (counted from its first `super`), or `self::super`.
            let pre = pre.trim_end();
            let Some(pre_self) = pre.strip_suffix("self") else {
                continue;
            };
            let pb = pre_self.as_bytes();
            let standalone = pb.last().is_none_or(|&c| !is_ident_byte(c) && c != b'$')
                && !pre_self.trim_end().ends_with("::");
            if !standalone {
                continue;
            }
            chain.push_str("self::");
            start = pre_self.len();
        }
        let mut pos = at;
        let mut up = 0;
        let mut bare_end = false;
        while code[pos..].starts_with("super") && !b.get(pos + 5).is_some_and(|&c| is_ident_byte(c))
        {
            up += 1;
            let after = code[pos + 5..].trim_start();
            let after_at = code.len() - after.len();
            match after.strip_prefix("::") {
                Some(r) => {
                    chain.push_str("super::");
                    pos = code.len() - r.trim_start().len();
                }
                None => {
                    chain.push_str("super");
                    pos = after_at;
                    bare_end = true;
                    break;
                }
            }
        }
        if !chain.contains("super::") {
            continue; // `pub(super)`, `pub(in super)`
        }
        let tails = if bare_end {
            vec![vec![]]
        } else {
            expand(&code[pos..])
        };
        out.push(SuperPath {
            at: start,
            up,
            chain,
            tails,
        });
    }
    out
}

/// The predicate of a `cfg(…)` attribute (the text inside `#[…]`).
fn cfg_predicate(attr: &str) -> Option<&str> {
    let name = ident(attr);
    if name != "cfg" {
        return None;
    }
    let rest = attr.trim_start()[name.len()..].trim_start();
    rest.starts_with('(').then(|| matching_group(rest))
}

/// Whether a cfg predicate holds only in test builds (`test`,
/// `all(test, …)`, `any(all(test, a), test)`).
fn implies_test(pred: &str) -> bool {
    let name = ident(pred);
    let rest = pred.trim_start()[name.len()..].trim_start();
    if rest.starts_with('(') {
        let items = top_level_items(matching_group(rest));
        match name {
            "all" => items.iter().any(|p| implies_test(p)),
            "any" => !items.is_empty() && items.iter().all(|p| implies_test(p)),
            _ => false,
        }
    } else {
        name == "test" && rest.is_empty()
    }
}

/// Whether a cfg predicate names `test` (not under `not(…)`):
/// `any(test, feature = "testing")` does.
fn mentions_test(pred: &str) -> bool {
    let name = ident(pred);
    let rest = pred.trim_start()[name.len()..].trim_start();
    if rest.starts_with('(') {
        let items = top_level_items(matching_group(rest));
        matches!(name, "all" | "any") && items.iter().any(|p| mentions_test(p))
    } else {
        name == "test" && rest.is_empty()
    }
}

/// How an item ends, for finding the extent of a `#[cfg(test)]` item.
#[derive(Clone, Copy, PartialEq)]
enum ItemKind {
    /// `fn`, `mod`, `impl`, `struct`, a block, a macro call…: at the `}`
    /// that closes its body, or a `;`.
    Braced,
    /// `use`, `const`, `static`, `type`, `let`: at a `;`.
    Statement,
    /// Anything else (a field, an argument, a match arm): at a `,` or `;`.
    Other,
}

/// The offset just past the item that starts at `start` (after its
/// attributes). An item also ends where its enclosing group closes.
fn item_end(code: &str, start: usize) -> usize {
    let b = code.as_bytes();
    let skip_ws = |mut j: usize| {
        while j < b.len() && b[j].is_ascii_whitespace() {
            j += 1;
        }
        j
    };
    let mut kind = ItemKind::Other;
    let mut j = start;
    if b[start] == b'{' {
        kind = ItemKind::Braced;
    } else {
        loop {
            let w = ident(&code[j..]);
            if w.is_empty() {
                break;
            }
            let after = skip_ws(j + w.len());
            match w {
                "pub" => {
                    j = after;
                    if b.get(j) == Some(&b'(') {
                        j = skip_ws(group_end(b, j).map_or(b.len(), |e| e + 1));
                    }
                }
                "unsafe" | "async" | "default" | "extern" => j = after,
                "const" => {
                    if matches!(ident(&code[after..]), "fn" | "unsafe" | "async" | "extern") {
                        j = after;
                    } else {
                        kind = ItemKind::Statement;
                        break;
                    }
                }
                "use" | "static" | "type" | "let" => {
                    kind = ItemKind::Statement;
                    break;
                }
                "fn" | "mod" | "impl" | "trait" | "struct" | "enum" | "union" => {
                    kind = ItemKind::Braced;
                    break;
                }
                _ => {
                    if b.get(after) == Some(&b'!') {
                        kind = ItemKind::Braced;
                    }
                    break;
                }
            }
        }
    }
    let mut depth = 0usize;
    for (k, &c) in b.iter().enumerate().skip(start) {
        match c {
            b'{' | b'(' | b'[' => depth += 1,
            b'}' | b')' | b']' => {
                if depth == 0 {
                    return k;
                }
                depth -= 1;
                if depth == 0 && c == b'}' && kind == ItemKind::Braced {
                    return k + 1;
                }
            }
            b';' if depth == 0 => return k + 1,
            b',' if depth == 0 && kind == ItemKind::Other => return k,
            _ => {}
        }
    }
    b.len()
}

/// What the module structure of one file's (blanked) code says.
#[derive(Default)]
struct Scan {
    /// Inline `mod name { … }` blocks: (start, end, name), outer first.
    mods: Vec<(usize, usize, String)>,
    /// Byte ranges of items under `#[cfg(test)]` (or `all(test, …)`).
    tests: Vec<(usize, usize)>,
    /// `mod name;` lines: (offset, name, the attributes of the item).
    decls: Vec<(usize, String, Vec<String>)>,
    /// `#![cfg(test)]` at the top of the file.
    file_test: bool,
}

impl Scan {
    fn of(code: &str) -> Scan {
        let b = code.as_bytes();
        let mut s = Scan::default();
        // Attributes seen since the last item started: (first offset, texts).
        let mut pending: Option<(usize, Vec<String>)> = None;
        // Items that started with attributes: (offset, the attributes).
        let mut attributed: Vec<(usize, Vec<String>)> = Vec::new();
        let mut i = 0;
        while i < b.len() {
            let c = b[i];
            let inner = c == b'#' && b.get(i + 1) == Some(&b'!') && b.get(i + 2) == Some(&b'[');
            if c == b'#' && (b.get(i + 1) == Some(&b'[') || inner) {
                let open = if inner { i + 2 } else { i + 1 };
                let end = group_end(b, open).unwrap_or(b.len() - 1);
                let text = code[open + 1..end].to_string();
                if inner {
                    if cfg_predicate(&text).is_some_and(implies_test) {
                        match s.mods.iter().rev().find(|m| m.0 < i && i < m.1) {
                            Some(m) => s.tests.push((m.0, m.1)),
                            None => s.file_test = true,
                        }
                    }
                } else {
                    pending.get_or_insert_with(|| (i, Vec::new())).1.push(text);
                }
                i = end + 1;
                continue;
            }
            if c.is_ascii_whitespace() {
                i += 1;
                continue;
            }
            let word_start = (c.is_ascii_alphabetic() || c == b'_') && !prev_ident(b, i);
            if let Some((from, attrs)) = pending.take() {
                if attrs
                    .iter()
                    .any(|a| cfg_predicate(a).is_some_and(implies_test))
                {
                    s.tests.push((from, item_end(code, i)));
                }
                attributed.push((i, attrs));
            }
            if !word_start {
                i += 1;
                continue;
            }
            let w = ident(&code[i..]);
            if w == "mod" {
                let after = &code[i + 3..];
                let name = ident(after);
                let rest = after.trim_start()[name.len()..].trim_start();
                let at_rest = code.len() - rest.len();
                if !name.is_empty() && rest.starts_with('{') {
                    let end = group_end(b, at_rest).map_or(b.len(), |e| e + 1);
                    s.mods.push((i, end, name.to_string()));
                } else if !name.is_empty() && rest.starts_with(';') {
                    // The attributes of this item, if it has any: those of
                    // the last attributed item, when only a visibility
                    // stands between it and `mod`.
                    let attrs = attributed
                        .last()
                        .filter(|(from, _)| {
                            let lead = &code[*from..i];
                            lead.trim().is_empty() || is_visibility(lead)
                        })
                        .map(|(_, a)| a.clone())
                        .unwrap_or_default();
                    s.decls.push((i, name.to_string(), attrs));
                }
            }
            i += w.len();
        }
        s
    }

    /// The names of the inline modules around offset `at`, outer first.
    fn mods_at(&self, at: usize) -> impl Iterator<Item = &str> {
        self.mods
            .iter()
            .filter(move |m| m.0 < at && at < m.1)
            .map(|m| m.2.as_str())
    }

    fn in_test_item(&self, at: usize) -> bool {
        self.tests.iter().any(|&(s, e)| s <= at && at < e)
    }
}

/// `pub`, `pub(crate)`, `pub(in a::b)`: a visibility and nothing else.
fn is_visibility(s: &str) -> bool {
    let t = s.trim();
    t.strip_prefix("pub").is_some_and(|r| {
        let r = r.trim();
        r.is_empty() || (r.starts_with('(') && r.ends_with(')') && !r.contains([';', '{', '}']))
    })
}

/// The crate a file under `src/` is compiled into (`lib`, or `bin/NAME`)
/// and its module path in that crate: `geom/meshing/poisson/density.rs` is
/// `[geom, meshing, poisson, density]`, `geom/meshing/poisson/mod.rs` is
/// `[geom, meshing, poisson]`,
/// `bin/info.rs` is the root of the binary `info`.
fn module_of(rel: &Path) -> (String, Vec<String>) {
    let parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    let (krate, rest, root) = if parts[0] == "bin" && parts.len() == 2 {
        let name = parts[1].trim_end_matches(".rs");
        return (format!("bin/{name}"), Vec::new());
    } else if parts[0] == "bin" {
        (format!("bin/{}", parts[1]), &parts[2..], "main")
    } else {
        ("lib".to_string(), &parts[..], "lib")
    };
    let mut module: Vec<String> = rest.to_vec();
    let last = module.pop().unwrap_or_default();
    let stem = last.strip_suffix(".rs").unwrap_or(&last);
    if stem != "mod" && !(module.is_empty() && stem == root) {
        module.push(stem.to_string());
    }
    (krate, module)
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
fn macro_layers(files: &[SourceFile]) -> Vec<(String, &'static str)> {
    let mut out = Vec::new();
    for f in files {
        let Some(layer) = f.layer else {
            continue;
        };
        for (i, _) in f.code.match_indices("macro_rules!") {
            out.push((ident(&f.code[i + 12..]).to_string(), layer));
        }
    }
    out
}

/// One file under `src/`, read and scanned.
struct SourceFile {
    rel: PathBuf,
    layer: Option<&'static str>,
    code: String,
    krate: String,
    module: Vec<String>,
    scan: Scan,
    /// The whole file is test code (declared under `#[cfg(test)]`).
    test: bool,
}

impl SourceFile {
    fn in_test(&self, at: usize) -> bool {
        self.test || self.scan.in_test_item(at)
    }
}

/// Reads every `.rs` file under `src_root` and works out which are test
/// code: a file is when the `mod name;` line that declares it is under
/// `#[cfg(test)]` or inside test code itself.
fn read_tree(src_root: &Path) -> Vec<SourceFile> {
    let mut paths = Vec::new();
    rust_files(src_root, &mut paths);
    paths.sort();
    let mut files: Vec<SourceFile> = paths
        .into_iter()
        .map(|p| {
            let rel = p.strip_prefix(src_root).unwrap().to_path_buf();
            let code = code_only(&std::fs::read_to_string(&p).unwrap());
            let (krate, module) = module_of(&rel);
            let scan = Scan::of(&code);
            SourceFile {
                layer: layer_of_file(&rel),
                test: scan.file_test,
                rel,
                code,
                krate,
                module,
                scan,
            }
        })
        .collect();
    // Parents before children, so that a test file's own declarations
    // are test code too.
    let mut order: Vec<usize> = (0..files.len()).collect();
    order.sort_by_key(|&i| files[i].module.len());
    // (crate, module path) → declared as test code (every declaration).
    let mut declared: HashMap<(String, Vec<String>), bool> = HashMap::new();
    for i in order {
        let key = (files[i].krate.clone(), files[i].module.clone());
        if declared.get(&key) == Some(&true) {
            files[i].test = true;
        }
        let f = &files[i];
        for (at, name, attrs) in &f.scan.decls {
            let mut module = f.module.clone();
            module.extend(f.scan.mods_at(*at).map(str::to_string));
            module.push(name.clone());
            let test = f.in_test(*at)
                || attrs
                    .iter()
                    .any(|a| cfg_predicate(a).is_some_and(implies_test));
            let e = declared.entry((f.krate.clone(), module)).or_insert(true);
            *e &= test;
        }
    }
    files
}

/// Every forbidden path under `src_root`, as `file:line: message`.
fn violations(src_root: &Path) -> Vec<String> {
    let files = read_tree(src_root);
    let macros = macro_layers(&files);
    let mut bad = Vec::new();
    for f in &files {
        let Some(layer) = f.layer else {
            continue;
        };
        let starts = line_starts(&f.code);
        let file = format!("src/{}", f.rel.display());
        // The op this file is part of (`ops/mod.rs` is no op).
        let this_op = op_of(&f.rel).filter(|op| op != "mod");
        let check = |at: usize, path: &[String], shown: String| -> Option<String> {
            let first = path.first().map_or("", String::as_str);
            let line = line_at(&starts, at);
            let shown = format!("{file}:{line}: {shown}");
            if first == TESTING {
                if !f.in_test(at) {
                    return Some(format!(
                        "{shown}: `crate::testing` is test support, used here outside `#[cfg(test)]` code (docs/ARCHITECTURE.md: never from code that ships in a command)"
                    ));
                }
                return None;
            }
            if ANY_LAYER.contains(&first) {
                return None;
            }
            let by_macro = macros.iter().find(|(m, _)| m == first).map(|(_, l)| *l);
            let Some(target) = layer_of_module(first).or(by_macro) else {
                return Some(format!("{shown} is not a module of the layer table"));
            };
            if !allowed(layer).contains(&target) {
                return Some(format!(
                    "{shown}: layer `{layer}` may not import `{target}` (docs/ARCHITECTURE.md: {layer} imports only {})",
                    allowed(layer).join(", ")
                ));
            }
            if let (Some(me), "ops") = (&this_op, target) {
                let op = path.get(1).map_or("", String::as_str);
                if !op.is_empty() && op != me && op != "mod" {
                    return Some(format!(
                        "{shown}: op `{me}` reaches into op `{op}` (shared cores belong in a layer below ops)"
                    ));
                }
            }
            None
        };
        for (at, path) in paths_from(&f.code, "crate", false) {
            bad.extend(check(
                at,
                &path,
                format!("`crate::{}`", two_segments(&path)),
            ));
        }
        for sp in super_paths(&f.code) {
            let mut here = f.module.clone();
            here.extend(f.scan.mods_at(sp.at).map(str::to_string));
            for tail in &sp.tails {
                let written = format!("{}{}", sp.chain, tail.join("::"));
                let written = written.trim_end_matches("::");
                if sp.up > here.len() {
                    let line = line_at(&starts, sp.at);
                    let module = std::iter::once("crate")
                        .chain(here.iter().map(String::as_str))
                        .collect::<Vec<_>>()
                        .join("::");
                    bad.push(format!(
                        "{file}:{line}: `{written}`: climbs above the crate root (from `{module}`, {} levels up)",
                        sp.up
                    ));
                    continue;
                }
                let mut full = here[..here.len() - sp.up].to_vec();
                full.extend(tail.iter().cloned());
                let resolved = std::iter::once("crate")
                    .chain(full.iter().take(2).map(String::as_str))
                    .collect::<Vec<_>>()
                    .join("::");
                bad.extend(check(sp.at, &full, format!("`{written}` = `{resolved}`")));
            }
        }
        // The library's test support, named from a binary.
        for (at, path) in paths_from(&f.code, "splatkit", false) {
            if path.first().is_some_and(|p| p == TESTING) && !f.in_test(at) {
                let line = line_at(&starts, at);
                bad.push(format!(
                    "{file}:{line}: `splatkit::{}`: `splatkit::testing` is test support, used here outside `#[cfg(test)]` code (docs/ARCHITECTURE.md: never from code that ships in a command)",
                    path.join("::")
                ));
            }
        }
        if !RENDER_USERS.contains(&layer) {
            for (at, path) in paths_from(&f.code, "splatkit_render", true) {
                let line = line_at(&starts, at);
                let shown = std::iter::once("splatkit_render")
                    .chain(path.iter().map(String::as_str))
                    .collect::<Vec<_>>()
                    .join("::");
                bad.push(format!(
                    "{file}:{line}: `{shown}`: layer `{layer}` may not use the render crate (docs/ARCHITECTURE.md: only {} may)",
                    RENDER_USERS.join(", ")
                ));
            }
        }
    }
    bad
}

/// `src/lib.rs` (its text) must declare `mod testing;` under a `cfg`
/// attribute that names `test`, so the test support never ships.
fn testing_gate(lib_rs: &str) -> Result<(), String> {
    let code = code_only(lib_rs);
    let scan = Scan::of(&code);
    let Some((at, _, attrs)) = scan
        .decls
        .iter()
        .find(|(at, name, _)| name == TESTING && scan.mods_at(*at).next().is_none())
    else {
        return Ok(());
    };
    if attrs
        .iter()
        .any(|a| cfg_predicate(a).is_some_and(mentions_test))
    {
        return Ok(());
    }
    let line = line_at(&line_starts(&code), *at);
    Err(format!(
        "src/lib.rs:{line}: `mod testing;` is not under a `cfg` attribute naming `test` (want `#[cfg(any(test, feature = \"testing\"))]`; docs/ARCHITECTURE.md: `crate::testing` is test support only)"
    ))
}

#[test]
fn main_package_follows_the_layer_table() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let bad = violations(&root);
    assert!(
        bad.is_empty(),
        "{} paths against the layer table (docs/ARCHITECTURE.md, \"Layers\"):\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn testing_module_is_compiled_for_tests_only() {
    let lib = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs");
    if let Err(e) = testing_gate(&std::fs::read_to_string(lib).unwrap()) {
        panic!("{e}");
    }
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

/// Runs the checker on an in-memory tree of `(path under src/, text)`.
fn check_tree(files: &[(&str, &str)]) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    for (rel, text) in files {
        let p = dir.path().join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    violations(dir.path())
}

/// Each of `want` starts one finding of `bad`, and there are no others.
fn assert_findings(bad: &[String], want: &[&str]) {
    // Shown with `cargo test --test layers -- --nocapture`.
    for b in bad {
        println!("{b}");
    }
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

/// The checker itself: a tree with known wrong imports must be caught, with
/// the file and line named, and a clean one must pass. (This is the test
/// that shows the layer test can fail.)
#[test]
fn checker_catches_wrong_imports() {
    let bad = check_tree(&[
        (
            "io/any.rs",
            "use crate::model::Mesh;\nuse crate::{Error, Result};\n// crate::ops in a comment\nlet s = \"crate::cli\";\nfn f() { crate::cli::shown(p, false); }\n",
        ),
        (
            "eval/dtu.rs",
            "use crate::geom::knn::NnIndex;\nuse crate::{\n    io::dtu::ObsMask,\n    model::Mesh,\n};\n",
        ),
        (
            "ops/splat2points.rs",
            "use crate::ops::render::OrbitArgs;\nuse crate::ops::splat2points::x;\nuse crate::cli::Common;\n",
        ),
        (
            "geom/levelset.rs",
            "#[cfg(test)]\nmod t { fn f() { crate::ops::render::orbit(); } }\n",
        ),
        (
            "model/mesh.rs",
            "use crate::geom::x;\nuse crate::testing::shared_data;\n",
        ),
        (
            "app.rs",
            "use crate::ops::{chamfer, clean};\nuse crate::cli::exit_with;\n",
        ),
    ]);
    assert_findings(
        &bad,
        &[
            "src/io/any.rs:5: `crate::cli::shown`: layer `io` may not import `cli`",
            "src/eval/dtu.rs:2: `crate::io::dtu`: layer `eval` may not import `io`",
            "src/ops/splat2points.rs:1: `crate::ops::render`: op `splat2points` reaches into op `render`",
            "src/geom/levelset.rs:2: `crate::ops::render`: layer `geom` may not import `ops`",
            "src/model/mesh.rs:1: `crate::geom::x`: layer `model` may not import `geom`",
            // Shipping code of model/mesh.rs: test support is not open to it.
            "src/model/mesh.rs:2: `crate::testing::shared_data`: `crate::testing` is test support",
        ],
    );
}

/// io, eval and cli may not use the render crate, in any form of path;
/// the other layers may.
#[test]
fn checker_catches_render_crate_in_io_eval_cli() {
    let bad = check_tree(&[
        (
            "io/ply/soup.rs",
            "use glam::Vec3;\nuse splatkit_render::sh::sh_to_rgb;\nfn f() { let c = ::splatkit_render::camera::Camera::default(); }\nuse splatkit_render::{mesh::render, sh::{a, b}};\n// splatkit_render::x in a comment\nconst S: &str = \"splatkit_render::y\";\n",
        ),
        ("eval/cull.rs", "use splatkit_render as r;\n"),
        (
            "cli/orbit.rs",
            "\n#[cfg(test)]\nmod tests { use splatkit_render::camera::Camera; }\n",
        ),
    ]);
    assert_findings(
        &bad,
        &[
            "src/io/ply/soup.rs:2: `splatkit_render::sh::sh_to_rgb`: layer `io` may not use the render crate",
            "src/io/ply/soup.rs:3: `splatkit_render::camera::Camera::default`: layer `io` may not use the render crate",
            "src/io/ply/soup.rs:4: `splatkit_render::mesh::render`: layer `io`",
            "src/io/ply/soup.rs:4: `splatkit_render::sh::a`: layer `io`",
            "src/io/ply/soup.rs:4: `splatkit_render::sh::b`: layer `io`",
            "src/eval/cull.rs:1: `splatkit_render`: layer `eval` may not use the render crate",
            "src/cli/orbit.rs:3: `splatkit_render::camera::Camera`: layer `cli` may not use the render crate",
        ],
    );
    let good = check_tree(&[
        (
            "model/camera.rs",
            "pub use splatkit_render::camera::{Camera, CameraModel};\n",
        ),
        ("geom/x.rs", "use splatkit_render::mesh::render;\n"),
        (
            "train/x.rs",
            "fn f() { splatkit_render::sh::sh_to_rgb(); }\n",
        ),
        (
            "ops/render.rs",
            "use splatkit_render::{camera::Camera, mesh};\n",
        ),
        ("bin/render.rs", "use splatkit_render::mesh;\n"),
        (
            "io/cameras/mod.rs",
            "//! Same axes as [`splatkit_render::camera`].\nuse crate::model::Camera;\nfn my_splatkit_render() {}\n",
        ),
    ]);
    assert_findings(&good, &[]);
}

/// `super::` chains resolve from the file's module path, inline `mod`
/// blocks included, and count like the `crate::` path they reach.
#[test]
fn checker_resolves_super_paths() {
    let bad = check_tree(&[
        // `crate::io::a::b`: three levels up is the crate root.
        ("io/a/b.rs", "use super::super::super::cli::x;\n"),
        // `crate::io::a` (a mod.rs names its folder): two levels up.
        ("io/a/mod.rs", "mod b;\nuse super::super::cli::x;\n"),
        ("geom/x.rs", "fn f() {}\nuse super::super::super::y;\n"),
        (
            "ops/chamfer/core.rs",
            "use super::super::render::orbit;\nuse super::super::{clean::run, chamfer::y};\n",
        ),
        (
            "eval/tnt/plot.rs",
            "#[cfg(test)]\nmod tests {\n    use super::*;\n    use super::super::super::super::io::x;\n}\n",
        ),
        ("cli/mod.rs", "use super::{model::Mesh, geom::knn};\n"),
    ]);
    assert_findings(
        &bad,
        &[
            "src/io/a/b.rs:1: `super::super::super::cli::x` = `crate::cli::x`: layer `io` may not import `cli`",
            "src/io/a/mod.rs:2: `super::super::cli::x` = `crate::cli::x`: layer `io` may not import `cli`",
            "src/geom/x.rs:2: `super::super::super::y`: climbs above the crate root",
            "src/ops/chamfer/core.rs:1: `super::super::render::orbit` = `crate::ops::render`: op `chamfer` reaches into op `render`",
            "src/ops/chamfer/core.rs:2: `super::super::clean::run` = `crate::ops::clean`: op `chamfer` reaches into op `clean`",
            // Inside `mod tests`, four levels up from eval::tnt::plot::tests.
            "src/eval/tnt/plot.rs:4: `super::super::super::super::io::x` = `crate::io::x`: layer `eval` may not import `io`",
            "src/cli/mod.rs:1: `super::geom::knn` = `crate::geom::knn`: layer `cli` may not import `geom`",
        ],
    );
    let good = check_tree(&[
        (
            "io/a/b.rs",
            "use super::c;\npub(super) fn f() {}\npub(in super::super) fn g() {}\n#[cfg(test)]\nmod tests {\n    use super::*;\n    use super::super::d;\n    fn t() { super::f(); }\n}\n",
        ),
        // From `crate::io::a::c`, two levels up is `crate::io`: this is
        // `crate::io::cli`, inside io.
        ("io/a/c.rs", "use super::super::cli::x;\n"),
        (
            "io/mod.rs",
            "use super::model::Mesh;\nuse super::{Error, Result};\n",
        ),
        (
            "ops/chamfer/core.rs",
            "use super::super::chamfer::x;\nuse super::y;\n",
        ),
        (
            "ops/mod.rs",
            "pub mod chamfer;\n#[cfg(test)]\nmod tests { use super::*; use super::chamfer::x; }\n",
        ),
        (
            "geom/poisson/density.rs",
            "use super::super::super::model::Mesh;\n",
        ),
    ]);
    assert_findings(&good, &[]);
}

/// `crate::testing` is open to `#[cfg(test)]` code only: inline test
/// modules and items, and files declared under `#[cfg(test)]`.
#[test]
fn checker_keeps_testing_out_of_shipping_code() {
    let bad = check_tree(&[
        ("geom/x.rs", "use crate::testing::x;\nfn f() {}\n"),
        (
            "geom/y.rs",
            "#[cfg(test)]\nfn helper() { crate::testing::a(); }\nfn ship() { crate::testing::b(); }\n#[cfg(not(test))]\nuse crate::testing::c;\n#[cfg(any(test, unix))]\nuse crate::testing::d;\n",
        ),
        ("geom/b/mod.rs", "mod helpers;\n#[cfg(test)]\nmod tests;\n"),
        ("geom/b/helpers.rs", "pub use crate::testing::e;\n"),
        ("geom/b/tests.rs", "use crate::testing::f;\n"),
        ("io/mod.rs", "fn g() { super::testing::h(); }\n"),
        (
            "bin/info.rs",
            "use splatkit::testing::i;\nuse splatkit::io;\n",
        ),
    ]);
    assert_findings(
        &bad,
        &[
            "src/geom/x.rs:1: `crate::testing::x`: `crate::testing` is test support, used here outside `#[cfg(test)]` code",
            "src/geom/y.rs:3: `crate::testing::b`: `crate::testing` is test support",
            "src/geom/y.rs:5: `crate::testing::c`: `crate::testing` is test support",
            "src/geom/y.rs:7: `crate::testing::d`: `crate::testing` is test support",
            "src/geom/b/helpers.rs:1: `crate::testing::e`: `crate::testing` is test support",
            "src/io/mod.rs:1: `super::testing::h` = `crate::testing::h`: `crate::testing` is test support",
            "src/bin/info.rs:1: `splatkit::testing::i`: `splatkit::testing` is test support",
        ],
    );
    let good = check_tree(&[
        (
            "geom/x.rs",
            "fn f() {}\n#[cfg(test)]\nmod tests {\n    use crate::testing::x;\n    use super::*;\n}\n",
        ),
        (
            "geom/y.rs",
            "#[cfg(test)]\nuse crate::testing::{a, b};\n#[cfg(all(test, unix))]\n#[allow(dead_code)]\npub(crate) fn helper() { crate::testing::c(); }\n",
        ),
        (
            "geom/b/mod.rs",
            "#[cfg(test)]\n#[allow(unused)]\npub(crate) mod tests;\n",
        ),
        ("geom/b/tests.rs", "use crate::testing::f;\nmod more;\n"),
        ("geom/b/tests/more.rs", "use crate::testing::g;\n"),
        ("io/dataset.rs", "#[cfg(test)]\nmod tests;\n"),
        ("io/dataset/tests.rs", "use crate::testing::shared_data;\n"),
        (
            "bin/info.rs",
            "#[cfg(test)]\nmod tests { use splatkit::testing::i; }\n",
        ),
    ]);
    assert_findings(&good, &[]);
}

#[test]
fn checker_requires_the_testing_module_to_be_gated() {
    let bad = testing_gate("pub mod app;\n#[doc(hidden)]\npub mod testing;\npub mod train;\n");
    assert_eq!(
        bad.unwrap_err().split(" (want").next().unwrap(),
        "src/lib.rs:3: `mod testing;` is not under a `cfg` attribute naming `test`"
    );
    assert!(testing_gate("#[cfg(not(test))]\npub mod testing;\n").is_err());
    assert!(testing_gate("#[cfg(feature = \"test\")]\npub mod testing;\n").is_err());
    assert!(
        testing_gate("#[cfg(test)]\npub mod app;\npub mod testing;\n").is_err(),
        "the attribute of another item does not count"
    );
    testing_gate("#[cfg(any(test, feature = \"testing\"))]\n#[doc(hidden)]\npub mod testing;\n")
        .unwrap();
    testing_gate("#[doc(hidden)]\n#[cfg(test)]\npub(crate) mod testing;\n").unwrap();
}

#[test]
fn comment_and_string_stripping_keeps_lines() {
    let src = "a // crate::x\n/* crate::y\n */ b \"crate::z\" 'c' r#\"crate::w\"# crate::io::q\n";
    let code = code_only(src);
    assert_eq!(code.lines().count(), src.lines().count());
    assert_eq!(crate_paths(&code), vec![(3, "io::q".to_string())]);
}

#[test]
fn paths_and_module_paths() {
    assert_eq!(
        expand("{a::b, c::{d, self}, e as f, g::*}; x"),
        vec![
            vec!["a", "b"],
            vec!["c", "d"],
            vec!["c"],
            vec!["e"],
            vec!["g", "*"]
        ]
    );
    let m = |p: &str| module_of(Path::new(p));
    let v = |s: &[&str]| s.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    assert_eq!(
        m("geom/poisson/density.rs"),
        ("lib".into(), v(&["geom", "poisson", "density"]))
    );
    assert_eq!(
        m("geom/poisson/mod.rs"),
        ("lib".into(), v(&["geom", "poisson"]))
    );
    assert_eq!(m("lib.rs"), ("lib".into(), v(&[])));
    assert_eq!(m("app.rs"), ("lib".into(), v(&["app"])));
    assert_eq!(m("bin/info.rs"), ("bin/info".into(), v(&[])));
    assert!(implies_test("all(test, unix)"));
    assert!(!implies_test("any(test, feature =          )"));
    assert!(mentions_test("any(test, feature =          )"));
}
