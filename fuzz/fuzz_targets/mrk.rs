#![no_main]
//! DJI Timestamp.MRK files.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("f.MRK", data, |p| {
        let _ = integration::exposure::events::read_mrk(p);
    });
});
