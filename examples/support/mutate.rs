//! Byte-level mutations shared by the fuzz examples (`fuzz_readers`,
//! `fuzz_commands`), included by each with `#[path]`: one implementation, so
//! the reader fuzzer's mutants for a seed stay what they were.

use rand::RngExt;
use splatkit::model::rng;

/// Applies 1–4 random mutations to `b`.
pub fn mutate(b: &mut Vec<u8>, r: &mut rng::Rng) {
    let n = r.random_range(1..=4);
    for _ in 0..n {
        let len = b.len();
        match r.random_range(0..9) {
            0 if len > 0 => {
                let i = r.random_range(0..len);
                b[i] ^= 1 << r.random_range(0..8);
            }
            1 if len > 0 => {
                let i = r.random_range(0..len);
                b[i] = [0u8, 0xff, 0x7f, 0x80, b'-', b'9', b'\n'][r.random_range(0..7)];
            }
            2 if len >= 8 => {
                let i = r.random_range(0..len - 7);
                let v: u64 = [
                    0,
                    u32::MAX as u64,
                    i32::MAX as u64,
                    1 << 31,
                    u64::MAX,
                    len as u64,
                ][r.random_range(0..6)];
                let bytes = v.to_le_bytes();
                let w = [4usize, 8][r.random_range(0..2)];
                b[i..i + w].copy_from_slice(&bytes[..w]);
            }
            3 if len > 0 => {
                let at = r.random_range(0..len);
                b.truncate(at);
            }
            4 if len > 1 => {
                let a = r.random_range(0..len);
                let e = (a + r.random_range(1..=64)).min(len);
                b.drain(a..e);
            }
            5 if len > 1 => {
                let a = r.random_range(0..len);
                let e = (a + r.random_range(1..=64)).min(len);
                let chunk: Vec<u8> = b[a..e].to_vec();
                let at = r.random_range(0..=b.len());
                b.splice(at..at, chunk);
            }
            6 => {
                let at = r.random_range(0..=len);
                let k = r.random_range(1..=16);
                let junk: Vec<u8> = (0..k).map(|_| r.random_range(0..=255u8)).collect();
                b.splice(at..at, junk);
            }
            7 if len > 0 => {
                // A number in text replaced by an extreme one.
                let starts: Vec<usize> = (0..len)
                    .filter(|&i| b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_digit()))
                    .collect();
                if let Some(&s) = starts.get(r.random_range(0..starts.len().max(1))) {
                    let e = (s..len).find(|&i| !b[i].is_ascii_digit()).unwrap_or(len);
                    let v: &[u8] = [
                        &b"4294967295"[..],
                        b"18446744073709551615",
                        b"-1",
                        b"nan",
                        b"1e308",
                        b"0",
                        b"99999999999999999999999",
                    ][r.random_range(0..7)];
                    b.splice(s..e, v.iter().copied());
                }
            }
            _ => {}
        }
    }
}
