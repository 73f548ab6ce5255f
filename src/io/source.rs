//! Reading inputs (files by memory map, `-` from stdin) and writing outputs
//! atomically (temporary file in the destination folder, renamed at the end;
//! `-` writes to stdout; folder outputs through [`StagedDir`]).

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::ops::Deref;
use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// Display form of a path argument in messages (`-` shown as `<stdin>` or `<stdout>`).
pub fn shown(path: &Path, stdout: bool) -> String {
    if path.as_os_str() == "-" {
        if stdout { "<stdout>" } else { "<stdin>" }.to_string()
    } else {
        path.display().to_string()
    }
}

/// The bytes of one input, memory-mapped from a file or read from stdin.
pub struct Input {
    /// Display name used in error messages (`<stdin>` for `-`).
    pub name: String,
    bytes: InputBytes,
}

enum InputBytes {
    Mapped(memmap2::Mmap),
    Owned(Vec<u8>),
}

impl Input {
    /// Wraps bytes already in memory (tests, generated data).
    pub fn from_bytes(name: impl Into<String>, bytes: Vec<u8>) -> Self {
        Input {
            name: name.into(),
            bytes: InputBytes::Owned(bytes),
        }
    }

    /// True when this input came from stdin.
    pub fn is_stdin(&self) -> bool {
        self.name == "<stdin>"
    }
}

impl Deref for Input {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        match &self.bytes {
            InputBytes::Mapped(m) => m,
            InputBytes::Owned(v) => v,
        }
    }
}

/// Reads `path` (`-` = all of stdin). Files are memory-mapped read-only;
/// empty files and non-regular files (pipes, `/dev/stdin`) are read into memory.
pub fn read_input(path: &Path) -> Result<Input> {
    if path.as_os_str() == "-" {
        let mut v = Vec::new();
        std::io::stdin()
            .lock()
            .read_to_end(&mut v)
            .map_err(|e| Error::io("<stdin>", e))?;
        return Ok(Input::from_bytes("<stdin>", v));
    }
    let name = path.display().to_string();
    let file = File::open(path).map_err(|e| Error::io(&name, e))?;
    let meta = file.metadata().map_err(|e| Error::io(&name, e))?;
    if meta.is_dir() {
        return Err(Error::format(&name, "is a directory, expected a file"));
    }
    if meta.is_file() && meta.len() > 0 {
        // SAFETY: the map is read-only and private to this process. Another
        // process truncating the file while we read it could fault; this is
        // the accepted trade-off of memory-mapped readers (documented in
        // docs/formats.md), and the speed of large PLY loads depends on it.
        let map = unsafe { memmap2::Mmap::map(&file) }.map_err(|e| Error::io(&name, e))?;
        return Ok(Input {
            name,
            bytes: InputBytes::Mapped(map),
        });
    }
    let mut v = Vec::new();
    (&file)
        .read_to_end(&mut v)
        .map_err(|e| Error::io(&name, e))?;
    Ok(Input {
        name,
        bytes: InputBytes::Owned(v),
    })
}

/// Writes an output through `f`. For `-` the bytes go to stdout; otherwise to
/// a temporary file next to `path` that is renamed over `path` only when `f`
/// succeeded and the data were flushed, so a failed run never leaves a
/// half-written output (and never clobbers an existing one).
pub fn write_output<F>(path: &Path, f: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    if path.as_os_str() == "-" {
        let stdout = std::io::stdout();
        let mut w = BufWriter::with_capacity(1 << 20, stdout.lock());
        f(&mut w).map_err(|e| name_output(e, "<stdout>"))?;
        return w.flush().map_err(|e| Error::io("<stdout>", e));
    }
    let tmp = stage_file(path, f)?;
    tmp.persist(path)
        .map_err(|e| Error::io(path.display(), e.error))?;
    Ok(())
}

