#![no_main]
//! The antenna or exposure position tables `match --positions` reads to pick image pairs.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("positions.csv", data, |p| {
        let _ = integration::tiepoints::positions::read(p);
    });
});
