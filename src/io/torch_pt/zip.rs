//! The zip container of `torch.save` (torch ≥ 1.6): reading its records and
//! writing a new archive.
//!
//! An archive holds one top-level folder (any name; `archive/` when written by
//! `torch.save` to a file object) with `data.pkl`, `data/<key>` storages,
//! `byteorder` (`little` / `big`, little when absent) and `version`. torch
//! writes stored (uncompressed) entries whose data starts on a 64-byte
//! boundary; stored records are read in place, compressed ones are inflated.

use std::borrow::Cow;
use std::collections::HashMap;
use std::io::{Cursor, Read, Write};

use zip::CompressionMethod;

/// Location of one record in the archive.
#[derive(Clone, Copy, Debug)]
struct Record {
    index: usize,
    stored: bool,
    start: u64,
    compressed: u64,
    size: u64,
}

/// An opened torch zip archive.
pub(crate) struct TorchArchive<'a> {
    bytes: &'a [u8],
    /// Folder prefix including its trailing `/` (may be empty).
    pub prefix: String,
    records: HashMap<String, Record>,
    /// True when `byteorder` says `big`.
    pub big_endian: bool,
}

/// A short reason a torch file is not a zip archive, for legacy formats.
fn not_zip_hint(bytes: &[u8]) -> &'static str {
    if bytes.first() == Some(&0x80) {
        " (this looks like the legacy torch format from before torch 1.6; re-save it with a recent torch)"
    } else if bytes.len() > 262 && &bytes[257..262] == b"ustar" {
        " (this looks like the legacy tar-based torch format; re-save it with a recent torch)"
    } else {
        ""
    }
}

impl<'a> TorchArchive<'a> {
    /// Opens `bytes` as a torch zip archive. Errors are messages without the
    /// file name.
    pub fn open(bytes: &'a [u8]) -> Result<Self, String> {
        if bytes.len() < 4 || &bytes[..4] != b"PK\x03\x04" {
            return Err(format!(
                "not a torch zip archive (no zip signature at byte 0){}",
                not_zip_hint(bytes)
            ));
        }
        let mut za = zip::ZipArchive::new(Cursor::new(bytes))
            .map_err(|e| format!("invalid zip archive: {e}"))?;
        let mut records = HashMap::new();
        let mut pkl: Option<String> = None;
        for index in 0..za.len() {
            let f = za
                .by_index_raw(index)
                .map_err(|e| format!("zip entry {index}: {e}"))?;
            let name = f.name().map_err(|e| format!("zip entry {index}: {e}"))?;
            let name = name.into_owned();
            let stored = match f.compression() {
                CompressionMethod::Stored => true,
                CompressionMethod::Deflated => false,
                m => {
                    return Err(format!(
                        "zip entry {name:?} uses unsupported compression {m}"
                    ));
                }
            };
            let start = f
                .data_start()
                .ok_or_else(|| format!("zip entry {name:?}: data offset unknown"))?;
            let compressed = f.compressed_size();
            if start
                .checked_add(compressed)
                .is_none_or(|end| end > bytes.len() as u64)
            {
                return Err(format!(
                    "zip entry {name:?} ({compressed} bytes at byte {start}) runs past the end of the file ({} bytes)",
                    bytes.len()
                ));
            }
            if stored && f.size() != compressed {
                return Err(format!(
                    "stored zip entry {name:?} has size {} but {compressed} stored bytes",
                    f.size()
                ));
            }
            if name == "data.pkl" || name.ends_with("/data.pkl") {
                match &pkl {
                    Some(prev) if prev.len() <= name.len() => {}
                    _ => pkl = Some(name.clone()),
                }
            }
            let rec = Record {
                index,
                stored,
                start,
                compressed,
                size: f.size(),
            };
            records.insert(name, rec);
        }
        let Some(pkl) = pkl else {
            return Err("zip archive has no data.pkl record: not a torch.save file".into());
        };
        let prefix = pkl[..pkl.len() - "data.pkl".len()].to_string();
        let mut archive = TorchArchive {
            bytes,
            prefix,
            records,
            big_endian: false,
        };
        if let Some(order) = archive.record_opt("byteorder")? {
            archive.big_endian = match order.trim_ascii() {
                b"little" => false,
                b"big" => true,
                other => {
                    return Err(format!(
                        "record {}byteorder holds {:?}, expected \"little\" or \"big\"",
                        archive.prefix,
                        String::from_utf8_lossy(&other[..other.len().min(32)])
                    ));
                }
            };
        }
        Ok(archive)
    }

