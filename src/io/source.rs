//! Reading inputs (files by memory map, `-` from stdin) and writing outputs
//! atomically (temporary file in the destination folder, renamed at the end;
//! `-` writes to stdout; folder outputs through [`StagedDir`]).

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::ops::Deref;
use std::path::{Path, PathBuf};

use crate::io::{budget, transaction};
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

/// Reads `path` (`-` = all of stdin). Regular files are memory-mapped
/// read-only; stdin, devices, FIFOs and empty files are read into memory
/// with a cap ([`read_stream`]). The file is recorded as an input of the
/// run ([`transaction::note_input`]), which fails (usage) when an output of
/// the run resolves to it.
pub fn read_input(path: &Path) -> Result<Input> {
    if path.as_os_str() == "-" {
        transaction::note_stdin()?;
        let v = read_stream("<stdin>", std::io::stdin().lock())?;
        return Ok(Input::from_bytes("<stdin>", v));
    }
    let (name, file, meta) = open_input(path)?;
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
    let v = read_stream(&name, &file)?;
    Ok(Input {
        name,
        bytes: InputBytes::Owned(v),
    })
}

/// Records `path` as an input of the run and opens it: its display name,
/// the file and its metadata; a folder is an error.
fn open_input(path: &Path) -> Result<(String, File, std::fs::Metadata)> {
    transaction::note_input(path)?;
    let name = path.display().to_string();
    let file = File::open(path).map_err(|e| Error::io(&name, e))?;
    let meta = file.metadata().map_err(|e| Error::io(&name, e))?;
    if meta.is_dir() {
        return Err(Error::format(&name, "is a directory, expected a file"));
    }
    Ok((name, file, meta))
}

/// Reads a whole file into memory (a JSON file, a photo, optimiser state)
/// with the same rules as [`read_input`]: recorded as an input of the run;
/// a regular file larger than the memory budget is refused before it is
/// read; anything else is read with [`read_stream`]'s cap.
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    let (name, file, meta) = open_input(path)?;
    if meta.is_file() && meta.len() > 0 {
        budget::check(
            &format!("{name}: reading its {} bytes", meta.len()),
            meta.len(),
        )?;
        let mut v = Vec::with_capacity(meta.len() as usize);
        (&file)
            .read_to_end(&mut v)
            .map_err(|e| Error::io(&name, e))?;
        return Ok(v);
    }
    read_stream(&name, &file)
}

/// Bytes read from the start of a stream to recognise it.
const SNIFF_BYTES: usize = 64 << 10;

/// The most bytes read from a stream (stdin, a device, a FIFO) whose
/// header declares no size: a quarter of the usable memory budget
/// ([`budget::usable_bytes`]), since readers may hold a decoded copy
/// several times the size of the bytes.
pub fn stream_cap() -> u64 {
    budget::usable_bytes() / 4
}

/// Reads a stream that may never end (stdin, `/dev/zero`, a FIFO) with a
/// cap: the first 64 KiB are read first; if all of them are zero bytes the
/// stream is refused (no format splatkit reads starts so); a binary PLY or
/// GLB header there declares the total size, which caps the rest (with
/// 1 MiB of slack); otherwise the cap is [`stream_cap`]. A stream longer
/// than its cap is refused naming `name`, the cap and why.
pub fn read_stream(name: &str, mut r: impl Read) -> Result<Vec<u8>> {
    let mut v = Vec::new();
    (&mut r)
        .take(SNIFF_BYTES as u64)
        .read_to_end(&mut v)
        .map_err(|e| Error::io(name, e))?;
    if v.len() == SNIFF_BYTES && v.iter().all(|&b| b == 0) {
        return Err(Error::format(
            name,
            format!(
                "the first {SNIFF_BYTES} bytes are all zero: not a file splatkit reads \
                 (is it /dev/zero?)"
            ),
        ));
    }
    if v.len() < SNIFF_BYTES {
        return Ok(v);
    }
    let general = stream_cap();
    let (cap, why) = match declared_len(&v) {
        Some((n, what)) => {
            if n > general {
                return Err(Error::format(
                    name,
                    format!(
                        "its {what} header declares {n} bytes, more than the {general} bytes \
                         this process reads from a stream (a quarter of its memory budget)"
                    ),
                ));
            }
            (
                n.saturating_add(1 << 20),
                format!("the {n} bytes its {what} header declares"),
            )
        }
        None => (
            general,
            "a quarter of this process's memory budget".to_string(),
        ),
    };
    (&mut r)
        .take(cap - v.len() as u64 + 1)
        .read_to_end(&mut v)
        .map_err(|e| Error::io(name, e))?;
    if v.len() as u64 > cap {
        return Err(Error::format(
            name,
            format!("the stream goes on past {cap} bytes ({why}); refused (give a regular file)"),
        ));
    }
    Ok(v)
}

