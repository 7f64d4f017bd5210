//! EGM2008 from the grids users have, on the real crop of NGA's 2.5′ grid in the shared data
//! (`geoid/egm2008-norcal-crop`): NGA's raw layout, PROJ's GTX, and a GeoTIFF written here
//! from the crop as PROJ lays its grids out, each held to the four values PROJ computes from
//! the full grid (the crop's README), and a point outside named with the grid's extent.

use georef::geoid_grid::{GeoidGrid, Placement};
use georef::height::Heights;
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

/// The crop as PROJ's CDN grids are stored: tiled (16 × 16 here, so the 25 × 25 grid spans
/// four partly filled tiles) with the floating-point predictor (TIFF Technical Note 3: each
/// row's bytes split into planes, most significant first, then differenced byte by byte),
/// written by hand because the `tiff` crate cannot encode that predictor.
fn write_tiled_fp_geotiff(path: &Path, v: &[f32]) {
    const T: usize = 16;
    let mut tiles: Vec<Vec<u8>> = Vec::new();
    for ty in 0..2 {
        for tx in 0..2 {
            let mut tile = Vec::with_capacity(T * T * 4);
            for r in 0..T {
                let (y, x0) = (ty * T + r, tx * T);
                let row: Vec<[u8; 4]> = (0..T)
                    .map(|c| {
                        let x = x0 + c;
                        let val = if y < 25 && x < 25 { v[y * 25 + x] } else { 0.0 };
                        val.to_be_bytes()
                    })
                    .collect();
                let mut bytes: Vec<u8> =
                    (0..4).flat_map(|k| row.iter().map(move |b| b[k])).collect();
                for j in (1..bytes.len()).rev() {
                    bytes[j] = bytes[j].wrapping_sub(bytes[j - 1]);
                }
                tile.extend(bytes);
            }
            tiles.push(tile);
        }
    }
    let step = 2.5 / 60.0;
    let doubles = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let keys: Vec<u8> = [
        1u16, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 2, 2048, 0, 1, 4326,
    ]
    .iter()
    .flat_map(|k| k.to_le_bytes())
    .collect();
    // Out-of-line values after the directory, then the tiles.
    const N: usize = 17;
    let mut extra: Vec<u8> = Vec::new();
    let base = 8 + 2 + 12 * N + 4;
    let put = |b: &[u8], extra: &mut Vec<u8>| -> u32 {
        let at = (base + extra.len()) as u32;
        extra.extend_from_slice(b);
        if extra.len() % 2 == 1 {
            extra.push(0);
        }
        at
    };
    let scale = put(&doubles(&[step, step, 0.0]), &mut extra);
    let tie = put(&doubles(&[0.0, 0.0, 0.0, -123.0, 38.0, 0.0]), &mut extra);
    let geo = put(&keys, &mut extra);
    let nodata = put(b"-32768\0", &mut extra);
    let counts_at = put(&[0u8; 16], &mut extra);
    let offsets_at = put(&[0u8; 16], &mut extra);
    let mut offsets = Vec::new();
    for t in &tiles {
        offsets.push(put(t, &mut extra));
    }
    let fill = |extra: &mut Vec<u8>, at: u32, vals: &[u32]| {
        let o = at as usize - base;
        for (k, v) in vals.iter().enumerate() {
            extra[o + 4 * k..o + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
    };
    fill(&mut extra, counts_at, &[(T * T * 4) as u32; 4]);
    fill(&mut extra, offsets_at, &offsets);
    // (tag, type, count, value or offset): SHORT 3, LONG 4, DOUBLE 12, ASCII 2.
    let entries: [(u16, u16, u32, u32); N] = [
        (256, 3, 1, 25),
        (257, 3, 1, 25),
        (258, 3, 1, 32),
        (259, 3, 1, 1),
        (262, 3, 1, 1),
        (277, 3, 1, 1),
        (284, 3, 1, 1),
        (317, 3, 1, 3),
        (322, 3, 1, T as u32),
        (323, 3, 1, T as u32),
        (324, 4, 4, offsets_at),
        (325, 4, 4, counts_at),
        (339, 3, 1, 3),
        (33550, 12, 3, scale),
        (33922, 12, 6, tie),
        (34735, 3, 16, geo),
        (42113, 2, 7, nodata),
    ];
    let mut b: Vec<u8> = b"II*\0".to_vec();
    b.extend(8u32.to_le_bytes());
    b.extend((N as u16).to_le_bytes());
    for (tag, typ, count, value) in entries {
        b.extend(tag.to_le_bytes());
        b.extend(typ.to_le_bytes());
        b.extend(count.to_le_bytes());
        b.extend(value.to_le_bytes());
    }
    b.extend(0u32.to_le_bytes());
    b.extend(extra);
    std::fs::write(path, b).unwrap();
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
    let tiled = testkit::scratch_path("egm2008-crop-tiled-fp.tif");
    write_tiled_fp_geotiff(&tiled, &values(&raw));
    check(
        &GeoidGrid::read(&tiled).unwrap(),
        "tiled GeoTIFF, floating-point predictor",
    );
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
