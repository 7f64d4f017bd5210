#![no_main]
//! ppkat project TOML, with small valid copies of every table and file it may name beside it
//! (so a project that parses goes on to read them as `adjust` would).

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::{with_file, write_project_files};

fuzz_target!(|data: &[u8]| {
    with_file("project.toml", data, |p| {
        write_project_files(p.parent().expect("a folder"));
        let _ = integration::adjust::project::Project::load(p);
    });
});
