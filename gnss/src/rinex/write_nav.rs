//! RINEX 3.04 mixed navigation writer for Keplerian ephemerides (GPS, QZSS, Galileo,
//! BeiDou) and GLONASS state vectors.
//!
//! What enters: [`NavRecord`]s laid out as RINEX 3 records (as [`super::nav`] reads them and
//! the raw-log decoders of [`crate::raw`] make them) and the header's ionosphere parameters.
//! What leaves: text on a `Write`, D19.12 fields written as `±d.dddddddddddd E±ee`, so that
//! [`super::nav::NavFile`] reads back the same values to 13 significant digits.

use super::nav::{Klobuchar, NavRecord};
use super::write::{epoch_fields, line, opening};
use crate::sv::Constellation;
use std::io::{Result, Write};

/// What the header of a navigation file says.
#[derive(Clone, Debug, Default)]
pub struct NavHeaderOut {
    /// Program that wrote the file (PGM / RUN BY / DATE).
    pub program: String,
    /// COMMENT lines.
    pub comments: Vec<String>,
    /// GPS Klobuchar parameters (IONOSPHERIC CORR GPSA/GPSB), when known.
    pub gps_iono: Option<Klobuchar>,
    /// BeiDou Klobuchar parameters (IONOSPHERIC CORR BDSA/BDSB), when known.
    pub bds_iono: Option<Klobuchar>,
    /// GPS − UTC leap seconds (LEAP SECONDS), when known.
    pub leap_seconds: Option<i32>,
}

/// `x` in scientific notation with one leading digit, `decimals` digits after the point and a
/// two-digit exponent, right-aligned in `width` characters (RINEX's Dw.d fields).
pub fn sci(x: f64, width: usize, decimals: usize) -> String {
    let s = format!("{:.*E}", decimals, x);
    let (m, e) = s.split_once('E').unwrap_or((&s, "0"));
    let e: i32 = e.parse().unwrap_or(0);
    let sign = if e < 0 { '-' } else { '+' };
    format!("{:>width$}", format!("{m}E{sign}{:02}", e.abs()))
}

/// Write the header.
pub fn write_nav_header(w: &mut dyn Write, h: &NavHeaderOut) -> Result<()> {
    opening(w, "N: GNSS NAV DATA", &h.program, &h.comments)?;
    for (k, a, b) in [(&h.gps_iono, "GPSA", "GPSB"), (&h.bds_iono, "BDSA", "BDSB")] {
        let Some(k) = k else { continue };
        for (name, v) in [(a, k.alpha), (b, k.beta)] {
            let vals: String = v.iter().map(|x| sci(*x, 12, 4)).collect();
            line(w, &format!("{name} {vals}"), "IONOSPHERIC CORR")?;
        }
    }
    if let Some(l) = h.leap_seconds {
        line(w, &format!("{l:6}"), "LEAP SECONDS")?;
    }
    line(w, "", "END OF HEADER")
}

/// Write one record: the satellite, time of clock and clock terms, then the orbit values
/// four to a line. The time of clock is written in the system's time (GPST for GPS, QZSS and
/// Galileo; BDT for BeiDou; UTC for GLONASS).
pub fn write_nav_record(w: &mut dyn Write, r: &NavRecord) -> Result<()> {
    let toc = match r.sv.sys {
        Constellation::BeiDou => r.toc - hifitime::Duration::from_seconds(14.0),
        // GPST − UTC = (TAI − UTC) − 19 s
        Constellation::Glonass => {
            let leap = r.toc.leap_seconds(true).unwrap_or(37.0) - 19.0;
            r.toc - hifitime::Duration::from_seconds(leap)
        }
        _ => r.toc,
    };
    let f = epoch_fields(toc);
    // epoch_fields gives seconds as F11.7; navigation records take whole seconds (I2.2).
    let (date, sec) = f.split_at(f.len() - 11);
    let sec: f64 = sec.trim().parse().unwrap_or(0.0);
    write!(w, "{} {date} {:02}", r.sv, sec.round() as u32)?;
    for c in r.clock {
        w.write_all(sci(c, 19, 12).as_bytes())?;
    }
    writeln!(w)?;
    for chunk in r.orbit.chunks(4) {
        w.write_all(b"    ")?;
        for v in chunk {
            w.write_all(sci(*v, 19, 12).as_bytes())?;
        }
        writeln!(w)?;
    }
    Ok(())
}

/// Write a whole file: the header, then the records in the order given.
pub fn write_nav(w: &mut dyn Write, h: &NavHeaderOut, records: &[NavRecord]) -> Result<()> {
    write_nav_header(w, h)?;
    for r in records {
        write_nav_record(w, r)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scientific_fields() {
        assert_eq!(sci(1.36842497159e-3, 19, 12), " 1.368424971590E-03");
        assert_eq!(sci(-101.375, 19, 12), "-1.013750000000E+02");
        assert_eq!(sci(0.0, 19, 12), " 0.000000000000E+00");
        assert_eq!(sci(2.794e-8, 12, 4), "  2.7940E-08");
    }
}
