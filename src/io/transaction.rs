//! One output transaction per command run (RELIABILITY.md, "Nothing is
//! lost"), and the record of what the run reads, so that no output can
//! replace an input.
//!
//! While a [`Transaction`] is open (the command binaries open one around
//! each run, `crate::cli::exit_with`), every output written through
//! [`crate::io::write_output`], [`crate::io::source::write_outputs`] or a
//! committed [`crate::io::StagedDir`] stays under its staging name in the
//! target's own folder:
//!
//! - files: `.NAME.splatkit-PID-K.tmp` next to `NAME`;
//! - folders: `.NAME.splatkit-PID-K` next to `NAME`.
//!
//! [`Transaction::commit`] moves them all into place only when the command
//! returned success, in two phases: each existing target is first renamed to
//! `.NAME.splatkit-PID-K.old`, then the staged file takes its name; if any
//! rename fails, the renames already done are undone in reverse order and
//! the backups return, so the targets are as they were. The backups are
//! removed last. A run that fails (or panics) drops the transaction, which
//! removes every staged file and folder. Reports for stdout (`--json`) are
//! held too and printed after the commit.
//!
//! Staging left by a killed run is recognised by its name (the PID of a
//! process that no longer runs) and cleaned by the next run that stages the
//! same target: `.tmp` files and staging folders are removed; a `.old`
//! backup whose target is missing (the run died between its two renames) is
//! renamed back, otherwise removed. Each is reported on stderr.
//!
//! Inputs: readers call [`note_input`] / [`note_input_dir`]; outputs are
//! declared with [`note_output`] (by the output checks and
//! [`crate::io::StagedDir::new`]). Declaring an output that resolves to an
//! input file, or that lies in or is an input folder, is an
//! [`Error::Usage`] (exit 2), whichever of the two is recorded first, so it
//! is found before the work. The commit checks every target again
//! against the inputs (by device and inode, so hard links and symlinks are
//! caught) before renaming anything.
//!
//! Without an open transaction (library use, unit tests) outputs are
//! renamed into place at once, as before.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::{Error, Result};

/// One staged output waiting for the commit.
#[derive(Debug)]
struct Pending {
    target: PathBuf,
    staged: PathBuf,
    /// Parent folders made for this output (deepest first), removed again
    /// when the run fails.
    created: Vec<PathBuf>,
}

/// A file or folder the run reads (or will write), as given and as resolved.
#[derive(Debug, Clone)]
struct Noted {
    shown: String,
    canonical: PathBuf,
    id: Option<(u64, u64)>,
}

#[derive(Debug, Default)]
struct State {
    pending: Vec<Pending>,
    input_files: Vec<Noted>,
    input_dirs: Vec<Noted>,
    outputs: Vec<(Noted, String)>,
    /// Folders whose files the run reads and may replace (a `--resume`
    /// checkpoint the run advances): not recorded as inputs.
    replaceable: Vec<PathBuf>,
    /// Staging folders of this run: files written inside one are renamed
    /// at once (the folder is the unit the commit moves), so the run can
    /// read back what it wrote there.
    staging_dirs: Vec<PathBuf>,
    /// The same folders resolved: what the run reads or writes inside
    /// them is its own work in progress, neither an input nor an output.
    staging_resolved: Vec<PathBuf>,
    stdout: Vec<String>,
}

impl State {
    /// Records input file `n`, refusing it when a declared output is it
    /// (`what` words the clash: "is the input file").
    fn add_input_file(&mut self, n: Noted, what: &str) -> Result<()> {
        for (o, role) in &self.outputs {
            if clash_file(o, &n) {
                return Err(clash_message(role, o, what, &n));
            }
        }
        self.input_files.push(n);
        Ok(())
    }

    fn in_staging(&self, n: &Noted) -> bool {
        self.staging_resolved
            .iter()
            .any(|d| n.canonical.starts_with(d))
    }
}

static ACTIVE: Mutex<Option<State>> = Mutex::new(None);

fn lock() -> std::sync::MutexGuard<'static, Option<State>> {
    ACTIVE.lock().unwrap_or_else(|p| p.into_inner())
}

/// The open transaction of this process's command run (see the module docs).
/// Dropping it without [`Transaction::commit`] removes everything staged.
#[must_use = "a transaction that is dropped removes its staged outputs"]
pub struct Transaction {
    owner: bool,
}

