#![no_main]
//! A photograph's metadata as `match` reads it (EXIF of JPEG or TIFF, DJI XMP).

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    for name in ["f.jpg", "f.tif"] {
        with_file(name, data, |p| {
            let _ = integration::tiepoints::meta::read(p);
        });
    }
});
