//! PROJ's geoid grids in GeoTIFF (`us_nga_egm08_25.tif`, `us_nga_egm96_15.tif`, the national
//! grids of the PROJ-data package and its CDN): the first image of the file, one sample per
//! pixel (float, or integers with GDAL's offset and scale), placed by GeoTIFF's
//! `ModelPixelScale` and `ModelTiepoint` tags in a geographic (degrees) model, pixel-is-area
//! or pixel-is-point as its `GTRasterTypeGeoKey` says. GDAL's no-data value marks nodes
//! without a value. Strips or tiles, DEFLATE or LZW, with or without a predictor: as the
//! `tiff` crate decodes them (already in the build for the photos).

use super::{GeoidGrid, MAX_GRID_BYTES};
use gnss::error::{Error, Result};
use std::path::Path;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

/// Whether `b` starts as a TIFF or BigTIFF file does.
pub fn is_tiff(b: &[u8]) -> bool {
    b.starts_with(b"II*\0")
        || b.starts_with(b"MM\0*")
        || b.starts_with(b"II+\0")
        || b.starts_with(b"MM\0+")
}

/// GeoTIFF's keys read here.
const MODEL_TYPE: u16 = 1024;
const RASTER_TYPE: u16 = 1025;
/// `GTModelTypeGeoKey` of a geographic (latitude, longitude) model.
const GEOGRAPHIC: u16 = 2;
/// `GTRasterTypeGeoKey` of pixel-is-point (1 is pixel-is-area, the default).
const PIXEL_IS_POINT: u16 = 2;
/// GDAL's metadata tag (XML with the band's offset and scale).
const GDAL_METADATA: u16 = 42112;

/// The grid in the first image of a GeoTIFF file.
pub(super) fn read(path: &Path, b: &[u8]) -> Result<GeoidGrid> {
    let bad = |what: String| Error::input(path, format!("GeoTIFF geoid grid: {what}"));
    let mut limits = Limits::default();
    limits.decoding_buffer_size = MAX_GRID_BYTES as usize;
    limits.intermediate_buffer_size = MAX_GRID_BYTES as usize;
    let mut d = Decoder::new(std::io::Cursor::new(b))
        .map_err(|e| bad(format!("not a readable TIFF ({e})")))?
        .with_limits(limits);
    let (cols, rows) = d.dimensions().map_err(|e| bad(e.to_string()))?;
    let (cols, rows) = (cols as usize, rows as usize);
    let f64s = |d: &mut Decoder<_>, tag: Tag| d.get_tag_f64_vec(tag).ok();
    let (Some(scale), Some(tie)) = (
        f64s(&mut d, Tag::ModelPixelScaleTag),
        f64s(&mut d, Tag::ModelTiepointTag),
    ) else {
        return Err(bad(
            "no ModelPixelScale and ModelTiepoint tags: a TIFF that is not a georeferenced grid"
                .into(),
        ));
    };
    if scale.len() < 2 || tie.len() < 6 || !(scale[0] > 0.0 && scale[1] > 0.0) {
        return Err(bad(format!(
            "pixel scale {scale:?} and tie point {tie:?} do not place a grid"
        )));
    }
    let keys = d
        .get_tag_u16_vec(Tag::GeoKeyDirectoryTag)
        .unwrap_or_default();
    if geo_key(&keys, MODEL_TYPE).is_some_and(|m| m != GEOGRAPHIC) {
        return Err(bad(
            "the grid is in a projected model; a geoid grid here is in latitude and longitude (degrees)".into(),
        ));
    }
    let point = geo_key(&keys, RASTER_TYPE) == Some(PIXEL_IS_POINT);
    let nodata = d
        .get_tag_ascii_string(Tag::GdalNodata)
        .ok()
        .and_then(|s| s.trim_matches(char::from(0)).trim().parse::<f64>().ok());
    let (offset, factor) = d
        .get_tag_ascii_string(Tag::Unknown(GDAL_METADATA))
        .map(|x| offset_scale(&x))
        .unwrap_or((0.0, 1.0));
    let values = samples(d.read_image().map_err(|e| bad(format!("its image: {e}")))?)
        .ok_or_else(|| bad("samples of a type a geoid grid does not have".into()))?;
    if values.len() != rows * cols {
        return Err(bad(format!(
            "{} samples for {cols} × {rows} pixels: one band (the undulation) is expected",
            values.len()
        )));
    }
    // The centre of pixel (0, 0) for pixel-is-area, the pixel itself for pixel-is-point.
    let half = if point { 0.0 } else { 0.5 };
    let west = tie[3] + (half - tie[0]) * scale[0];
    let north = tie[4] - (half - tie[1]) * scale[1];
    // Image row 0 is the north.
    let south = north - (rows.max(1) - 1) as f64 * scale[1];
    Ok(GeoidGrid::from_north_rows(
        path,
        (south, west),
        (scale[1], scale[0]),
        (rows, cols),
        |r, c| {
            let x = values[r * cols + c];
            let missing = !x.is_finite() || nodata.is_some_and(|nd| x == nd);
            if missing {
                f32::NAN
            } else {
                (offset + factor * x) as f32
            }
        },
    ))
}

/// The value of GeoTIFF key `id` when stored in the directory itself (location 0).
fn geo_key(keys: &[u16], id: u16) -> Option<u16> {
    keys.get(4..)?
        .chunks_exact(4)
        .find(|k| k[0] == id && k[1] == 0)
        .map(|k| k[3])
}

/// Every sample as f64, from the integer and float types the decoder gives.
fn samples(r: DecodingResult) -> Option<Vec<f64>> {
    fn all<T: Copy + Into<f64>>(v: Vec<T>) -> Vec<f64> {
        v.into_iter().map(Into::into).collect()
    }
    Some(match r {
        DecodingResult::F32(v) => all(v),
        DecodingResult::F64(v) => v,
        DecodingResult::I16(v) => all(v),
        DecodingResult::U16(v) => all(v),
        DecodingResult::I32(v) => all(v),
        DecodingResult::U32(v) => all(v),
        DecodingResult::I8(v) => all(v),
        DecodingResult::U8(v) => all(v),
        _ => return None,
    })
}

/// GDAL's band offset and scale from its metadata XML (`<Item … role="offset">x</Item>`);
/// (0, 1) where absent.
fn offset_scale(xml: &str) -> (f64, f64) {
    let item = |role: &str| {
        let at = xml.find(&format!("role=\"{role}\""))?;
        let rest = &xml[at..];
        let open = rest.find('>')? + 1;
        let close = rest[open..].find('<')? + open;
        rest[open..close].trim().parse::<f64>().ok()
    };
    (item("offset").unwrap_or(0.0), item("scale").unwrap_or(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gdal_metadata_offset_and_scale() {
        let xml = r#"<GDALMetadata><Item name="OFFSET" sample="0" role="offset">-10.5</Item><Item name="SCALE" sample="0" role="scale">0.003</Item></GDALMetadata>"#;
        assert_eq!(offset_scale(xml), (-10.5, 0.003));
        assert_eq!(offset_scale("<GDALMetadata></GDALMetadata>"), (0.0, 1.0));
        assert_eq!(
            geo_key(&[1, 1, 0, 2, 1024, 0, 1, 2, 1025, 0, 1, 2], 1025),
            Some(2)
        );
        assert_eq!(geo_key(&[1, 1, 0, 1, 1024, 0, 1, 2], 1025), None);
    }
}
