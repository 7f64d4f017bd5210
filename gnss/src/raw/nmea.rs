//! The receiver's own solution from NMEA GGA sentences, for comparison with ppkat's.
//!
//! What enters: a GGA sentence's address and fields (between `$` and `*`, checksum already
//! checked by [`super::mixed`]) and the log's time. What leaves: a [`NmeaFix`] in GPST with
//! an ellipsoidal ECEF position and the RTKLIB quality of the receiver's fix kind, or why the
//! sentence gives none.
//!
//! GGA carries the UTC time of day only: the day is the one that puts the fix nearest the
//! log's time, and GPST = UTC + the leap seconds. Its height is the altitude above the geoid
//! plus the geoid separation it states, so the ellipsoidal height is their sum. Fix quality
//! 4 (RTK fixed) is RTKLIB's Q 1, 5 (RTK float) Q 2, any other fix Q 5 (single), 0 no fix.

use super::rtcm_msm::WEEK_MS;
use crate::frame::{Ecef, Geodetic};
use crate::solution::Quality;
use hifitime::Epoch;

const DAY_MS: i64 = 86_400_000;

/// A position the receiver computed itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NmeaFix {
    /// The time of the fix, GPST.
    pub time: Epoch,
    /// Ellipsoidal position, ECEF.
    pub pos: Ecef,
    /// The receiver's fix kind as RTKLIB numbers it.
    pub quality: Quality,
    /// Satellites used.
    pub nsat: usize,
}

/// Why a GGA sentence gives no fix.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GgaSkip {
    /// Fix quality 0, or empty position fields.
    NoFix,
    /// A field that is not a number or out of range.
    Malformed,
}

/// `ddmm.mmmm` / `dddmm.mmmm` and a hemisphere letter as degrees.
fn degrees(v: &str, hemi: &str, negative: &str) -> Option<f64> {
    let x: f64 = v.parse().ok()?;
    let d = (x / 100.0).trunc();
    let m = x - 100.0 * d;
    if !(0.0..60.0).contains(&m) {
        return None;
    }
    let deg = d + m / 60.0;
    Some(if hemi == negative { -deg } else { deg })
}

/// `hhmmss.ss` as seconds of the day.
fn seconds_of_day(v: &str) -> Option<f64> {
    if v.len() < 6 || !v.is_char_boundary(2) || !v.is_char_boundary(4) {
        return None;
    }
    let (h, m, s): (f64, f64, f64) = (
        v[..2].parse().ok()?,
        v[2..4].parse().ok()?,
        v[4..].parse().ok()?,
    );
    (h < 24.0 && m < 60.0 && (0.0..61.0).contains(&s)).then_some(h * 3600.0 + m * 60.0 + s)
}

/// Whether a sentence's address is a GGA (any talker: GP, GN, GL, GA …).
pub fn is_gga(sentence: &str) -> bool {
    sentence
        .split(',')
        .next()
        .is_some_and(|a| a.len() == 5 && a.ends_with("GGA"))
}

