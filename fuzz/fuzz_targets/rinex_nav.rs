#![no_main]
//! RINEX navigation files.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("f.nav", data, |p| {
        let _ = gnss::rinex::nav::NavFile::read(p);
    });
});
