#![no_main]
//! EXIF of JPEG/TIFF photos: read, position, and a geotagged copy.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    use integration::exposure::exif_io;
    with_file("f.jpg", data, |p| {
        if let Ok(Some(x)) = exif_io::read(p) {
            let _ = exif_io::gps_position(&x);
        }
    });
    let _ = exif_io::geotagged(data, 47.3, 8.5, 830.0);
});
