#![no_main]
//! RINEX clock files.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("f.clk", data, |p| {
        let _ = gnss::orbit::clk::ClockFile::read(p);
    });
});
