#![no_main]
//! The names file of `exposures --names` (one photo name per exposure, in exposure order).

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("names.txt", data, |p| {
        let _ = integration::exposure::names::read_file(p);
    });
});
