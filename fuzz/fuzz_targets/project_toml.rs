#![no_main]
//! ppkat project TOML, with small valid copies of every table and file it may name beside it
//! (so a project that parses goes on to read them as `adjust` would).

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::{with_file, write_fixed, PROJECT_EXTRAS, PROJECT_TABLES};

fuzz_target!(|data: &[u8]| {
    with_file("project.toml", data, |p| {
        let dir = p.parent().expect("a folder");
        write_fixed(dir, &PROJECT_TABLES);
        write_fixed(dir, &PROJECT_EXTRAS);
        let _ = integration::adjust::project::Project::load(p);
    });
});
