#![no_main]
//! ppkat project TOML (the tables it names are absent or fuzzed beside it).

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("project.toml", data, |p| {
        let _ = integration::adjust::project::Project::load(p);
    });
});
