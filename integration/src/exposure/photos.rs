//! Photographs beside the exposures: the photo list is matched to the events (counts and, where
//! the images carry `DateTimeOriginal`, the rhythm of their intervals), and geotagged copies are
//! written with the projection centres — originals are never modified.
//!
//! Enters: a folder of JPEG files and the camera stations. Leaves: the matched photo list (or
//! why it does not match) and geotagged copies in another folder (WGS84 latitude, longitude,
//! ellipsoidal height of the projection centre). Uses `little_exif`.

use super::CameraStation;
use gnss::error::{Error, Result};
use little_exif::exif_tag::ExifTag;
use little_exif::metadata::Metadata;
use little_exif::rational::uR64;
use std::path::{Path, PathBuf};

/// A photograph and the camera-clock time it was taken (seconds, camera time scale).
#[derive(Clone, Debug)]
pub struct Photo {
    /// The file.
    pub path: PathBuf,
    /// Its file name (becomes the station's label once matched).
    pub name: String,
    /// EXIF `DateTimeOriginal` as seconds of the camera's clock (read as UTC), when present.
    pub taken: Option<f64>,
}

fn exif_seconds(s: &str) -> Option<f64> {
    // "YYYY:MM:DD HH:MM:SS"
    let s = s.trim_matches(char::from(0)).trim();
    let (d, t) = s.split_once(' ')?;
    let d: Vec<i64> = d
        .split(':')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let t: Vec<i64> = t
        .split(':')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    if d.len() != 3 || t.len() != 3 {
        return None;
    }
    let e = hifitime::Epoch::maybe_from_gregorian(
        d[0] as i32,
        d[1] as u8,
        d[2] as u8,
        t[0] as u8,
        t[1] as u8,
        t[2] as u8,
        0,
        hifitime::TimeScale::UTC,
    )
    .ok()?;
    Some(e.to_utc_seconds())
}

/// JPEG photographs of a folder, sorted by name, with their EXIF capture times.
pub fn list(dir: &Path) -> Result<Vec<Photo>> {
    let rd = std::fs::read_dir(dir).map_err(Error::io(dir))?;
    let mut out: Vec<Photo> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|x| x.to_str())
                .is_some_and(|x| x.eq_ignore_ascii_case("jpg") || x.eq_ignore_ascii_case("jpeg"))
        })
        .map(|path| {
            let taken = Metadata::new_from_path(&path).ok().and_then(|m| {
                m.get_tag(&ExifTag::DateTimeOriginal(String::new()))
                    .find_map(|t| match t {
                        ExifTag::DateTimeOriginal(s) => exif_seconds(s),
                        _ => None,
                    })
            });
            let name = path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            Photo { path, name, taken }
        })
        .collect();
    out.sort_by(|a, b| a.name.cmp(&b.name));
    if out.is_empty() {
        return Err(Error::input(dir, "no JPEG photograph in this folder"));
    }
    Ok(out)
}

/// Check that the photos match the stations one to one. `Err` says how many of each and where
/// the mismatch starts: the first photo whose interval to its predecessor disagrees with the
/// exposures' by more than 1.1 s, when the photos carry capture times (EXIF seconds: a
/// missing photo shows when exposures are at least about two seconds apart).
pub fn check(photos: &[Photo], stations: &[CameraStation]) -> std::result::Result<(), String> {
    let n = photos.len().min(stations.len());
    for k in 1..n {
        if let (Some(a), Some(b)) = (photos[k - 1].taken, photos[k].taken) {
            let dp = b - a;
            let de = (stations[k].time - stations[k - 1].time).to_seconds();
            if (dp - de).abs() > 1.1 {
                return Err(format!(
                    "{} photos, {} exposures; the mismatch starts at photo {} (#{}): {:.1} s after its predecessor, the exposures {:.1} s",
                    photos.len(),
                    stations.len(),
                    photos[k].name,
                    k + 1,
                    dp,
                    de
                ));
            }
        }
    }
    if photos.len() != stations.len() {
        return Err(format!(
            "{} photos, {} exposures; the intervals agree up to #{n}, so the extra {} are at the end",
            photos.len(),
            stations.len(),
            if photos.len() > stations.len() { "photos" } else { "exposures" }
        ));
    }
    Ok(())
}

