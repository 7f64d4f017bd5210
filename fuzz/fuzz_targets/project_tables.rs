#![no_main]
//! The CSV tables of a project (`adjust::tables` through `Project::load`): the first byte
//! picks the table fuzzed (images, measurements, ground points, antennas), the others are
//! small valid ones.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

const PROJECT: &str = "name = \"f\"\noutput = \"utm\"\n\n[[camera]]\nid = \"c\"\nfocal_mm = 35\npixel_um = 3.9\nwidth_px = 4000\nheight_px = 6000\n\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n\n[gnss]\nantennas = \"antennas.csv\"\nlever_arm = [0.1, -0.05, 0.45]\ndrift = \"auto\"\n";

/// The tables, each a small valid one.
const TABLES: [(&str, &str); 4] = [
    ("images.csv", "image,strip\n1,1\n2,1\n"),
    (
        "image_observations.csv",
        "image,point,x_px,y_px,sigma_px\n1,G1,983.8,1698.6,0.5\n2,G1,130.2,1669.5,0.5\n1,T1,10,20,0.5\n2,T1,30,40,0.5\n",
    ),
    (
        "ground_points.csv",
        "point,kind,lat_deg,lon_deg,h,sigma_xy,sigma_z\nG1,gcp,47.2911,8.5423,492.1,0.02,0.03\n",
    ),
    (
        "antennas.csv",
        "id,week,tow,lat,lon,h,c_ee,c_en,c_eu,c_nn,c_nu,c_uu,quality,segment\n1,2318,291695.3,47.2913,8.5431,830.09,9.6e-6,0,0,1.3e-5,0,1e-4,1,2\n2,2318,291695.9,47.2915,8.5432,830.08,9.6e-6,0,0,1.3e-5,0,1e-4,1,2\n",
    ),
];

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