impl Transaction {
    /// Opens the transaction. A second `begin` while one is open returns a
    /// guard that does nothing (the outer one commits).
    pub fn begin() -> Transaction {
        let mut g = lock();
        if g.is_some() {
            return Transaction { owner: false };
        }
        *g = Some(State::default());
        Transaction { owner: true }
    }

    /// Checks every target against the inputs, moves every staged output
    /// into place (all or none), then prints the held stdout reports.
    pub fn commit(mut self) -> Result<()> {
        if !self.owner {
            return Ok(());
        }
        self.owner = false;
        let state = lock().take().unwrap_or_default();
        let State {
            pending,
            input_files,
            input_dirs,
            stdout,
            ..
        } = state;
        let moves = match plan(&pending, &input_files, &input_dirs) {
            Ok(m) => m,
            Err(e) => {
                discard(pending);
                return Err(e);
            }
        };
        if let Err(e) = apply(&moves) {
            discard(pending);
            return Err(e);
        }
        // Merged staging folders are empty shells now.
        for p in &pending {
            if p.staged.is_dir() {
                let _ = std::fs::remove_dir_all(&p.staged);
            }
        }
        for text in stdout {
            crate::io::source::print_stdout(&format!("{text}\n"));
        }
        Ok(())
    }
}

impl Drop for Transaction {
    fn drop(&mut self) {
        if self.owner
            && let Some(state) = lock().take()
        {
            discard(state.pending);
        }
    }
}

/// True while a transaction is open.
pub fn active() -> bool {
    lock().is_some()
}

/// Hands a staged file or folder to the open transaction; returns it back
/// (`Err`) when no transaction is open, for the caller to rename at once.
/// A second output to the same target replaces the first one's staging.
pub(crate) fn defer(
    target: &Path,
    staged: PathBuf,
    created: Vec<PathBuf>,
) -> std::result::Result<(), PathBuf> {
    let mut g = lock();
    let Some(state) = g.as_mut() else {
        return Err(staged);
    };
    if state.staging_dirs.iter().any(|d| target.starts_with(d)) {
        return Err(staged);
    }
    if let Some(old) = state.pending.iter_mut().find(|p| p.target == target) {
        remove_any(&old.staged);
        old.staged = staged;
        old.created.extend(created);
    } else {
        state.pending.push(Pending {
            target: target.to_path_buf(),
            staged,
            created,
        });
    }
    Ok(())
}

/// Holds a report for stdout until the commit; `Err(text)` back when no
/// transaction is open (print it now).
pub fn defer_stdout(text: String) -> std::result::Result<(), String> {
    let mut g = lock();
    match g.as_mut() {
        Some(state) => {
            state.stdout.push(text);
            Ok(())
        }
        None => Err(text),
    }
}

/// Commits `(target, staged)` pairs now, all or none, outside a command
/// run (library use): the same plan and two-phase renames as
/// [`Transaction::commit`], without the input checks.
pub(crate) fn commit_now(pairs: Vec<(PathBuf, PathBuf)>) -> Result<()> {
    let pending: Vec<Pending> = pairs
        .into_iter()
        .map(|(target, staged)| Pending {
            target,
            staged,
            created: Vec::new(),
        })
        .collect();
    let result = plan(&pending, &[], &[]).and_then(|m| apply(&m));
    if result.is_err() {
        discard(pending);
        return result;
    }
    for p in &pending {
        if p.staged.is_dir() {
            let _ = std::fs::remove_dir_all(&p.staged);
        }
    }
    Ok(())
}

fn remove_any(p: &Path) {
    if p.is_dir() {
        let _ = std::fs::remove_dir_all(p);
    } else {
        let _ = std::fs::remove_file(p);
    }
}

fn discard(pending: Vec<Pending>) {
    for p in pending {
        remove_any(&p.staged);
        for d in &p.created {
            let _ = std::fs::remove_dir(d);
        }
    }
}

// ---------------------------------------------------------------------------
// Inputs and outputs