    /// The bytes of `<prefix><rel>`, or `None` when there is no such record.
    pub fn record_opt(&self, rel: &str) -> Result<Option<Cow<'a, [u8]>>, String> {
        let name = format!("{}{rel}", self.prefix);
        let Some(rec) = self.records.get(&name).copied() else {
            return Ok(None);
        };
        let raw = &self.bytes[rec.start as usize..(rec.start + rec.compressed) as usize];
        if rec.stored {
            return Ok(Some(Cow::Borrowed(raw)));
        }
        // Deflate expands at most 1032:1; a larger declared size is corrupt
        // and must not drive the allocation.
        let limit = rec.compressed.saturating_mul(1032).saturating_add(64);
        if rec.size > limit {
            return Err(format!(
                "zip entry {name:?} declares {} bytes from {} compressed bytes",
                rec.size, rec.compressed
            ));
        }
        let mut za = zip::ZipArchive::new(Cursor::new(self.bytes))
            .map_err(|e| format!("invalid zip archive: {e}"))?;
        let f = za
            .by_index(rec.index)
            .map_err(|e| format!("zip entry {name:?}: {e}"))?;
        let mut out = Vec::with_capacity(rec.size as usize);
        f.take(rec.size)
            .read_to_end(&mut out)
            .map_err(|e| format!("zip entry {name:?}: {e}"))?;
        if out.len() as u64 != rec.size {
            return Err(format!(
                "zip entry {name:?} inflates to {} bytes, declared {}",
                out.len(),
                rec.size
            ));
        }
        Ok(Some(Cow::Owned(out)))
    }

    /// The bytes of `<prefix><rel>`, which must exist.
    pub fn record(&self, rel: &str) -> Result<Cow<'a, [u8]>, String> {
        self.record_opt(rel)?
            .ok_or_else(|| format!("zip archive has no record {}{rel}", self.prefix))
    }
}

/// Writes a zip archive of stored entries, streaming, with each entry's data
/// aligned to 64 bytes (as torch does) and zip64 records where sizes or
/// offsets need them. Timestamps are fixed (1980-01-01) so output is
/// reproducible.
pub(crate) struct StoredZipWriter<'w> {
    w: &'w mut dyn Write,
    offset: u64,
    central: Vec<u8>,
    count: u64,
    /// Write zip64 fields even for small archives (tests).
    pub force_zip64: bool,
}

/// Where a record's bytes are handed, piece by piece.
pub(crate) type Sink<'a> = &'a mut dyn FnMut(&[u8]) -> std::io::Result<()>;

const ALIGN: u64 = 64;
const DOS_DATE: u16 = 0x21; // 1980-01-01
const U32_MAX: u64 = 0xffff_ffff;

impl<'w> StoredZipWriter<'w> {
    /// A writer onto `w`.
    pub fn new(w: &'w mut dyn Write) -> Self {
        StoredZipWriter {
            w,
            offset: 0,
            central: Vec::new(),
            count: 0,
            force_zip64: false,
        }
    }

    fn put(&mut self, b: &[u8]) -> std::io::Result<()> {
        self.w.write_all(b)?;
        self.offset += b.len() as u64;
        Ok(())
    }

    /// Adds the entry `name` holding `data`.
    pub fn add(&mut self, name: &str, data: &[u8]) -> std::io::Result<()> {
        self.add_streamed(name, data.len() as u64, &|sink| sink(data))
    }

    /// Adds the entry `name` of `size` bytes that `produce` hands to its sink
    /// in pieces. `produce` runs twice (checksum, then data) and must give
    /// the same bytes both times.
    pub fn add_streamed(
        &mut self,
        name: &str,
        size: u64,
        produce: &dyn Fn(Sink<'_>) -> std::io::Result<()>,
    ) -> std::io::Result<()> {
        let mut hasher = crc32fast::Hasher::new();
        let mut counted = 0u64;
        produce(&mut |b| {
            hasher.update(b);
            counted += b.len() as u64;
            Ok(())
        })?;
        if counted != size {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("zip entry {name}: {counted} bytes produced, {size} announced"),
            ));
        }
        let crc = hasher.finalize();
        let header_at = self.offset;
        let big_size = self.force_zip64 || size >= U32_MAX;
        let big_offset = self.force_zip64 || header_at >= U32_MAX;
        let mut extra = Vec::new();
        if big_size {
            extra.extend(1u16.to_le_bytes());
            extra.extend(16u16.to_le_bytes());
            extra.extend(size.to_le_bytes());
            extra.extend(size.to_le_bytes());
        }
        // Padding field 'FB' so that the data starts on a 64-byte boundary.
        let before = header_at + 30 + name.len() as u64 + extra.len() as u64 + 4;
        let pad = (ALIGN - before % ALIGN) % ALIGN;
        extra.extend(0x4246u16.to_le_bytes());
        extra.extend((pad as u16).to_le_bytes());
        extra.resize(extra.len() + pad as usize, 0);
        let version: u16 = if big_size || big_offset { 45 } else { 20 };
        let size32 = if big_size {
            U32_MAX as u32
        } else {
            size as u32
        };

