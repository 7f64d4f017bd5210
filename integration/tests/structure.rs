//! No function over 120 lines, and no two files of a crate import each other, directly or
//! around a circle (see `testkit::imports`): for `integration` and every crate beside it in
//! `integration/` (`common` checks itself). A crate added there is checked without being named.

use std::path::{Path, PathBuf};

/// `integration` and each crate folder inside it.
fn crates() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(root)
        .expect("integration/ readable")
        .filter_map(|e| Some(e.ok()?.path()))
        .filter(|p| p.join("Cargo.toml").is_file() && p.join("src").is_dir())
        .collect();
    dirs.sort();
    dirs.insert(0, root.to_path_buf());
    assert!(dirs.len() >= 8, "integration's crates not found: {dirs:?}");
    dirs
}

#[test]
fn no_import_circle_between_the_files_of_any_integration_crate() {
    for dir in crates() {
        testkit::imports::assert_no_import_circles(dir.to_str().expect("UTF-8 path"));
    }
}

#[test]
fn no_function_over_120_lines_in_any_integration_crate() {
    for dir in crates() {
        testkit::imports::assert_no_long_functions(dir.to_str().expect("UTF-8 path"), 120);
    }
}