/// The path with its existing part resolved (symlinks, `..`) and the rest
/// appended, so a path that does not exist yet still compares correctly.
pub fn resolve(path: &Path) -> PathBuf {
    let abs = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map(|d| d.join(path))
            .unwrap_or_else(|_| path.to_path_buf())
    };
    if let Ok(c) = std::fs::canonicalize(&abs) {
        return c;
    }
    let mut rest = Vec::new();
    let mut cur = abs.as_path();
    loop {
        match cur.file_name() {
            Some(n) => rest.push(n.to_os_string()),
            None => return abs,
        }
        match cur.parent() {
            Some(p) => {
                cur = p;
                if let Ok(mut c) = std::fs::canonicalize(cur) {
                    for n in rest.iter().rev() {
                        if n == ".." {
                            c.pop();
                        } else if n != "." {
                            c.push(n);
                        }
                    }
                    return c;
                }
            }
            None => return abs,
        }
    }
}

#[cfg(unix)]
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(_: &Path) -> Option<(u64, u64)> {
    None
}

fn noted(path: &Path) -> Noted {
    Noted {
        shown: path.display().to_string(),
        canonical: resolve(path),
        id: file_id(path),
    }
}

fn is_std(path: &Path) -> bool {
    path.as_os_str() == "-" || path.as_os_str().is_empty()
}

/// Is output `o` (declared as `role`) the input file `i`, or in or the input folder?
fn clash_file(o: &Noted, i: &Noted) -> bool {
    o.canonical == i.canonical || (o.id.is_some() && o.id == i.id)
}

fn clash_dir(o: &Noted, d: &Noted) -> bool {
    o.canonical.starts_with(&d.canonical) || (o.id.is_some() && o.id == d.id)
}

fn clash_message(out_role: &str, o: &Noted, what: &str, i: &Noted) -> Error {
    Error::usage(format!(
        "{out_role} {}: {what} {} (inputs are never written; choose another output path)",
        o.shown, i.shown
    ))
}

/// Records a file the run reads. Fails ([`Error::Usage`]) when an output
/// already declared resolves to it. Does nothing without a transaction, or
/// for stdin.
pub fn note_input(path: &Path) -> Result<()> {
    if is_std(path) {
        return Ok(());
    }
    let mut g = lock();
    let Some(state) = g.as_mut() else {
        return Ok(());
    };
    let n = noted(path);
    if state.in_staging(&n) || state.replaceable.iter().any(|d| n.canonical.starts_with(d)) {
        return Ok(());
    }
    state.add_input_file(n, "is the input file")
}

/// Records the file on stdin (`< FILE`) as an input, by device and inode,
/// so an output path naming that same file is refused like any other
/// input. Nothing for a pipe or a terminal.
pub fn note_stdin() -> Result<()> {
    let Ok(meta) = std::fs::metadata("/dev/stdin") else {
        return Ok(());
    };
    if !meta.is_file() {
        return Ok(());
    }
    let mut g = lock();
    let Some(state) = g.as_mut() else {
        return Ok(());
    };
    #[cfg(unix)]
    let id = {
        use std::os::unix::fs::MetadataExt;
        Some((meta.dev(), meta.ino()))
    };
    #[cfg(not(unix))]
    let id = None;
    let n = Noted {
        shown: "<stdin>".into(),
        canonical: PathBuf::from("<stdin>"),
        id,
    };
    state.add_input_file(n, "is the file on")
}

/// Marks `dir` as the run's own state, which it reads and may replace: the
/// checkpoint folder of `--resume`, whose successor the run writes (resuming
/// into the same output folder is the normal workflow). Its files are then
/// not recorded as inputs. Call it before reading them.
pub fn note_replaceable(dir: &Path) {
    if let Some(state) = lock().as_mut() {
        state.replaceable.push(resolve(dir));
    }
}

/// Records a folder the run reads (a data set, an image folder). Fails
/// when an output already declared lies in it or is it.
pub fn note_input_dir(path: &Path) -> Result<()> {
    if is_std(path) {
        return Ok(());
    }
    let mut g = lock();
    let Some(state) = g.as_mut() else {
        return Ok(());
    };
    let n = noted(path);
    for (o, role) in &state.outputs {
        if clash_dir(o, &n) {
            return Err(clash_message(
                role,
                o,
                "would write into the input folder",
                &n,
            ));
        }
    }
    state.input_dirs.push(n);
    Ok(())
}

