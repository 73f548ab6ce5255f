//! Test support: locating the shared real-data sets.
//!
//! Tests that read `../shared/data` call [`shared_data`]; when the folder is
//! absent they print why and skip, unless `SPLATKIT_REQUIRE_SHARED=1`, in
//! which case they fail (CI sets it so real-data tests can never silently skip).

use std::path::PathBuf;

/// The path of `rel` under `../shared/data` next to the repository, or
/// `None` (after printing a skip notice) when it does not exist.
///
/// # Panics
/// When the path is missing and `SPLATKIT_REQUIRE_SHARED=1` is set.
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let root = std::env::var_os("SPLATKIT_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"));
    let p = root.join(rel);
    if p.exists() {
        return Some(p);
    }
    if std::env::var("SPLATKIT_REQUIRE_SHARED").as_deref() == Ok("1") {
        panic!(
            "{} is missing and SPLATKIT_REQUIRE_SHARED=1: the shared data sets must be beside the checkout",
            p.display()
        );
    }
    eprintln!(
        "skipped: {} is absent (shared data not checked out)",
        p.display()
    );
    None
}
