//! Photos built to hurt the EXIF reader (issue 19, `tests/fixtures/exif`): directory chains
//! that loop, counts of 0xFFFFFFFF, a PNG named `.jpg`. Each must cost one message naming the photo, never memory
//! without bound or a panic, and the other photos must still be listed and geotagged.

use gnss::solution::Quality;
use integration::exposure::photos;
use integration::exposure::{AttitudeSource, CameraStation};
use nalgebra::Matrix3;
use std::path::Path;

use testkit::scratch_dir as tmp;

/// The hostile photos of `tests/fixtures/exif` (see its README), by name.
fn hostile() -> Vec<(&'static str, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/exif");
    [
        "self_loop.jpg",
        "ping_pong.jpg",
        "sub_loop.jpg",
        "huge_count.jpg",
        "huge_rational.jpg",
        "renamed_png.jpg",
    ]
    .into_iter()
    .map(|n| (n, std::fs::read(dir.join(n)).unwrap()))
    .collect()
}

fn station(k: usize) -> CameraStation {
    let c = gnss::frame::Geodetic::from_degrees(47.3 + 0.001 * k as f64, 8.55, 830.0).to_ecef();
    CameraStation {
        id: format!("{}", k + 1),
        time: gnss::time::from_week_tow(2318, 291_700.0 + 3.0 * k as f64),
        antenna: c,
        velocity: nalgebra::Vector3::zeros(),
        centre: c,
        cov: Matrix3::identity() * 1e-4,
        quality: Quality::Fixed,
        segment: 0,
        rotation: Matrix3::identity(),
        attitude: AttitudeSource::Heading,
        rotation_sigma: None,
        flags: vec![],
    }
}

fn good_photo() -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/photo_16x16.jpg"))
        .unwrap()
}

/// Each hostile photo alone is read in bounded time and memory: a reason, no capture time.
#[test]
fn looping_and_lying_exif_is_refused_with_a_reason() {
    for (name, bytes) in hostile() {
        let dir = tmp(name.trim_end_matches(".jpg"));
        std::fs::write(dir.join(name), &bytes).unwrap();
        let list = photos::list(&dir).unwrap();
        assert_eq!(list.len(), 1);
        assert!(list[0].taken.is_none(), "{name}");
        // A PNG has no EXIF to read (it is refused when geotagging).
        if name != "renamed_png.jpg" {
            assert!(list[0].exif_error.is_some(), "{name}: no error");
        }
        assert!(photos::read_position(&dir.join(name)).is_none(), "{name}");
    }
}

/// A folder of good photos with the hostile ones among them: every good one is geotagged, each
/// hostile one is named with its reason, and nothing of it is left in the output folder.
#[test]
fn one_bad_photo_is_one_message_and_the_rest_are_geotagged() {
    let dir = tmp("mixed");
    let mut names = Vec::new();
    for (k, (name, bytes)) in hostile().into_iter().enumerate() {
        let good = format!("good_{k}.jpg");
        std::fs::write(dir.join(&good), good_photo()).unwrap();
        std::fs::write(dir.join(name), &bytes).unwrap();
        names.push(good);
        names.push(name.to_string());
    }
    let originals: Vec<Vec<u8>> = names
        .iter()
        .map(|n| std::fs::read(dir.join(n)).unwrap())
        .collect();
    let list = photos::list(&dir).unwrap();
    assert_eq!(list.len(), names.len());
    let stations: Vec<CameraStation> = (0..list.len()).map(station).collect();
    let out = tmp("mixed-out");
    let done = photos::geotag(&list, &stations, &out, &Default::default()).unwrap();
    assert_eq!(done.written.len(), 6, "the good ones: {:?}", done.skipped);
    assert_eq!(done.skipped.len(), 6, "{:?}", done.skipped);
    for (p, why) in &done.skipped {
        assert!(
            p.starts_with(&dir),
            "the original is named: {}",
            p.display()
        );
        assert!(!out.join(p.file_name().unwrap()).exists(), "{why}");
    }
    let png = done
        .skipped
        .iter()
        .find(|(p, _)| p.ends_with("renamed_png.jpg"))
        .unwrap();
    assert!(
        png.1.contains("not a JPEG") && png.1.contains("PNG"),
        "{}",
        png.1
    );
    for w in &done.written {
        let k = list
            .iter()
            .position(|p| w.file_name() == Some(p.name.as_ref()))
            .unwrap();
        let (lat, _, h) = photos::read_position(w).expect("GPS written");
        assert!((lat - (47.3 + 0.001 * k as f64)).abs() < 1e-7 && (h - 830.0).abs() < 1e-3);
    }
    // No temporary file left beside the copies; the originals as they were.
    let leftovers: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    for (n, o) in names.iter().zip(&originals) {
        assert_eq!(&std::fs::read(dir.join(n)).unwrap(), o, "{n} untouched");
    }
}
