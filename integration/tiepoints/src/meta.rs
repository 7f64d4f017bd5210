//! What a photograph says about itself: EXIF (GPS position, focal length, 35 mm equivalent,
//! focal-plane resolution, size, make and model, capture time) and DJI's XMP (absolute and
//! relative altitude, gimbal and flight angles, calibrated focal length and optical centre,
//! RTK flag and σ). Reads at most the first [`XMP_SCAN_BYTES`] of a file for the XMP packet.
//!
//! Enters: a photo's path. Leaves: [`PhotoMeta`], or why the photo cannot be used.

use exif::{In, Tag, Value};
use exposure::exif_io;
use std::io::Read;
use std::path::{Path, PathBuf};

/// How far into a file the XMP packet is looked for (it sits in the JPEG header segments).
pub const XMP_SCAN_BYTES: u64 = 1 << 20;

/// DJI XMP fields (`drone-dji:`), each when present.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DjiXmp {
    /// `AbsoluteAltitude`, m.
    pub absolute_altitude: Option<f64>,
    /// `RelativeAltitude` (above take-off), m.
    pub relative_altitude: Option<f64>,
    /// `GimbalRollDegree`, `GimbalPitchDegree`, `GimbalYawDegree`, degrees.
    pub gimbal: Option<[f64; 3]>,
    /// `FlightRollDegree`, `FlightPitchDegree`, `FlightYawDegree`, degrees.
    pub flight: Option<[f64; 3]>,
    /// `CalibratedFocalLength`, pixels.
    pub calibrated_focal_px: Option<f64>,
    /// `CalibratedOpticalCenterX`, `…Y`, pixels.
    pub optical_centre_px: Option<[f64; 2]>,
    /// `RtkFlag` (50 fixed, 34 float, 16 single).
    pub rtk_flag: Option<u32>,
    /// `RtkStdLon`, `RtkStdLat`, `RtkStdHgt`, m.
    pub rtk_std: Option<[f64; 3]>,
}

/// A photograph's metadata.
#[derive(Clone, Debug)]
pub struct PhotoMeta {
    /// The file.
    pub path: PathBuf,
    /// The image id: the file name without its extension.
    pub id: String,
    /// Make and model (`DJI FC300S`), or `unknown`.
    pub model: String,
    /// Width and height, pixels, when the EXIF states them.
    pub size: Option<(u32, u32)>,
    /// Focal length, mm.
    pub focal_mm: Option<f64>,
    /// 35 mm equivalent focal length, mm.
    pub focal_35mm: Option<f64>,
    /// Focal-plane resolution, pixels per mm (x).
    pub focal_plane_px_per_mm: Option<f64>,
    /// GPS latitude, longitude (degrees) and altitude (m, as the camera wrote it).
    pub gps: Option<(f64, f64, f64)>,
    /// Capture time, `YYYY:MM:DD HH:MM:SS` as written.
    pub taken: Option<String>,
    /// DJI XMP.
    pub dji: DjiXmp,
}

fn first_rational(x: &exif::Exif, tag: Tag) -> Option<f64> {
    exif_io::rationals(x, tag)?
        .first()
        .copied()
        .filter(|v| v.is_finite())
}

fn uint(x: &exif::Exif, tag: Tag) -> Option<u32> {
    let f = x.get_field(tag, In::PRIMARY)?;
    match &f.value {
        Value::Short(v) => v.first().map(|&s| s as u32),
        Value::Long(v) => v.first().copied(),
        _ => None,
    }
}

/// Pixels per mm from `FocalPlaneXResolution` and its unit (2 inch, 3 cm, 4 mm, 5 µm).
fn plane_resolution(x: &exif::Exif) -> Option<f64> {
    let r = first_rational(x, Tag::FocalPlaneXResolution)?;
    let per_mm = match uint(x, Tag::FocalPlaneResolutionUnit).unwrap_or(2) {
        3 => r / 10.0,
        4 => r,
        5 => r * 1000.0,
        _ => r / 25.4,
    };
    (per_mm > 0.0 && per_mm.is_finite()).then_some(per_mm)
}

/// The value of `drone-dji:NAME` in an XMP packet, as attribute or element.
fn xmp_value<'a>(xmp: &'a str, name: &str) -> Option<&'a str> {
    let key = format!("drone-dji:{name}");
    let mut from = 0;
    while let Some(i) = xmp[from..].find(&key) {
        let at = from + i + key.len();
        let rest = &xmp[at..];
        let t = rest.trim_start();
        if let Some(v) = t.strip_prefix('=') {
            let v = v.trim_start();
            let q = v.chars().next()?;
            if q == '"' || q == '\'' {
                return v[1..].split(q).next();
            }
        } else if let Some(v) = rest.strip_prefix('>') {
            return v.split('<').next();
        }
        from = at;
    }
    None
}

