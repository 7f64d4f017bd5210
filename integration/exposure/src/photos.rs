//! Photographs beside the exposures: the photo list is checked against the exposure times
//! (counts and, where the images carry `DateTimeOriginal`, the rhythm of their intervals; the
//! pairing itself is [`super::names::match_photos`]), and geotagged copies are written with
//! the projection centres — originals are never modified.
//!
//! Enters: a folder of JPEG files and the camera stations. Leaves: the matched photo list (or
//! why it does not match) and geotagged copies in another folder (WGS84 latitude, longitude,
//! ellipsoidal height of the projection centre). Uses [`super::exif_io`].

use super::exif_io;
use super::station::CameraStation;
use super::xmp::PositionTag;
use georef::height::Heights;
use gnss::error::{Error, Result};
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
    /// Why the photo's EXIF could not be read (damaged, looping, lying about its sizes), when
    /// it could not: the photo still takes its place in the list, without a capture time.
    pub exif_error: Option<String>,
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
    // A year of millions is no capture time, and hifitime's calendar walks it year by year.
    if d.len() != 3 || t.len() != 3 || !(1900..=2200).contains(&d[0]) {
        return None;
    }
    let u = |v: i64| u8::try_from(v).ok();
    let e = hifitime::Epoch::maybe_from_gregorian(
        i32::try_from(d[0]).ok()?,
        u(d[1])?,
        u(d[2])?,
        u(t[0])?,
        u(t[1])?,
        u(t[2])?,
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
            let (taken, exif_error) = match exif_io::read(&path) {
                Ok(x) => (
                    x.and_then(|x| exif_io::ascii(&x, exif::Tag::DateTimeOriginal))
                        .and_then(|s| exif_seconds(&s)),
                    None,
                ),
                Err(why) => (None, Some(why)),
            };
            let name = path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            Photo {
                path,
                name,
                taken,
                exif_error,
            }
        })
        .collect();
    out.sort_by(|a, b| a.name.cmp(&b.name));
    if out.is_empty() {
        return Err(Error::input(dir, "no JPEG photograph in this folder"));
    }
    Ok(out)
}

/// Check that the photos match the stations one to one (see [`check_times`]).
pub fn check(photos: &[Photo], stations: &[CameraStation]) -> std::result::Result<(), String> {
    let times: Vec<hifitime::Epoch> = stations.iter().map(|s| s.time).collect();
    check_times(photos, &times)
}

/// Check that the photos match the exposure times (in time order) one to one. `Err` says how
/// many of each and where the mismatch starts: the first photo whose interval to its
/// predecessor disagrees with the exposures' by more than 1.1 s, when the photos carry capture
/// times (EXIF seconds: a missing photo shows when exposures are at least about two seconds
/// apart).
pub fn check_times(photos: &[Photo], times: &[hifitime::Epoch]) -> std::result::Result<(), String> {
    let n = photos.len().min(times.len());
    for k in 1..n {
        if let (Some(a), Some(b)) = (photos[k - 1].taken, photos[k].taken) {
            let dp = b - a;
            let de = (times[k] - times[k - 1]).to_seconds();
            if (dp - de).abs() > 1.1 {
                return Err(format!(
                    "{} photos, {} exposures; the mismatch starts at photo {} (#{}): {:.1} s after its predecessor, the exposures {:.1} s",
                    photos.len(),
                    times.len(),
                    photos[k].name,
                    k + 1,
                    dp,
                    de
                ));
            }
        }
    }
    if photos.len() != times.len() {
        return Err(format!(
            "{} photos, {} exposures; the intervals agree up to #{n}, so the extra {} are at the end",
            photos.len(),
            times.len(),
            if photos.len() > times.len() { "photos" } else { "exposures" }
        ));
    }
    Ok(())
}

/// What geotagging did: the copies written, and the photos left out with the reason.
#[derive(Clone, Debug, Default)]
pub struct Geotagged {
    /// The copies written.
    pub written: Vec<PathBuf>,
    /// Originals that got no copy, and why (nothing of them is left in the output folder).
    pub skipped: Vec<(PathBuf, String)>,
}