/// A file output whose bytes are `f`'s, written to a temporary file in
/// `path`'s folder (with the permissions the output will have) and not yet
/// renamed.
fn stage_file<F>(path: &Path, f: F) -> Result<tempfile::NamedTempFile>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    let name = path.display().to_string();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".splatkit-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(|e| Error::io(dir.display(), e))?;
    {
        let mut w = BufWriter::with_capacity(1 << 20, tmp.as_file());
        f(&mut w).map_err(|e| name_output(e, &name))?;
        w.flush().map_err(|e| Error::io(&name, e))?;
    }
    // tempfile creates 0600 files; give the output the permissions a plain
    // create would (or keep those of the file being replaced).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let perms = std::fs::metadata(path)
            .map(|m| m.permissions())
            .unwrap_or_else(|_| std::fs::Permissions::from_mode(0o644));
        tmp.as_file()
            .set_permissions(perms)
            .map_err(|e| Error::io(&name, e))?;
    }
    Ok(tmp)
}

/// One file of [`write_outputs`]: its path and the writer of its bytes.
pub type OutputFile<'a> = (PathBuf, Box<dyn FnOnce(&mut dyn Write) -> Result<()> + 'a>);

/// Writes several files that belong together (an OBJ with its MTL and
/// texture): each goes to a temporary file next to it, and they are renamed
/// into place, in the given order, only after every one was written, so a
/// failure leaves none of them behind or replaced. (`-` is not accepted.)
pub fn write_outputs(files: Vec<OutputFile<'_>>) -> Result<()> {
    let mut staged = Vec::with_capacity(files.len());
    for (path, f) in files {
        if path.as_os_str() == "-" {
            return Err(Error::invalid(
                "these outputs are several files and cannot go to stdout",
            ));
        }
        let tmp = stage_file(&path, f)?;
        staged.push((path, tmp));
    }
    for (path, tmp) in staged {
        tmp.persist(&path)
            .map_err(|e| Error::io(path.display(), e.error))?;
    }
    Ok(())
}

/// Gives an I/O error raised through [`werr`] the output's real name.
fn name_output(e: Error, name: &str) -> Error {
    match e {
        Error::Io { path, source } if path == OUTPUT => Error::io(name, source),
        other => other,
    }
}

const OUTPUT: &str = "<output>";

/// Maps a write error to an [`Error`] naming the output.
/// Writers call this on `std::io::Error`s; [`write_output`] then replaces the
/// placeholder name with the real output path.
pub fn werr(e: std::io::Error) -> Error {
    Error::io(OUTPUT, e)
}

/// A folder output written all or nothing: files go into a new sibling
/// folder `.NAME.splatkit-PID-K` next to the target, and
/// [`StagedDir::commit`] moves them in only after the command succeeded. A
/// run that fails (or panics) before the commit leaves the target as it
/// was; the staging folder is removed when the `StagedDir` is dropped.
///
/// Commit renames the staging folder to the target when the target does
/// not exist; otherwise it renames each staged file over its namesake in
/// the target (files of the target that this run did not write are kept,
/// as a plain overwrite would keep them). Each rename is atomic; the set is
/// not, but it only starts once every file was written.
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    /// Parent folders this stage created, deepest first (removed again,
    /// when empty, by a run that does not commit).
    created: Vec<PathBuf>,
    committed: bool,
}

