//! What the tests of every ppkat crate share (a dev-dependency only):
//! - [`shared_data`] finds a set of `../shared/data` beside the repository, skipping a test with
//!   a message when it is absent and failing it on CI (`CI=true`), where it must be present;
//! - [`scratch_dir`], [`scratch_path`] and [`scratch_file`] give a test its files in the build folder
//!   (`target/tmp/<test binary>/`), not the system's temporary folder: each test binary empties
//!   its folder when it first asks for one, so a run leaves only its own files — there for a
//!   look after a failure — and the next run replaces them. Before, every run left ~300 MB of
//!   folders named by process id in `/tmp`;
//! - [`imports::assert_no_import_circles`] fails a crate whose files import each other in a
//!   circle.

pub mod imports;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The file or folder `rel` of `../shared/data` beside the repository, or `None` (with a
/// "skipped" message) when it is absent. Panics when absent on CI (`CI=true`).
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel);
    if p.exists() {
        return Some(p);
    }
    assert!(
        std::env::var("CI").map(|v| v != "true").unwrap_or(true),
        "{} is missing on CI: the shared data must be present",
        p.display()
    );
    eprintln!("skipped: {} not found (shared data absent)", p.display());
    None
}

/// A fresh, empty folder `name` in this test binary's scratch folder (emptied if a test of
/// this process made it before).
pub fn scratch_dir(name: &str) -> PathBuf {
    let d = root().join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d)
        .unwrap_or_else(|e| panic!("cannot make the scratch folder {}: {e}", d.display()));
    d
}

/// The path `name` in this test binary's scratch folder, which exists and held nothing when
/// the process began; `name` itself is not created.
pub fn scratch_path(name: &str) -> PathBuf {
    root().join(name)
}

/// `bytes` written to the file `name` (which may hold folders) of this test binary's scratch
/// folder; its path.
pub fn scratch_file(name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let p = root().join(name);
    let made = p
        .parent()
        .map_or(Ok(()), std::fs::create_dir_all)
        .and_then(|()| std::fs::write(&p, bytes));
    made.unwrap_or_else(|e| panic!("cannot write the scratch file {}: {e}", p.display()));
    p
}

/// `<target>/tmp/<test binary>`, emptied at the first call of the process. The test binary
/// runs from `<target>/<profile>/deps/<name>-<hash>`.
fn root() -> &'static Path {
    static ROOT: OnceLock<PathBuf> = OnceLock::new();
    ROOT.get_or_init(|| {
        let exe = std::env::current_exe().expect("the test binary's path");
        let stem = exe.file_stem().and_then(|s| s.to_str()).unwrap_or("tests");
        let name = stem.rsplit_once('-').map_or(stem, |(n, _)| n);
        let target = exe
            .ancestors()
            .nth(3)
            .map_or_else(std::env::temp_dir, Path::to_path_buf);
        let d = target.join("tmp").join(name);
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d)
            .unwrap_or_else(|e| panic!("cannot make the scratch folder {}: {e}", d.display()));
        d
    })
}
