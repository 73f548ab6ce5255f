//! Reading inputs (files by memory map, `-` from stdin) and writing outputs
//! atomically (temporary file in the destination folder, renamed at the end;
//! `-` writes to stdout).

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::ops::Deref;
use std::path::Path;

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
    tmp.persist(path).map_err(|e| Error::io(&name, e.error))?;
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