        let mut h = Vec::with_capacity(30 + name.len() + extra.len());
        h.extend(0x0403_4b50u32.to_le_bytes());
        h.extend(version.to_le_bytes());
        h.extend(0u16.to_le_bytes()); // flags
        h.extend(0u16.to_le_bytes()); // stored
        h.extend(0u16.to_le_bytes()); // time
        h.extend(DOS_DATE.to_le_bytes());
        h.extend(crc.to_le_bytes());
        h.extend(size32.to_le_bytes());
        h.extend(size32.to_le_bytes());
        h.extend((name.len() as u16).to_le_bytes());
        h.extend((extra.len() as u16).to_le_bytes());
        h.extend(name.as_bytes());
        h.extend(&extra);
        self.put(&h)?;
        let mut written = 0u64;
        produce(&mut |b| {
            written += b.len() as u64;
            self.put(b)
        })?;
        if written != size {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("zip entry {name}: {written} bytes written, {size} announced"),
            ));
        }

        let mut cextra = Vec::new();
        if big_size || big_offset {
            let mut fields = Vec::new();
            if big_size {
                fields.extend(size.to_le_bytes());
                fields.extend(size.to_le_bytes());
            }
            if big_offset {
                fields.extend(header_at.to_le_bytes());
            }
            cextra.extend(1u16.to_le_bytes());
            cextra.extend((fields.len() as u16).to_le_bytes());
            cextra.extend(fields);
        }
        let off32 = if big_offset {
            U32_MAX as u32
        } else {
            header_at as u32
        };
        let c = &mut self.central;
        c.extend(0x0201_4b50u32.to_le_bytes());
        c.extend(version.to_le_bytes()); // made by
        c.extend(version.to_le_bytes()); // needed
        c.extend(0u16.to_le_bytes());
        c.extend(0u16.to_le_bytes());
        c.extend(0u16.to_le_bytes());
        c.extend(DOS_DATE.to_le_bytes());
        c.extend(crc.to_le_bytes());
        c.extend(size32.to_le_bytes());
        c.extend(size32.to_le_bytes());
        c.extend((name.len() as u16).to_le_bytes());
        c.extend((cextra.len() as u16).to_le_bytes());
        c.extend(0u16.to_le_bytes()); // comment
        c.extend(0u16.to_le_bytes()); // disk
        c.extend(0u16.to_le_bytes()); // internal attributes
        c.extend(0u32.to_le_bytes()); // external attributes
        c.extend(off32.to_le_bytes());
        c.extend(name.as_bytes());
        c.extend(&cextra);
        self.count += 1;
        Ok(())
    }

    /// Writes the central directory and the end records.
    pub fn finish(mut self) -> std::io::Result<()> {
        let cd_start = self.offset;
        let central = std::mem::take(&mut self.central);
        self.put(&central)?;
        let cd_size = central.len() as u64;
        let big =
            self.force_zip64 || self.count >= 0xffff || cd_start >= U32_MAX || cd_size >= U32_MAX;
        let mut e = Vec::new();
        if big {
            let z64_at = self.offset;
            e.extend(0x0606_4b50u32.to_le_bytes());
            e.extend(44u64.to_le_bytes());
            e.extend(45u16.to_le_bytes());
            e.extend(45u16.to_le_bytes());
            e.extend(0u32.to_le_bytes());
            e.extend(0u32.to_le_bytes());
            e.extend(self.count.to_le_bytes());
            e.extend(self.count.to_le_bytes());
            e.extend(cd_size.to_le_bytes());
            e.extend(cd_start.to_le_bytes());
            e.extend(0x0706_4b50u32.to_le_bytes());
            e.extend(0u32.to_le_bytes());
            e.extend(z64_at.to_le_bytes());
            e.extend(1u32.to_le_bytes());
        }
        let n16 = if big { 0xffff } else { self.count as u16 };
        e.extend(0x0605_4b50u32.to_le_bytes());
        e.extend(0u16.to_le_bytes());
        e.extend(0u16.to_le_bytes());
        e.extend(n16.to_le_bytes());
        e.extend(n16.to_le_bytes());
        e.extend((if big { U32_MAX } else { cd_size } as u32).to_le_bytes());
        e.extend((if big { U32_MAX } else { cd_start } as u32).to_le_bytes());
        e.extend(0u16.to_le_bytes());
        self.put(&e)?;
        self.w.flush()
    }
}
