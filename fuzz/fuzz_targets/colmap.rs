#![no_main]
//! COLMAP sparse text models: the first byte picks the file fuzzed (cameras.txt, images.txt,
//! points3D.txt), the others are small valid ones; the datum folder holds no photo.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

/// The model's files, each a small valid one.
const FILES: [(&str, &str); 3] = [
    ("cameras.txt", "# Camera list\n1 SIMPLE_RADIAL 4000 3000 3000 2000 1500 0.01\n"),
    (
        "images.txt",
        "# Image list\n1 1 0 0 0 0 0 0 1 a.jpg\n100 200 1 300 400 2\n2 1 0 0 0 1 0 0 1 b.jpg\n110 210 1 310 410 2\n",
    ),
    (
        "points3D.txt",
        "# 3D point list\n1 0.1 0.2 5.0 128 128 128 0.5 1 0 2 0\n2 0.3 0.4 5.0 128 128 128 0.5 1 2 2 2\n",
    ),
];

fuzz_target!(|data: &[u8]| {
    use integration::import::colmap::{import, ColmapJob};
    let Some((&pick, text)) = data.split_first() else {
        return;
    };
    let fuzzed = pick as usize % FILES.len();
    with_file("cameras.txt", FILES[0].1.as_bytes(), |p| {
        let dir = p.parent().expect("a folder").to_path_buf();
        for (k, (name, fixed)) in FILES.iter().enumerate() {
            let bytes = if k == fuzzed { text } else { fixed.as_bytes() };
            std::fs::write(dir.join(name), bytes).expect("temporary file");
        }
        let photos = dir.join("photos");
        std::fs::create_dir_all(&photos).expect("temporary folder");
        let _ = import(&ColmapJob {
            dir,
            gnss_exif: Some(photos),
            gnss_sigma: [3.0, 5.0],
            min_track: 2,
            pixel_um: 1.0,
            sigma_px: 1.0,
        });
    });
});
