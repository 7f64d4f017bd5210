#![no_main]
//! PATB image coordinates, imported with one ideal camera.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    use integration::import::patb::{import, CameraNumbers, CameraSource, PatbJob, Units};
    with_file("f.patb", data, |p| {
        for units in [Units::Mm, Units::Px] {
            let _ = import(&PatbJob {
                images: p.to_path_buf(),
                units,
                camera: CameraSource::Numbers(CameraNumbers {
                    focal_mm: 35.0,
                    pixel_um: 4.0,
                    width_px: Some(6000),
                    height_px: Some(4000),
                    sigma_px: 0.5,
                }),
                ground: None,
                check: vec![],
                ground_sigma: [0.02, 0.03],
                crs: None,
            });
        }
    });
});
