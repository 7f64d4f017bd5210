//! What every fuzz target shares: the parsers read files, so the input is written to a file of
//! this process first.

use std::path::{Path, PathBuf};

/// Write `data` to a file of this process named `name` and run `f` on its path.
pub fn with_file<T>(name: &str, data: &[u8], f: impl FnOnce(&Path) -> T) -> T {
    let dir = std::env::temp_dir().join(format!("ppkat-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let path: PathBuf = dir.join(name);
    std::fs::write(&path, data).expect("temporary file");
    f(&path)
}
