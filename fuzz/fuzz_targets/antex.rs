#![no_main]
//! ANTEX antenna files.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("f.atx", data, |p| {
        let _ = gnss::model::antex::Antex::read(p);
    });
});