impl StagedDir {
    /// Starts a folder output at `target`, creating its missing parent
    /// folders (removed again if the run does not commit). Fails now,
    /// before any work, when `target` exists and is not a folder or when its
    /// parent cannot be created or written.
    pub fn new(target: &Path) -> Result<Self> {
        let name = target.display().to_string();
        if target.exists() && !target.is_dir() {
            return Err(Error::format(&name, "exists and is not a folder"));
        }
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let created: Vec<PathBuf> = parent
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
            .map(Path::to_path_buf)
            .collect();
        std::fs::create_dir_all(&parent).map_err(|e| Error::io(parent.display(), e))?;
        let base = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "output".into());
        for k in 0u32.. {
            let staging = parent.join(format!(".{base}.splatkit-{}-{k}", std::process::id()));
            match std::fs::create_dir(&staging) {
                Ok(()) => {
                    return Ok(StagedDir {
                        target: target.to_path_buf(),
                        staging,
                        created,
                        committed: false,
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(Error::io(parent.display(), e)),
            }
        }
        unreachable!("a free staging name exists")
    }

    /// The folder to write into now.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// Moves the written files into the target (see the type's doc).
    pub fn commit(mut self) -> Result<()> {
        let name = self.target.display().to_string();
        if !self.target.exists() {
            std::fs::rename(&self.staging, &self.target).map_err(|e| Error::io(&name, e))?;
        } else {
            merge_into(&self.staging, &self.target)?;
            std::fs::remove_dir_all(&self.staging)
                .map_err(|e| Error::io(self.staging.display(), e))?;
        }
        self.committed = true;
        Ok(())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
            for dir in &self.created {
                let _ = std::fs::remove_dir(dir);
            }
        }
    }
}

/// Renames every entry of `from` into `to`, merging sub-folders that exist
/// in both.
fn merge_into(from: &Path, to: &Path) -> Result<()> {
    let entries = std::fs::read_dir(from).map_err(|e| Error::io(from.display(), e))?;
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(from.display(), e))?;
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if src.is_dir() && dst.is_dir() {
            merge_into(&src, &dst)?;
        } else {
            std::fs::rename(&src, &dst).map_err(|e| Error::io(dst.display(), e))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// A new folder appears only on commit; a dropped stage leaves nothing.
    #[test]
    fn staged_dir_new_target() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("out");
        {
            let st = StagedDir::new(&target).unwrap();
            std::fs::write(st.path().join("a.png"), b"1").unwrap();
        }
        assert_eq!(names(root.path()), Vec::<String>::new());
        let st = StagedDir::new(&target).unwrap();
        std::fs::write(st.path().join("a.png"), b"1").unwrap();
        st.commit().unwrap();
        assert_eq!(names(root.path()), ["out"]);
        assert_eq!(names(&target), ["a.png"]);
    }

    /// Over an existing folder: nothing changes until commit; commit
    /// replaces the files written, keeps the others, and leaves no staging
    /// folder behind.
    #[test]
    fn staged_dir_existing_target() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("out");
        std::fs::create_dir_all(target.join("sub")).unwrap();
        std::fs::write(target.join("a.png"), b"old").unwrap();
        std::fs::write(target.join("b.png"), b"keep").unwrap();
        std::fs::write(target.join("sub/x"), b"old").unwrap();
        let write = |st: &StagedDir| {
            std::fs::write(st.path().join("a.png"), b"new").unwrap();
            std::fs::write(st.path().join("c.png"), b"new").unwrap();
            std::fs::create_dir(st.path().join("sub")).unwrap();
            std::fs::write(st.path().join("sub/x"), b"new").unwrap();
        };
        {
            let st = StagedDir::new(&target).unwrap();
            write(&st);
        }
        assert_eq!(std::fs::read(target.join("a.png")).unwrap(), b"old");
        assert_eq!(names(&target), ["a.png", "b.png", "sub"]);
        assert_eq!(names(root.path()), ["out"]);
        let st = StagedDir::new(&target).unwrap();
        write(&st);
        st.commit().unwrap();
        assert_eq!(names(&target), ["a.png", "b.png", "c.png", "sub"]);
        assert_eq!(std::fs::read(target.join("a.png")).unwrap(), b"new");
        assert_eq!(std::fs::read(target.join("b.png")).unwrap(), b"keep");
        assert_eq!(std::fs::read(target.join("sub/x")).unwrap(), b"new");
        assert_eq!(names(root.path()), ["out"]);
    }

    /// Missing parent folders are made for the stage and removed again when
    /// it is dropped without a commit.
    #[test]
    fn staged_dir_removes_the_parents_it_made() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("a/b/out");
        {
            let st = StagedDir::new(&target).unwrap();
            std::fs::write(st.path().join("x"), b"1").unwrap();
            assert!(root.path().join("a/b").is_dir());
        }
        assert_eq!(names(root.path()), Vec::<String>::new());
        let st = StagedDir::new(&target).unwrap();
        std::fs::write(st.path().join("x"), b"1").unwrap();
        st.commit().unwrap();
        assert_eq!(names(&target), ["x"]);
    }

    /// A target that is a file is refused before anything is staged.
    #[test]
    fn staged_dir_refuses_a_file_target() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("out");
        std::fs::write(&target, b"x").unwrap();
        let e = StagedDir::new(&target).err().unwrap().to_string();
        assert!(e.contains("not a folder"), "{e}");
        assert_eq!(names(root.path()), ["out"]);
    }
}
