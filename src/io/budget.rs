//! The process's memory budget, one rule for every command (RELIABILITY.md,
//! "One memory budget"): sizes that a flag or a file drives are estimated
//! and compared with it *before* anything that large is allocated.
//!
//! The budget is min(MemTotal, `ulimit -v`) read from `/proc`; the part an
//! estimate may take is [`USABLE_NUM`]/[`USABLE_DEN`] of it (the margin leaves
//! room for the program, its thread stacks, the allocator's slack and the
//! buffers no estimate counts). Where `/proc` cannot be read the budget is
//! taken as [`FALLBACK_BYTES`].

use crate::{Error, Result};

/// Budget assumed where neither `/proc/meminfo` nor `/proc/self/limits` can be read.
pub const FALLBACK_BYTES: u64 = 8 << 30;
/// The fraction of the budget one estimate may use: 3/4.
pub const USABLE_NUM: u64 = 3;
/// See [`USABLE_NUM`].
pub const USABLE_DEN: u64 = 4;

/// Bytes of memory this process may use: the smaller of the machine's
/// total memory (`/proc/meminfo`) and the address-space limit
/// (`ulimit -v`, from `/proc/self/limits`); `None` where neither can be read.
pub fn memory_budget() -> Option<u64> {
    let total = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        t.lines()
            .find(|l| l.starts_with("MemTotal:"))
            .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
            .map(|kib| kib.saturating_mul(1024))
    });
    let limit = std::fs::read_to_string("/proc/self/limits")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("Max address space"))
                .and_then(|l| l.split_whitespace().nth(3)?.parse::<u64>().ok())
        });
    match (total, limit) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// The bytes one estimate may take: [`USABLE_NUM`]/[`USABLE_DEN`] of
/// [`memory_budget`] (or of [`FALLBACK_BYTES`]).
pub fn usable_bytes() -> u64 {
    memory_budget().unwrap_or(FALLBACK_BYTES) / USABLE_DEN * USABLE_NUM
}

/// Human form of a byte count ("3.0 GiB", "512.0 MiB", "900 B").
pub fn human_bytes(b: u64) -> String {
    const K: f64 = 1024.0;
    let f = b as f64;
    if f >= K * K * K * K {
        format!("{:.1} TiB", f / (K * K * K * K))
    } else if f >= K * K * K {
        format!("{:.1} GiB", f / (K * K * K))
    } else if f >= K * K {
        format!("{:.1} MiB", f / (K * K))
    } else if f >= K {
        format!("{:.1} KiB", f / K)
    } else {
        format!("{b} B")
    }
}

/// Refuses an estimate above [`usable_bytes`]: `Err(Error::Invalid)` whose
/// message names `what` (the flag or file and the quantity, e.g.
/// "--size 16384x16384: the image buffers"), the estimate and the budget.
/// Use saturating arithmetic to form `bytes` so an overflow is refused too.
pub fn check(what: &str, bytes: u64) -> Result<()> {
    let usable = usable_bytes();
    if bytes > usable {
        return Err(Error::invalid(format!(
            "{what} would need about {}, more than this process's memory budget of {} \
             (3/4 of the smaller of MemTotal and `ulimit -v`)",
            human_bytes(bytes),
            human_bytes(usable)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The budget is read on Linux and is at least a few MB; the usable part is 3/4 of it.
    #[test]
    fn budget_is_read_and_checked() {
        let b = memory_budget().expect("/proc is readable on Linux");
        assert!(b > 16 << 20);
        assert_eq!(usable_bytes(), b / 4 * 3);
        assert!(check("small", 1024).is_ok());
        let e = check("--size 9x9: the images", u64::MAX)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--size 9x9: the images") && e.contains("memory budget"),
            "{e}"
        );
        assert_eq!(human_bytes(3 << 30), "3.0 GiB");
    }
}
