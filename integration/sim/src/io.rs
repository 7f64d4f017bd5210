//! How the simulator writes its files: atomically, creating the folder.
//!
//! What enters: a folder, a file name and the text (or bytes). What leaves: the file's path, or the
//! [`SimError`] of the failure.

use super::error::SimError;
use std::path::{Path, PathBuf};

/// Write a simulated file atomically, creating its folder.
pub(super) fn write(dir: &Path, name: &str, text: &str) -> Result<PathBuf, SimError> {
    write_bytes(dir, name, text.as_bytes())
}

/// Write a simulated binary file (a raw log) atomically, creating its folder.
pub(super) fn write_bytes(dir: &Path, name: &str, bytes: &[u8]) -> Result<PathBuf, SimError> {
    std::fs::create_dir_all(dir).map_err(gnss::Error::io(dir))?;
    let p = dir.join(name);
    common::atomic::write_atomic(&p, |w| w.write_all(bytes))?;
    Ok(p)
}