fn num(xmp: &str, name: &str) -> Option<f64> {
    xmp_value(xmp, name)?
        .trim()
        .trim_start_matches('+')
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite())
}

/// DJI fields of an XMP packet.
pub fn dji_xmp(xmp: &str) -> DjiXmp {
    let three = |a: &str, b: &str, c: &str| Some([num(xmp, a)?, num(xmp, b)?, num(xmp, c)?]);
    DjiXmp {
        absolute_altitude: num(xmp, "AbsoluteAltitude"),
        relative_altitude: num(xmp, "RelativeAltitude"),
        gimbal: three("GimbalRollDegree", "GimbalPitchDegree", "GimbalYawDegree"),
        flight: three("FlightRollDegree", "FlightPitchDegree", "FlightYawDegree"),
        calibrated_focal_px: num(xmp, "CalibratedFocalLength"),
        optical_centre_px: num(xmp, "CalibratedOpticalCenterX")
            .zip(num(xmp, "CalibratedOpticalCenterY"))
            .map(|(x, y)| [x, y]),
        rtk_flag: num(xmp, "RtkFlag").map(|v| v as u32),
        rtk_std: three("RtkStdLon", "RtkStdLat", "RtkStdHgt"),
    }
}

/// The XMP packet of a file (from its first [`XMP_SCAN_BYTES`]), when there is one.
fn xmp_packet(path: &Path) -> Option<String> {
    let mut buf = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .take(XMP_SCAN_BYTES)
        .read_to_end(&mut buf)
        .ok()?;
    let start = find(&buf, b"<x:xmpmeta")?;
    let end = start + find(&buf[start..], b"</x:xmpmeta>")?;
    Some(String::from_utf8_lossy(&buf[start..end]).into_owned())
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// The metadata of one photograph; `Err(reason)` when its EXIF is damaged.
pub fn read(path: &Path) -> Result<PhotoMeta, String> {
    let id = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let x = exif_io::read(path)?;
    let dji = xmp_packet(path).map(|p| dji_xmp(&p)).unwrap_or_default();
    let mut m = PhotoMeta {
        path: path.to_path_buf(),
        id,
        model: "unknown".into(),
        size: None,
        focal_mm: None,
        focal_35mm: None,
        focal_plane_px_per_mm: None,
        gps: None,
        taken: None,
        dji,
    };
    let Some(x) = x else {
        return Ok(m);
    };
    let make = exif_io::ascii(&x, Tag::Make).unwrap_or_default();
    let model = exif_io::ascii(&x, Tag::Model).unwrap_or_default();
    let mm = format!("{} {}", make.trim(), model.trim());
    if !mm.trim().is_empty() {
        m.model = mm.trim().to_string();
    }
    m.size = uint(&x, Tag::PixelXDimension).zip(uint(&x, Tag::PixelYDimension));
    m.focal_mm = first_rational(&x, Tag::FocalLength).filter(|f| *f > 0.0);
    m.focal_35mm = uint(&x, Tag::FocalLengthIn35mmFilm)
        .map(|v| v as f64)
        .filter(|f| *f > 0.0);
    m.focal_plane_px_per_mm = plane_resolution(&x);
    m.gps = exif_io::gps_position(&x)
        .and_then(|(lat, lon, h)| Some((lat, lon, h?)))
        .filter(|g| g.0.abs() <= 90.0 && g.1.abs() <= 180.0);
    m.taken = exif_io::ascii(&x, Tag::DateTimeOriginal);
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dji_fields_are_read_as_attributes_and_elements() {
        let xmp = r#"<x:xmpmeta><rdf:Description drone-dji:AbsoluteAltitude="+198.31"
   drone-dji:RelativeAltitude="+39.80" drone-dji:GimbalRollDegree="+0.00"
   drone-dji:GimbalYawDegree="+45.00" drone-dji:GimbalPitchDegree="-89.90"
   drone-dji:RtkFlag='50'><drone-dji:RtkStdLon>0.012</drone-dji:RtkStdLon>
   <drone-dji:RtkStdLat>0.011</drone-dji:RtkStdLat><drone-dji:RtkStdHgt>0.025</drone-dji:RtkStdHgt>
   </rdf:Description></x:xmpmeta>"#;
        let d = dji_xmp(xmp);
        assert_eq!(d.absolute_altitude, Some(198.31));
        assert_eq!(d.relative_altitude, Some(39.8));
        assert_eq!(d.gimbal, Some([0.0, -89.9, 45.0]));
        assert_eq!(d.flight, None);
        assert_eq!(d.rtk_flag, Some(50));
        assert_eq!(d.rtk_std, Some([0.012, 0.011, 0.025]));
    }
}
