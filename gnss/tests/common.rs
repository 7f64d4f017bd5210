//! Helpers shared by the real-data tests: find ../shared/data, skip or fail when absent.

#![allow(dead_code)]

use std::path::PathBuf;

/// The shared data folder, or `None` (with a message) when it is absent outside CI.
/// On CI (`CI=true`) its absence is a failure.
pub fn data(rel: &str) -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    let p = root.join(rel);
    if p.exists() {
        return Some(p);
    }
    if std::env::var("CI").map(|v| v == "true").unwrap_or(false) {
        panic!(
            "{} is missing on CI: the shared data must be present",
            p.display()
        );
    }
    eprintln!("skipped: {} not found (shared data absent)", p.display());
    None
}

pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}
