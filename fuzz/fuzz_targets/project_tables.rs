#![no_main]
//! The CSV tables of a project (`adjust::tables` through `Project::load`): the first byte
//! picks the table fuzzed (images, measurements, ground points, antennas), the others are
//! small valid ones.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::{with_file, PROJECT_TABLES as TABLES};

const PROJECT: &str = "name = \"f\"\noutput = \"utm\"\n\n[[camera]]\nid = \"c\"\nfocal_mm = 35\npixel_um = 3.9\nwidth_px = 4000\nheight_px = 6000\n\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n\n[gnss]\nantennas = \"antennas.csv\"\nlever_arm = [0.1, -0.05, 0.45]\ndrift = \"auto\"\n";

fuzz_target!(|data: &[u8]| {
    let Some((&pick, table)) = data.split_first() else {
        return;
    };
    let fuzzed = pick as usize % TABLES.len();
    with_file("project.toml", PROJECT.as_bytes(), |p| {
        let dir = p.parent().expect("a folder");
        for (k, (name, text)) in TABLES.iter().enumerate() {
            let bytes = if k == fuzzed { table } else { text.as_bytes() };
            std::fs::write(dir.join(name), bytes).expect("temporary file");
        }
        let _ = integration::adjust::project::Project::load(p);
    });
});
