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
    let tag = integration::exposure::xmp::PositionTag {
        lat: 47.3,
        lon: 8.5,
        height: 830.0,
        reference: "ellipsoidal (WGS84)".into(),
        orthometric: false,
        sigma_enu: [0.01, 0.01, 0.02],
        quality: 1,
    };
    let _ = exif_io::geotagged(data, &tag);
});