/// Write geotagged copies of the photos into the folder `out_dir`, the originals untouched.
/// Photo k gets station k's projection centre. The folder is written whole
/// ([`common::atomic::StagedDir`]): it holds the previous run's copies or this run's, never a
/// mix, and an existing folder holding other files than these photos' names is refused. A
/// photo that cannot be tagged (not a JPEG, damaged, EXIF unreadable) is named in
/// [`Geotagged::skipped`] and the others are still written. `Err` only when nothing can be
/// written (the folder) or the output would replace an original.
pub fn geotag(
    photos: &[Photo],
    stations: &[CameraStation],
    out_dir: &Path,
    heights: &Heights,
) -> Result<Geotagged> {
    let (done, staged) = geotag_staged(photos, stations, out_dir, heights)?;
    staged.commit()?;
    Ok(done)
}

/// [`geotag`] without the last step: the tagged copies wait in the returned staging folder,
/// which [`common::atomic::StagedDir::commit`] swaps in (dropped, it is removed and `out_dir`
/// stays as it was). So a caller writing another output beside them commits both at the end,
/// one right after the other.
pub fn geotag_staged(
    photos: &[Photo],
    stations: &[CameraStation],
    out_dir: &Path,
    heights: &Heights,
) -> Result<(Geotagged, common::atomic::StagedDir)> {
    for p in photos {
        let dest = out_dir.join(&p.name);
        let folder = p.path.parent().filter(|d| !d.as_os_str().is_empty());
        if dest == p.path
            || same_file(&dest, &p.path)
            || folder.is_some_and(|d| same_file(d, out_dir))
        {
            return Err(Error::input(
                &dest,
                "refusing to overwrite an original photograph: choose another output folder",
            ));
        }
    }
    let owned: Vec<&str> = photos.iter().map(|p| p.name.as_str()).collect();
    let staged = common::atomic::StagedDir::new(out_dir, &owned)?;
    let mut done = Geotagged::default();
    for (p, s) in photos.iter().zip(stations) {
        let g = s.centre.to_geodetic();
        let r = gnss::frame::enu_rotation(&g);
        let c = r * s.cov * r.transpose();
        let tag = PositionTag {
            lat: g.lat.to_degrees(),
            lon: g.lon.to_degrees(),
            height: heights.height(&g)?,
            reference: heights.describe(),
            orthometric: heights.orthometric(),
            sigma_enu: [0, 1, 2].map(|k| c[(k, k)].max(0.0).sqrt()),
            quality: s.quality as u8,
        };
        let tagged = read_limited(&p.path).and_then(|jpeg| exif_io::geotagged(&jpeg, &tag));
        match tagged {
            Ok(bytes) => {
                let staged_copy = staged.path().join(&p.name);
                common::atomic::write_atomic(&staged_copy, |w| w.write_all(&bytes))?;
                done.written.push(out_dir.join(&p.name));
            }
            Err(why) => done.skipped.push((p.path.clone(), why)),
        }
    }
    Ok((done, staged))
}

/// Whether two paths name one existing file (a folder reached by another name).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// The bytes of a photo, refusing files beyond [`exif_io::MAX_PHOTO_BYTES`].
fn read_limited(path: &Path) -> std::result::Result<Vec<u8>, String> {
    let len = std::fs::metadata(path)
        .map_err(|e| format!("cannot read: {e}"))?
        .len();
    if len > exif_io::MAX_PHOTO_BYTES {
        return Err(format!("{len} bytes: too large for a photograph"));
    }
    std::fs::read(path).map_err(|e| format!("cannot read: {e}"))
}

/// Latitude, longitude (degrees) and height read back from a geotagged photo (`None` when it
/// has no GPS position or its EXIF cannot be read). The height is the EXIF GPSAltitude, or
/// for ppkat's copies with ellipsoidal heights (which leave it out) the XMP `ppkat:Height`.
pub fn read_position(path: &Path) -> Option<(f64, f64, f64)> {
    let (lat, lon, h) = exif_io::gps_position(&exif_io::read(path).ok()??)?;
    let h = match h {
        Some(h) => h,
        None => {
            let jpeg = read_limited(path).ok()?;
            let packet = exif_io::xmp_packet(&jpeg)?;
            super::xmp::value(&packet, "ppkat:Height")?.parse().ok()?
        }
    };
    Some((lat, lon, h))
}
