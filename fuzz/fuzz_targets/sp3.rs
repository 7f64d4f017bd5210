#![no_main]
//! SP3 precise orbits.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("f.sp3", data, |p| {
        let _ = gnss::orbit::sp3::Sp3::read(p);
    });
});
