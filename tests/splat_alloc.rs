//! A SOG bundle's zip entries declare their uncompressed sizes; the reader
//! must not reserve what a header claims (fuzzing found a 25-KB bundle whose
//! entry declared 1 GiB, reserved before inflating: an abort at the
//! address-space limit on a 16-core machine). A tracking allocator
//! (`common/largest_alloc.rs`) measures the largest single allocation.

#[path = "common/largest_alloc.rs"]
mod largest_alloc;

use std::path::Path;

use splatkit::io::splat::sog;

const FIXTURE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/testdata/splats/splat_transform.sog"
);

/// `bytes` with the uncompressed size of entry `name` set to `size` in its
/// local header and in the central directory (no zip64: the fixture is small).
fn declare_size(bytes: &[u8], name: &str, size: u32) -> Vec<u8> {
    let mut b = bytes.to_vec();
    let mut patched = 0;
    for at in 0..b.len().saturating_sub(46) {
        // (name length, uncompressed size, name) offsets: local, central header
        let (name_len_at, size_at, name_at) = match &b[at..at + 4] {
            [b'P', b'K', 3, 4] => (at + 26, at + 22, at + 30),
            [b'P', b'K', 1, 2] => (at + 28, at + 24, at + 46),
            _ => continue,
        };
        let n = u16::from_le_bytes([b[name_len_at], b[name_len_at + 1]]) as usize;
        if b.get(name_at..name_at + n) == Some(name.as_bytes()) {
            b[size_at..size_at + 4].copy_from_slice(&size.to_le_bytes());
            patched += 1;
        }
    }
    assert_eq!(patched, 2, "entry {name} in the local and central headers");
    b
}

/// The fixture reads with small allocations; the same bundle with one image
/// entry declaring 1 GiB or 4 GiB − 1 is an error naming the entry and both
/// sizes, and reading it allocates no more than the clean read does
/// (bound: 16 MiB, the reader's fixed first reservation, whatever the header
/// claims; the clean fixture is 25 KB).
#[test]
fn declared_zip_entry_sizes_are_not_reserved() {
    let clean = std::fs::read(FIXTURE).unwrap();
    let read = |b: &[u8]| sog::read("s.sog", b, Path::new("/nonexistent"));
    let (g, clean_largest) = largest_alloc::during(|| read(&clean));
    assert!(g.is_ok(), "{:?}", g.err());
    assert!(clean_largest < 1 << 20, "clean read: {clean_largest} bytes");
    for size in [1u32 << 30, u32::MAX - 1] {
        let hostile = declare_size(&clean, "means_l.webp", size);
        let (r, largest) = largest_alloc::during(|| read(&hostile));
        let e = r.expect_err("a size the entry does not hold").to_string();
        assert!(
            e.contains("means_l.webp") && e.contains(&size.to_string()),
            "{e}"
        );
        assert!(
            largest <= 16 << 20,
            "declared {size}: allocated {largest} bytes"
        );
    }
}