fn dms(v: f64) -> Vec<uR64> {
    let a = v.abs();
    let d = a.floor();
    let m = ((a - d) * 60.0).floor();
    let s = ((a - d) * 60.0 - m) * 60.0;
    vec![
        uR64 {
            nominator: d as u32,
            denominator: 1,
        },
        uR64 {
            nominator: m as u32,
            denominator: 1,
        },
        uR64 {
            nominator: (s * 10_000.0).round() as u32,
            denominator: 10_000,
        },
    ]
}

/// Write geotagged copies of the photos into `out_dir` (created), the originals untouched.
/// Photo k gets station k's projection centre. Returns the paths written.
pub fn geotag(
    photos: &[Photo],
    stations: &[CameraStation],
    out_dir: &Path,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out_dir).map_err(Error::io(out_dir))?;
    let mut written = Vec::new();
    for (p, s) in photos.iter().zip(stations) {
        let dest = out_dir.join(&p.name);
        if dest == p.path {
            return Err(Error::input(
                &dest,
                "refusing to overwrite an original photograph: choose another output folder",
            ));
        }
        let io = Error::io(&dest);
        std::fs::copy(&p.path, &dest).map_err(io)?;
        let g = s.centre.to_geodetic();
        let mut m = Metadata::new_from_path(&dest).unwrap_or_else(|_| Metadata::new());
        m.set_tag(ExifTag::GPSVersionID(vec![2, 3, 0, 0]));
        m.set_tag(ExifTag::GPSLatitudeRef(
            if g.lat >= 0.0 { "N" } else { "S" }.to_string(),
        ));
        m.set_tag(ExifTag::GPSLatitude(dms(g.lat.to_degrees())));
        m.set_tag(ExifTag::GPSLongitudeRef(
            if g.lon >= 0.0 { "E" } else { "W" }.to_string(),
        ));
        m.set_tag(ExifTag::GPSLongitude(dms(g.lon.to_degrees())));
        m.set_tag(ExifTag::GPSAltitudeRef(vec![if g.h >= 0.0 {
            0
        } else {
            1
        }]));
        m.set_tag(ExifTag::GPSAltitude(vec![uR64 {
            nominator: (g.h.abs() * 1000.0).round() as u32,
            denominator: 1000,
        }]));
        m.set_tag(ExifTag::GPSMapDatum("WGS-84".to_string()));
        m.write_to_file(&dest).map_err(io)?;
        written.push(dest);
    }
    Ok(written)
}

/// Latitude, longitude (degrees) and height read back from a geotagged photo.
pub fn read_position(path: &Path) -> Option<(f64, f64, f64)> {
    let m = Metadata::new_from_path(path).ok()?;
    let get = |tag: ExifTag| m.get_tag(&tag).next().cloned();
    let val = |v: &[uR64]| {
        v.iter()
            .zip([1.0, 60.0, 3600.0])
            .map(|(r, d)| r.nominator as f64 / r.denominator as f64 / d)
            .sum::<f64>()
    };
    let lat = match get(ExifTag::GPSLatitude(vec![]))? {
        ExifTag::GPSLatitude(v) => val(&v),
        _ => return None,
    };
    let lon = match get(ExifTag::GPSLongitude(vec![]))? {
        ExifTag::GPSLongitude(v) => val(&v),
        _ => return None,
    };
    let h = match get(ExifTag::GPSAltitude(vec![]))? {
        ExifTag::GPSAltitude(v) => v
            .first()
            .map(|r| r.nominator as f64 / r.denominator as f64)?,
        _ => return None,
    };
    let s = |t: ExifTag| match get(t) {
        Some(ExifTag::GPSLatitudeRef(r)) | Some(ExifTag::GPSLongitudeRef(r)) => {
            r.starts_with('S') || r.starts_with('W')
        }
        _ => false,
    };
    let lat = if s(ExifTag::GPSLatitudeRef(String::new())) {
        -lat
    } else {
        lat
    };
    let lon = if s(ExifTag::GPSLongitudeRef(String::new())) {
        -lon
    } else {
        lon
    };
    Some((lat, lon, h))
}