/// Declares an output (a file, or a folder the run fills) under `role`
/// (the flag, e.g. `-o`). Fails when it resolves to an input file, or lies
/// in or is an input folder, recorded so far; later inputs are checked
/// against it as they are noted.
pub fn note_output(path: &Path, role: &str) -> Result<()> {
    if is_std(path) {
        return Ok(());
    }
    let mut g = lock();
    let Some(state) = g.as_mut() else {
        return Ok(());
    };
    let n = noted(path);
    if state.in_staging(&n) {
        return Ok(());
    }
    for i in &state.input_files {
        if clash_file(&n, i) {
            return Err(clash_message(role, &n, "is the input file", i));
        }
    }
    for d in &state.input_dirs {
        if clash_dir(&n, d) {
            return Err(clash_message(
                role,
                &n,
                "would write into the input folder",
                d,
            ));
        }
    }
    state.outputs.push((n, role.to_string()));
    Ok(())
}

// ---------------------------------------------------------------------------
// The commit

/// One rename of the commit: `from` (staged) to `to` (target).
#[derive(Debug)]
struct Move {
    from: PathBuf,
    to: PathBuf,
}

/// Expands the pending outputs into renames (a staged folder whose target
/// exists is merged file by file), checking before any rename that no
/// target is an input or lies in an input folder, and that no file would
/// replace a folder or the reverse.
fn plan(pending: &[Pending], inputs: &[Noted], input_dirs: &[Noted]) -> Result<Vec<Move>> {
    let mut moves = Vec::new();
    for p in pending {
        if p.staged.is_dir() && p.target.is_dir() {
            merge_plan(&p.staged, &p.target, &mut moves)?;
        } else {
            if p.target.is_dir() && !p.staged.is_dir() {
                return Err(Error::format(
                    p.target.display(),
                    "is a folder; the output file cannot replace it",
                ));
            }
            if p.staged.is_dir() && p.target.exists() {
                return Err(Error::format(
                    p.target.display(),
                    "exists and is not a folder; the output folder cannot replace it",
                ));
            }
            moves.push(Move {
                from: p.staged.clone(),
                to: p.target.clone(),
            });
        }
    }
    for m in &moves {
        let n = noted(&m.to);
        for i in inputs {
            if clash_file(&n, i) {
                return Err(clash_message("the output", &n, "is the input file", i));
            }
        }
        for d in input_dirs {
            if clash_dir(&n, d) {
                return Err(clash_message(
                    "the output",
                    &n,
                    "would write into the input folder",
                    d,
                ));
            }
        }
    }
    Ok(moves)
}

fn merge_plan(from: &Path, to: &Path, moves: &mut Vec<Move>) -> Result<()> {
    let entries = std::fs::read_dir(from).map_err(|e| Error::io(from.display(), e))?;
    let mut entries: Vec<_> = entries
        .collect::<std::io::Result<Vec<_>>>()
        .map_err(|e| Error::io(from.display(), e))?;
    entries.sort_by_key(|e| e.file_name());
    for entry in entries {
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if src.is_dir() && dst.is_dir() {
            merge_plan(&src, &dst, moves)?;
        } else if dst.is_dir() {
            return Err(Error::format(
                dst.display(),
                "is a folder; the output file cannot replace it",
            ));
        } else if src.is_dir() && dst.exists() {
            return Err(Error::format(
                dst.display(),
                "exists and is not a folder; the output folder cannot replace it",
            ));
        } else {
            moves.push(Move { from: src, to: dst });
        }
    }
    Ok(())
}

/// A free backup name `.NAME.splatkit-PID-K.old` next to `target`.
fn backup_name(target: &Path) -> PathBuf {
    let (dir, base) = split(target);
    let pid = std::process::id();
    (0u32..)
        .map(|k| dir.join(format!(".{base}.splatkit-{pid}-{k}.old")))
        .find(|p| std::fs::symlink_metadata(p).is_err())
        .expect("a free backup name exists")
}

/// The folder and file name of a path (`.` for a bare name).
pub(crate) fn split(target: &Path) -> (PathBuf, String) {
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let base = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    (dir, base)
}

/// Fault injection for the tests of the undo path: with
/// `SPLATKIT_FAULT_COMMIT=N` in the environment, the N-th rename of a
/// commit (1-based) fails as if the disk refused it. Unset, it costs one
/// environment lookup per renamed file.
fn fault(k: usize) -> Option<std::io::Error> {
    let n: usize = std::env::var("SPLATKIT_FAULT_COMMIT").ok()?.parse().ok()?;
    (n == k).then(|| std::io::Error::other("injected failure (SPLATKIT_FAULT_COMMIT)"))
}

