//! The joint GNSS-supported adjustment on simulated blocks with known truth, one test binary
//! with a module per topic; the helpers shared by them live here.

mod attitude;
mod bad_input;
mod classic;
mod close_range;
mod inputs;
mod latency;
mod models;
mod nav;
mod patb;
mod sparse;

use integration::adjust::{self, results::Results};
use integration::simulate::block::{self, BlockSpec, BlockTruth};
use std::path::PathBuf;

pub use testkit::scratch_path as tmp;

pub fn run(spec: &BlockSpec, name: &str) -> (BlockTruth, Results) {
    let dir = tmp(name);
    let truth = block::aerial(spec, &dir).unwrap();
    let res = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    (truth, res)
}

/// The tape-measured lever arm: truth + (1.5, −1.0, 1.5) cm, σ 2 cm.
pub fn gnss_options(drift_model: &str) -> String {
    block::gnss_section(
        &BlockSpec::classic(),
        block::TAPE_ERROR,
        "block",
        drift_model,
    )
}

/// A written classic project to break in one way.
pub fn project_dir(name: &str) -> PathBuf {
    let dir = tmp(name);
    let mut spec = BlockSpec::classic();
    spec.project_options = gnss_options("linear");
    block::aerial(&spec, &dir).unwrap();
    dir
}

pub fn edit(dir: &std::path::Path, file: &str, f: impl Fn(&str) -> String) {
    let p = dir.join(file);
    let t = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, f(&t)).unwrap();
}

pub fn fails(dir: &std::path::Path) -> String {
    let e = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .expect_err("must fail");
    assert!(
        !dir.join("out/report.json").exists(),
        "no output on failure"
    );
    e.to_string()
}
