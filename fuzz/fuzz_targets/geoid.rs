#![no_main]
//! Geoid grids (`--height geoid:FILE`): the first byte picks the name (`.gtx` is told by its
//! extension; PGM by its magic, text otherwise), then the grid is sampled at a few places.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    let name = if pick & 1 == 0 { "g.gtx" } else { "g.txt" };
    with_file(name, bytes, |p| {
        if let Ok(g) = integration::geoid_grid::GeoidGrid::read(p) {
            for (lat, lon) in [(0.0, 0.0), (50.5, 0.5), (-90.0, 359.9), (89.99, -180.0)] {
                let _ = g.undulation(lat, lon);
            }
        }
    });
});