/// Renames every move in order, each existing target first set aside; on
/// a failure, undoes what was done and reports the failure.
fn apply(moves: &[Move]) -> Result<()> {
    // (target, its backup if it existed)
    let mut done: Vec<(&Move, Option<PathBuf>)> = Vec::new();
    let mut failure = None;
    for m in moves {
        let backup = if std::fs::symlink_metadata(&m.to).is_ok() {
            let b = backup_name(&m.to);
            if let Err(e) = std::fs::rename(&m.to, &b) {
                failure = Some(Error::io(m.to.display(), e));
                break;
            }
            Some(b)
        } else {
            None
        };
        if let Err(e) = fault(done.len() + 1).map_or_else(|| std::fs::rename(&m.from, &m.to), Err) {
            if let Some(b) = &backup {
                let _ = std::fs::rename(b, &m.to);
            }
            failure = Some(Error::io(m.to.display(), e));
            break;
        }
        done.push((m, backup));
    }
    match failure {
        None => {
            for (_, b) in done {
                if let Some(b) = b {
                    remove_any(&b);
                }
            }
            Ok(())
        }
        Some(e) => {
            for (m, b) in done.into_iter().rev() {
                // Back to its staging name (removed by the caller), then the
                // old target returns.
                let _ = std::fs::rename(&m.to, &m.from);
                if let Some(b) = b {
                    let _ = std::fs::rename(&b, &m.to);
                }
            }
            Err(e)
        }
    }
}

// ---------------------------------------------------------------------------
// Staging names and leftovers of killed runs

/// Creates a new staging file `.NAME.splatkit-PID-K.tmp` next to `target`
/// (create-new, so it never opens an existing file), after cleaning the
/// staging that killed runs left for this target.
pub(crate) fn create_staging_file(target: &Path) -> Result<(PathBuf, std::fs::File)> {
    create_staging(target, ".tmp", |p| {
        std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(p)
    })
}

/// Proves that an output file can be staged next to `target`: creates a
/// staging file there and removes it again.
pub fn probe_writable(target: &Path) -> Result<()> {
    if crate::io::source::is_special(target) {
        // Written in place (a device or a pipe): nothing is staged.
        return Ok(());
    }
    let (p, f) = create_staging_file(target)?;
    drop(f);
    let _ = std::fs::remove_file(p);
    Ok(())
}

/// Creates a new staging folder `.NAME.splatkit-PID-K` next to `target`,
/// after cleaning the leftovers of killed runs; files written in it are the
/// run's work in progress (see [`State::in_staging`]).
pub(crate) fn create_staging_dir(target: &Path) -> Result<PathBuf> {
    let (p, ()) = create_staging(target, "", |p| std::fs::create_dir(p))?;
    if let Some(state) = lock().as_mut() {
        state.staging_dirs.push(p.clone());
        state.staging_resolved.push(resolve(&p));
    }
    Ok(p)
}

/// The first free `.NAME.splatkit-PID-K{suffix}` next to `target` that
/// `make` creates (it must fail with `AlreadyExists` on a taken name).
fn create_staging<T>(
    target: &Path,
    suffix: &str,
    make: impl Fn(&Path) -> std::io::Result<T>,
) -> Result<(PathBuf, T)> {
    let (dir, base) = split(target);
    clean_leftovers(&dir, &base);
    let pid = std::process::id();
    for k in 0u32.. {
        let p = dir.join(format!(".{base}.splatkit-{pid}-{k}{suffix}"));
        match make(&p) {
            Ok(t) => return Ok((p, t)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(Error::io(dir.display(), e)),
        }
    }
    unreachable!("a free staging name exists")
}

/// What a staging name says: the PID of the run that made it and whether
/// it is a backup (`.old`).
fn parse_staging(name: &str, base: &str) -> Option<(u32, bool)> {
    let rest = name.strip_prefix('.')?.strip_prefix(base)?;
    let rest = rest.strip_prefix(".splatkit-")?;
    let (core, old) = if let Some(c) = rest.strip_suffix(".old") {
        (c, true)
    } else if let Some(c) = rest.strip_suffix(".tmp") {
        (c, false)
    } else {
        (rest, false)
    };
    let (pid, k) = core.split_once('-')?;
    k.parse::<u32>().ok()?;
    Some((pid.parse().ok()?, old))
}

fn process_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    #[cfg(target_os = "linux")]
    {
        Path::new(&format!("/proc/{pid}")).exists()
    }
    #[cfg(not(target_os = "linux"))]
    {
        true
    }
}

