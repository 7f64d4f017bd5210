//! EGM2008 from the grids users have, on the real crop of NGA's 2.5′ grid in the shared data
//! (`geoid/egm2008-norcal-crop`): NGA's raw layout, PROJ's GTX, and a GeoTIFF written here
//! from the crop as PROJ lays its grids out, each held to the four values PROJ computes from
//! the full grid (the crop's README), and a point outside named with the grid's extent.

use integration::geoid_grid::{GeoidGrid, Placement};
use integration::height::Heights;
use std::path::{Path, PathBuf};

/// PROJ 9.8.1 with `us_nga_egm08_25.tif`, bilinear (the crop's README).
const PROJ: [(f64, f64, f64); 4] = [
    (37.774900, -122.419400, -32.163558372373),
    (37.500000, -122.750000, -33.605857849121),
    (37.875000, -122.125000, -31.847370147705),
    (38.000000, -122.000000, -31.767843246460),
];

fn crop() -> Option<PathBuf> {
    testkit::shared_data("geoid/egm2008-norcal-crop")
}

fn check(g: &GeoidGrid, what: &str) {
    for (lat, lon, n) in PROJ {
        let got = g.undulation(lat, lon).unwrap();
        assert!(
            (got - n).abs() < 1e-3,
            "{what}: ({lat}, {lon}) {got:.6} m, PROJ {n:.6} m"
        );
    }
}

/// The crop's 25 × 25 values, north row first, from its raw file.
fn values(raw: &Path) -> Vec<f32> {
    let b = std::fs::read(raw).unwrap();
    b.chunks_exact(108)
        .flat_map(|r| {
            r[4..104]
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The crop as PROJ's GeoTIFF grids are laid out: float32, DEFLATE, a geographic model,
/// nodes from 38° N, 123° W every 2.5′ (pixel-is-point, or pixel-is-area with the tie point
/// half a pixel out at the corner), GDAL's no-data value.
fn write_geotiff(path: &Path, v: &[f32], area: bool) {
    use tiff::encoder::{colortype::Gray32Float, Compression, DeflateLevel, TiffEncoder};
    use tiff::tags::Tag;
    let file = std::fs::File::create(path).unwrap();
    let mut enc = TiffEncoder::new(std::io::BufWriter::new(file))
        .unwrap()
        .with_compression(Compression::Deflate(DeflateLevel::Best));
    let mut img = enc.new_image::<Gray32Float>(25, 25).unwrap();
    let step = 2.5 / 60.0;
    let e = img.encoder();
    e.write_tag(Tag::ModelPixelScaleTag, &[step, step, 0.0][..])
        .unwrap();
    let (half, raster) = if area { (step / 2.0, 1) } else { (0.0, 2) };
    e.write_tag(
        Tag::ModelTiepointTag,
        &[0.0, 0.0, 0.0, -123.0 - half, 38.0 + half, 0.0][..],
    )
    .unwrap();
    // Version 1.1.0, 3 keys: model geographic, the raster type, WGS 84.
    e.write_tag(
        Tag::GeoKeyDirectoryTag,
        &[
            1u16, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, raster, 2048, 0, 1, 4326,
        ][..],
    )
    .unwrap();
    e.write_tag(Tag::GdalNodata, "-32768").unwrap();
    img.write_data(v).unwrap();
}

#[test]
fn the_crop_gives_proj_values_from_raw_gtx_and_geotiff() {
    let Some(dir) = crop() else {
        return;
    };
    let raw = dir.join("egm2008_25_norcal_crop.bin");
    let place = Placement::parse("38,-123,2.5").unwrap();
    check(&GeoidGrid::read_placed(&raw, Some(place)).unwrap(), "raw");
    check(
        &GeoidGrid::read(&dir.join("egm2008_25_norcal_crop.gtx")).unwrap(),
        "GTX",
    );
    for area in [false, true] {
        let tif = testkit::scratch_path(&format!("egm2008-crop-{area}.tif"));
        write_geotiff(&tif, &values(&raw), area);
        check(
            &GeoidGrid::read(&tif).unwrap(),
            &format!("GeoTIFF, pixel-is-area {area}"),
        );
    }
    // As a user gives it, through --height.
    let Heights::Grid(g) = Heights::parse(&format!("geoid:{}@38,-123,2.5", raw.display())).unwrap()
    else {
        panic!("a grid");
    };
    check(&g, "raw through --height");
}

#[test]
fn a_point_outside_the_crop_and_a_crop_without_placement_say_what_to_do() {
    let Some(dir) = crop() else {
        return;
    };
    let g = GeoidGrid::read(&dir.join("egm2008_25_norcal_crop.gtx")).unwrap();
    let e = g.undulation(36.5, -122.5).unwrap_err().to_string();
    for needle in [
        "latitude 36.500000",
        "longitude -122.500000",
        "latitudes 37.000000° to 38.000000°",
        "longitudes -123.000000° to -122.000000°",
    ] {
        assert!(e.contains(needle), "{needle:?} not in: {e}");
    }
    let e = GeoidGrid::read(&dir.join("egm2008_25_norcal_crop.bin"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("25 rows of 25") && e.contains("@38,-123,2.5"),
        "{e}"
    );
}