/// The fix of a GGA sentence (between `$` and `*`) at a log time `now_ms` (GPST ms since the
/// GPS epoch) with GPST − UTC = `leap` seconds.
pub fn gga_fix(sentence: &str, now_ms: i64, leap: i64) -> Result<NmeaFix, GgaSkip> {
    let f: Vec<&str> = sentence.split(',').collect();
    if f.len() < 12 {
        return Err(GgaSkip::Malformed);
    }
    let q: u8 = f[6].parse().map_err(|_| GgaSkip::Malformed)?;
    if q == 0 || f[2].is_empty() || f[4].is_empty() || f[9].is_empty() {
        return Err(GgaSkip::NoFix);
    }
    let tod = seconds_of_day(f[1]).ok_or(GgaSkip::Malformed)?;
    let lat = degrees(f[2], f[3], "S").filter(|l| l.abs() <= 90.0);
    let lon = degrees(f[4], f[5], "W").filter(|l| l.abs() <= 180.0);
    let alt: Option<f64> = f[9].parse().ok().filter(|a: &f64| a.abs() < 1e5);
    let sep: f64 = if f[11].is_empty() {
        0.0
    } else {
        f[11].parse().map_err(|_| GgaSkip::Malformed)?
    };
    let (Some(lat), Some(lon), Some(alt)) = (lat, lon, alt) else {
        return Err(GgaSkip::Malformed);
    };
    if sep.abs() > 200.0 {
        return Err(GgaSkip::Malformed);
    }
    let nsat = f[7].parse().unwrap_or(0);
    // The UTC day nearest the log's time.
    let now_utc = now_ms - leap * 1000;
    let day0 = now_utc - now_utc.rem_euclid(DAY_MS);
    let tod_ms = (tod * 1000.0).round() as i64;
    let utc = [day0 - DAY_MS, day0, day0 + DAY_MS]
        .map(|d| d + tod_ms)
        .into_iter()
        .min_by_key(|t| (t - now_utc).abs())
        .unwrap_or(day0 + tod_ms);
    let gpst_ms = utc + leap * 1000;
    let time = Epoch::from_gpst_seconds(gpst_ms.div_euclid(WEEK_MS) as f64 * 604_800.0)
        + hifitime::Duration::from_milliseconds(gpst_ms.rem_euclid(WEEK_MS) as f64);
    let quality = match q {
        4 => Quality::Fixed,
        5 => Quality::Float,
        _ => Quality::Single,
    };
    Ok(NmeaFix {
        time,
        pos: Geodetic::from_degrees(lat, lon, alt + sep).to_ecef(),
        quality,
        nsat,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The classic GGA example: position, ellipsoidal height = altitude + separation, the
    /// day nearest the log's time (across midnight too), GPST = UTC + leap seconds, RTK
    /// quality numbers.
    #[test]
    fn gga_gives_the_receivers_fix() {
        let s = "GNGGA,123519.50,4807.038,N,01131.000,W,4,08,0.9,545.4,M,46.9,M,1.0,0000";
        // 2024-03-10 12:00:00 GPST is week 2305, tow 0 + 12 h.
        let now = 2305 * WEEK_MS + 12 * 3_600_000;
        let fix = gga_fix(s, now, 18).unwrap();
        let g = fix.pos.to_geodetic();
        let (lat, lon) = (g.lat.to_degrees(), g.lon.to_degrees());
        assert!((lat - (48.0 + 7.038 / 60.0)).abs() < 1e-9, "{lat}");
        assert!((lon + (11.0 + 31.0 / 60.0)).abs() < 1e-9, "{lon}");
        assert!((g.h - 592.3).abs() < 1e-6, "{}", g.h);
        assert_eq!(fix.quality, Quality::Fixed);
        assert_eq!(fix.nsat, 8);
        let want =
            Epoch::from_gpst_seconds(2305.0 * 604_800.0 + 12.0 * 3600.0 + 35.0 * 60.0 + 37.5);
        assert!((fix.time - want).to_seconds().abs() < 1e-6, "{}", fix.time);
        // A fix just before midnight UTC read just after it belongs to the day before.
        let late = "GPGGA,235959.00,4807.038,N,01131.000,E,5,08,0.9,545.4,M,46.9,M,,";
        let f = gga_fix(late, 2305 * WEEK_MS + 18_000 + 2000, 18).unwrap();
        assert_eq!(f.quality, Quality::Float);
        assert!(
            (f.time - Epoch::from_gpst_seconds(2305.0 * 604_800.0 + 17.0))
                .to_seconds()
                .abs()
                < 1e-6
        );
        let single = "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,,M,,";
        assert_eq!(gga_fix(single, now, 18).unwrap().quality, Quality::Single);
        let none = "GPGGA,123519,,,,,0,00,,,M,,M,,";
        assert_eq!(gga_fix(none, now, 18), Err(GgaSkip::NoFix));
        let bad = "GPGGA,123519,48x7.038,N,01131.000,E,1,08,0.9,545.4,M,,M,,";
        assert_eq!(gga_fix(bad, now, 18), Err(GgaSkip::Malformed));
        assert!(is_gga("GNGGA,1") && !is_gga("GNRMC,1") && !is_gga("PUBX,00"));
    }
}