/// The total size a binary PLY or a GLB header in `head` declares, with
/// the format's name; `None` for other formats, text PLY and PLYs with
/// list properties (whose size the header does not fix).
fn declared_len(head: &[u8]) -> Option<(u64, &'static str)> {
    if head.len() >= 12 && &head[0..4] == b"glTF" {
        let n = u32::from_le_bytes(head[8..12].try_into().ok()?);
        return Some((n as u64, "GLB"));
    }
    if !head.starts_with(b"ply") {
        return None;
    }
    let end = head.windows(11).position(|w| w == b"end_header\n")? + 11;
    let text = std::str::from_utf8(&head[..end]).ok()?;
    let mut binary = false;
    let mut total: u64 = 0;
    let mut count: u64 = 0;
    let mut row: u64 = 0;
    for line in text.lines() {
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.as_slice() {
            ["format", f, ..] => binary = f.starts_with("binary"),
            ["element", _, n] => {
                total = total.saturating_add(count.saturating_mul(row));
                count = n.parse().ok()?;
                row = 0;
            }
            ["property", "list", ..] => return None,
            ["property", ty, _] => {
                row += match *ty {
                    "char" | "uchar" | "int8" | "uint8" => 1,
                    "short" | "ushort" | "int16" | "uint16" => 2,
                    "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
                    "double" | "float64" => 8,
                    _ => return None,
                }
            }
            _ => {}
        }
    }
    if !binary {
        return None;
    }
    total = total.saturating_add(count.saturating_mul(row));
    Some((total.saturating_add(end as u64), "PLY"))
}

/// Writes an output through `f`. For `-` the bytes go to stdout; otherwise to
/// a staging file next to `path` that is renamed over `path` only when `f`
/// succeeded and the data were flushed, so a failed run never leaves a
/// half-written output (and never clobbers an existing one). Inside a
/// command run the rename waits for the run's [`transaction`] commit.
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
    if is_special(path) {
        return write_special(path, f);
    }
    stage_file(path, f)?.finish()
}

/// True for an existing output that is neither a regular file nor a
/// folder: `/dev/null`, `/dev/stdout`, a FIFO, a terminal. Such a target is
/// written in place: renaming a staged file over it would replace the
/// device itself (a `/dev/null` turned regular file breaks every program
/// that discards output into it).
pub fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| {
        let t = m.file_type();
        !t.is_file() && !t.is_dir()
    })
}

/// Writes straight into a special file ([`is_special`]); not staged, since
/// a device or a pipe cannot be put back.
fn write_special<F>(path: &Path, f: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    let name = path.display().to_string();
    transaction::note_output(path, "the output")?;
    let file = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(|e| Error::io(&name, e))?;
    let mut w = BufWriter::with_capacity(1 << 20, file);
    f(&mut w).map_err(|e| name_output(e, &name))?;
    w.flush().map_err(|e| Error::io(&name, e))
}

/// A staged output file: removed when dropped unless [`StagedFile::finish`]
/// handed it on.
struct StagedFile {
    target: PathBuf,
    staged: Option<PathBuf>,
}