/// Removes (or, for a backup whose target is missing, restores) the
/// staging of `dir/base` left by runs that no longer run; reports each on
/// stderr. Errors are ignored: the leftovers stay and are reported.
pub fn clean_leftovers(dir: &Path, base: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let target = dir.join(base);
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some((pid, old)) = parse_staging(&name, base) else {
            continue;
        };
        if process_alive(pid) {
            continue;
        }
        let p = entry.path();
        if old && std::fs::symlink_metadata(&target).is_err() {
            match std::fs::rename(&p, &target) {
                Ok(()) => eprintln!(
                    "note: {}: restored from {name}, left by an interrupted run (process {pid})",
                    target.display()
                ),
                Err(e) => eprintln!(
                    "warning: {}: an interrupted run left its previous version as {name}: {e}",
                    target.display()
                ),
            }
        } else {
            remove_any(&p);
            if std::fs::symlink_metadata(&p).is_ok() {
                eprintln!(
                    "warning: {}: cannot remove {name}, left by an interrupted run (process {pid})",
                    target.display()
                );
            } else {
                eprintln!(
                    "note: {}: removed {name}, left by an interrupted run (process {pid})",
                    target.display()
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    //! Pure parts only: the process-wide transaction is exercised through
    //! the binaries (tests/hostile/transaction.rs), since unit tests run in
    //! parallel threads of one process.
    use super::*;

    #[test]
    fn staging_names_are_recognised() {
        assert_eq!(
            parse_staging(".out.ply.splatkit-12-0.tmp", "out.ply"),
            Some((12, false))
        );
        assert_eq!(
            parse_staging(".out.ply.splatkit-12-3.old", "out.ply"),
            Some((12, true))
        );
        assert_eq!(parse_staging(".out.splatkit-7-1", "out"), Some((7, false)));
        // Another target's staging, or a user's file, is not ours.
        assert_eq!(parse_staging(".out.ply.splatkit-12-0.tmp", "out"), None);
        assert_eq!(parse_staging(".out.splatkit-x-1", "out"), None);
        assert_eq!(parse_staging("out.splatkit-7-1", "out"), None);
    }

    /// Paths that do not exist yet resolve through their existing part, so
    /// `dir/link/../x` and symlinked folders compare equal to the real path.
    #[test]
    fn resolve_handles_missing_tails_and_symlinks() {
        let root = tempfile::tempdir().unwrap();
        let real = std::fs::canonicalize(root.path()).unwrap();
        std::fs::create_dir(real.join("d")).unwrap();
        std::os::unix::fs::symlink(real.join("d"), real.join("l")).unwrap();
        assert_eq!(resolve(&real.join("l/new/x.ply")), real.join("d/new/x.ply"));
        assert_eq!(resolve(&real.join("d/../d/y")), real.join("d/y"));
    }

    /// `commit_now` lands a set all or none: a folder in the way of the
    /// second file stops the set before the first is renamed.
    #[test]
    fn commit_now_is_all_or_none() {
        let root = tempfile::tempdir().unwrap();
        let d = root.path();
        std::fs::write(d.join("a"), b"old a").unwrap();
        std::fs::create_dir(d.join("b")).unwrap();
        std::fs::write(d.join("sa"), b"new a").unwrap();
        std::fs::write(d.join("sb"), b"new b").unwrap();
        let e = commit_now(vec![
            (d.join("a"), d.join("sa")),
            (d.join("b"), d.join("sb")),
        ])
        .unwrap_err()
        .to_string();
        assert!(e.contains("is a folder"), "{e}");
        assert_eq!(std::fs::read(d.join("a")).unwrap(), b"old a");
        assert!(!d.join("sa").exists() && !d.join("sb").exists());
        std::fs::write(d.join("sa"), b"new a").unwrap();
        std::fs::write(d.join("sc"), b"new c").unwrap();
        commit_now(vec![
            (d.join("a"), d.join("sa")),
            (d.join("c"), d.join("sc")),
        ])
        .unwrap();
        assert_eq!(std::fs::read(d.join("a")).unwrap(), b"new a");
        assert_eq!(std::fs::read(d.join("c")).unwrap(), b"new c");
        let mut left: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        left.sort();
        assert_eq!(left, ["a", "b", "c"], "no backup or staging left");
    }
}
