#![no_main]
//! `import patb`: the input read as image coordinates (in both units, with one ideal camera and
//! a fixed control file), as a control file (local frame and UTM, with fixed image
//! coordinates) and as a camera file (`--camera FILE`, also `match --camera`).

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::{with_file, write_fixed};
use std::path::Path;

/// Image coordinates measuring the points of `CONTROL`; headers name the camera `cam`.
const IMAGES: &str =
    "101 cam\nP1 0.25 0.1\nP2 -0.5 -0.4\nP3 1.0 2.0\n-99\n102 cam\nP1 0.3 0.2\nP2 -0.4 -0.3\n-99\n";
/// Control points in each of the file's forms (no σ, σXY σZ, σX σY σZ, a kind).
const CONTROL: &str = "P1 500100.0 5200200.0 430.0\nP2 500110.0 5200210.0 431.0 0.02 0.03 gcp\n-99\nP3 500120.0 5200190.0 429.0 0.02 0.02 0.04 check\n";

fuzz_target!(|data: &[u8]| {
    use integration::import::patb::{import, CameraNumbers, CameraSource, PatbJob, Units};
    with_file("f.patb", data, |p| {
        let dir = p.parent().expect("a folder");
        let [images, control] = write_fixed(dir, &[("i.patb", IMAGES), ("g.patb", CONTROL)]);
        let numbers = CameraSource::Numbers(CameraNumbers {
            focal_mm: 35.0,
            pixel_um: 4.0,
            width_px: Some(6000),
            height_px: Some(4000),
            sigma_px: 0.5,
        });
        let job = |images: &Path, camera, ground: &Path, check, crs| PatbJob {
            images: images.to_path_buf(),
            units: Units::Mm,
            camera,
            ground: Some(ground.to_path_buf()),
            check,
            ground_sigma: [0.02, 0.03],
            crs,
        };
        for units in [Units::Mm, Units::Px] {
            let _ = import(&PatbJob {
                units,
                ..job(p, numbers.clone(), &control, vec![], None)
            });
        }
        let _ = import(&job(&images, numbers.clone(), p, vec![], None));
        let utm = Some("EPSG:32632".to_string());
        let _ = import(&job(&images, numbers, p, vec!["P2".into()], utm));
        let file = CameraSource::File(p.to_path_buf());
        let _ = import(&job(&images, file, &control, vec![], None));
    });
});