impl StagedFile {
    /// Hands the file to the open transaction, or renames it into place
    /// now when there is none.
    fn finish(mut self) -> Result<()> {
        let staged = self.staged.take().expect("staged once");
        if let Err(staged) = transaction::defer(&self.target, staged, Vec::new())
            && let Err(e) = std::fs::rename(&staged, &self.target)
        {
            let _ = std::fs::remove_file(&staged);
            return Err(Error::io(self.target.display(), e));
        }
        Ok(())
    }
}

impl Drop for StagedFile {
    fn drop(&mut self) {
        if let Some(p) = &self.staged {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// A file output whose bytes are `f`'s, written to a staging file in
/// `path`'s folder (with the permissions the output will have) and not yet
/// renamed. Declares `path` as an output of the run first, which fails
/// when it is one of the run's inputs.
fn stage_file<F>(path: &Path, f: F) -> Result<StagedFile>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    let name = path.display().to_string();
    transaction::note_output(path, "the output")?;
    if path.is_dir() {
        return Err(Error::format(
            &name,
            "is a folder; the output file cannot replace it",
        ));
    }
    let (staged, file) = transaction::create_staging_file(path)?;
    let out = StagedFile {
        target: path.to_path_buf(),
        staged: Some(staged),
    };
    {
        let mut w = BufWriter::with_capacity(1 << 20, &file);
        f(&mut w).map_err(|e| name_output(e, &name))?;
        w.flush().map_err(|e| Error::io(&name, e))?;
    }
    // Staging files are created 0600 by some systems' umask rules; give the
    // output the permissions a plain create would (or keep those of the
    // file being replaced).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let perms = std::fs::metadata(path)
            .map(|m| m.permissions())
            .unwrap_or_else(|_| std::fs::Permissions::from_mode(0o644));
        file.set_permissions(perms)
            .map_err(|e| Error::io(&name, e))?;
    }
    Ok(out)
}

/// One file of [`write_outputs`]: its path and the writer of its bytes.
pub type OutputFile<'a> = (PathBuf, Box<dyn FnOnce(&mut dyn Write) -> Result<()> + 'a>);

