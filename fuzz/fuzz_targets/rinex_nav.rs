#![no_main]
//! RINEX navigation files, their ephemerides loaded and evaluated.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("f.nav", data, |p| {
        if let Ok(nav) = gnss::rinex::nav::NavFile::read(p) {
            ppkat_fuzz::evaluate(&[nav]);
        }
    });
});
