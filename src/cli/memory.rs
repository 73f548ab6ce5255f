//! Keeping freed memory for reuse in long iterative runs.
//!
//! A training step allocates and frees the same large buffers every
//! iteration (SH copies and gradients of 30–40 MB for 200k Gaussians, the
//! per-tile lists, the image buffers). glibc's malloc serves blocks above
//! its mmap threshold (at most 32 MB when left to adjust itself) with a
//! fresh `mmap` and returns them with `munmap`, so every step pays the page
//! faults of touching that memory again, and it trims the heap top above
//! 128 kB: at 200k Gaussians on 2 threads that was a fifth of a training
//! step (measured in docs/BENCHMARKS.md). [`keep_freed_memory`] raises both
//! limits so freed blocks stay in the process and are reused; the process
//! then keeps its peak size until it exits, which is what a command that
//! runs one job and exits wants.

/// Raises glibc malloc's mmap and trim thresholds to 1 GiB (see the module
/// docs). Call it once, early, from a command that iterates over large
/// buffers. Returns whether the allocator took both limits; elsewhere than
/// Linux with glibc it does nothing and returns false. Results do not
/// depend on it; only the time spent in the kernel does.
pub fn keep_freed_memory() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        const LIMIT: libc::c_int = 1 << 30;
        // SAFETY: mallopt only sets allocator parameters; it is safe to call
        // at any time, and a refused value leaves the default in place.
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, LIMIT) == 1
                && libc::mallopt(libc::M_TRIM_THRESHOLD, LIMIT) == 1
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    false
}

#[cfg(test)]
mod tests {
    /// glibc accepts both limits (a glibc that capped the mmap threshold,
    /// as old ones did at 32 MB, would refuse and this would fail).
    #[test]
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    fn glibc_takes_the_limits() {
        assert!(super::keep_freed_memory());
    }
}