/// Writes several files that belong together (an OBJ with its MTL and
/// texture): each goes to a staging file next to it, and they are renamed
/// into place only after every one was written (inside a command run, at
/// its commit), so a failure leaves none of them behind or replaced.
/// (`-` is not accepted.)
pub fn write_outputs(files: Vec<OutputFile<'_>>) -> Result<()> {
    let mut staged = Vec::with_capacity(files.len());
    for (path, _) in &files {
        if path.as_os_str() == "-" {
            return Err(Error::invalid(
                "these outputs are several files and cannot go to stdout",
            ));
        }
        if path.is_dir() {
            return Err(Error::format(
                path.display(),
                "is a folder; the output file cannot replace it",
            ));
        }
    }
    let mut special = Vec::new();
    for (path, f) in files {
        if is_special(&path) {
            special.push((path, f));
        } else {
            staged.push(stage_file(&path, f)?);
        }
    }
    for (path, f) in special {
        write_special(&path, f)?;
    }
    if transaction::active() {
        for s in staged {
            s.finish()?;
        }
        return Ok(());
    }
    // No command run: commit the set now, all or none.
    let pairs = staged
        .into_iter()
        .map(|mut s| (s.target.clone(), s.staged.take().expect("staged once")))
        .collect();
    transaction::commit_now(pairs)
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
    /// before any work, when `target` exists and is not a folder, when its
    /// parent cannot be created or written, or when `target` is (or lies
    /// in) an input folder of the run.
    pub fn new(target: &Path) -> Result<Self> {
        let name = target.display().to_string();
        if target.exists() && !target.is_dir() {
            return Err(Error::format(&name, "exists and is not a folder"));
        }
        transaction::note_output(target, "the output folder")?;
        let (parent, _) = transaction::split(target);
        let created: Vec<PathBuf> = parent
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
            .map(Path::to_path_buf)
            .collect();
        std::fs::create_dir_all(&parent).map_err(|e| Error::io(parent.display(), e))?;
        let staging = match transaction::create_staging_dir(target) {
            Ok(s) => s,
            Err(e) => {
                for dir in &created {
                    let _ = std::fs::remove_dir(dir);
                }
                return Err(e);
            }
        };
        Ok(StagedDir {
            target: target.to_path_buf(),
            staging,
            created,
            committed: false,
        })
    }

    /// The folder to write into now.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// Moves the written files into the target (see the type's doc); inside
    /// a command run, at the run's [`transaction`] commit.
    pub fn commit(mut self) -> Result<()> {
        self.committed = true;
        let created = std::mem::take(&mut self.created);
        let staging = self.staging.clone();
        if let Err(staging) = transaction::defer(&self.target, staging, created.clone())
            && let Err(e) = transaction::commit_now(vec![(self.target.clone(), staging)])
        {
            for dir in &created {
                let _ = std::fs::remove_dir(dir);
            }
            return Err(e);
        }
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

/// Prints `text` to stdout (a report, a summary): a reader that has gone
/// away (`--json | head`, a closed pipe) is not an error of the run — its
/// outputs are committed already — so a broken pipe ends the printing
/// silently; any other write error is said on stderr. Never panics, unlike
/// `print!`.
pub fn print_stdout(text: &str) {
    let mut out = std::io::stdout().lock();
    let r = out.write_all(text.as_bytes()).and_then(|()| out.flush());
    if let Err(e) = r
        && e.kind() != std::io::ErrorKind::BrokenPipe
    {
        eprintln!("warning: writing to stdout: {e}");
    }
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

    /// A binary PLY whose header and body exceed the 64 KiB sniff.
    fn big_ply() -> Vec<u8> {
        let n = 10_000;
        let mut v = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {n}\n\
             property float x\nproperty float y\nproperty float z\nend_header\n"
        )
        .into_bytes();
        v.extend((0..n * 12).map(|i| (i % 251) as u8 + 1));
        v
    }

    /// Streams: all-zero starts are refused at once; short streams are read
    /// whole; a binary PLY is read to its declared size, and a stream that
    /// goes on more than 1 MiB past it is refused naming the stream.
    #[test]
    fn streams_are_read_with_a_cap() {
        let e = read_stream("zero", std::io::repeat(0))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("zero:") && e.contains("all zero"), "{e}");
        assert_eq!(read_stream("s", &b"abc"[..]).unwrap(), b"abc");
        let ply = big_ply();
        assert_eq!(
            declared_len(&ply[..SNIFF_BYTES]),
            Some((ply.len() as u64, "PLY"))
        );
        assert_eq!(read_stream("p", &ply[..]).unwrap(), ply);
        let endless = (&ply[..]).chain(std::io::repeat(7));
        let e = read_stream("<stdin>", endless).unwrap_err().to_string();
        assert!(e.contains("<stdin>") && e.contains("goes on past"), "{e}");
        // Text PLY and list properties declare no size; GLB declares it.
        assert_eq!(declared_len(b"ply\nformat ascii 1.0\nend_header\n"), None);
        let list = b"ply\nformat binary_little_endian 1.0\nelement face 3\n\
                     property list uchar int vertex_indices\nend_header\n";
        assert_eq!(declared_len(list), None);
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(1000u32.to_le_bytes());
        assert_eq!(declared_len(&glb), Some((1000, "GLB")));
    }

    /// Outside a command run `write_output` still lands at once, and a
    /// writer's failure leaves the old file and no staging file.
    #[test]
    fn write_output_without_a_transaction() {
        let root = tempfile::tempdir().unwrap();
        let p = root.path().join("a.txt");
        std::fs::write(&p, b"old").unwrap();
        let r = write_output(&p, |_| Err(Error::invalid("writer failed")));
        assert!(r.is_err());
        assert_eq!(names(root.path()), ["a.txt"]);
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        write_output(&p, |w| w.write_all(b"new").map_err(werr)).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert_eq!(names(root.path()), ["a.txt"]);
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
