//! RINEX navigation files (2.x GPS/GLONASS, 3.x and 4.x mixed) read into plain records: the
//! satellite, its time of clock, the three clock terms and the broadcast-orbit values in file
//! order. The `orbit` module turns them into typed ephemerides.

use super::body::make_epoch;
use super::lines::{cols, label, parse_real, Lines};
use crate::error::{Error, Result};
use crate::sv::{Constellation, Sv};
use hifitime::{Epoch, TimeScale};
use std::path::{Path, PathBuf};

/// Message type of a record (RINEX 4 names it; older versions imply it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NavKind {
    /// GPS/QZSS legacy, Galileo (I/NAV or F/NAV, see data sources), BeiDou D1/D2, IRNSS: all
    /// Keplerian with the same field layout.
    Kepler,
    /// GLONASS FDMA state vector.
    Glonass,
    /// SBAS state vector (read, not used for positioning).
    Sbas,
    /// A RINEX 4 message ppkat does not use (CNAV, CNV1 …), kept so it can be counted.
    Other,
}

/// One ephemeris record as written in the file.
#[derive(Clone, Debug)]
pub struct NavRecord {
    /// The satellite.
    pub sv: Sv,
    /// What kind of message the record holds.
    pub kind: NavKind,
    /// Time of clock in GPST.
    pub toc: Epoch,
    /// Clock bias, drift, drift rate (GLONASS: −τn, +γn, message frame time).
    pub clock: [f64; 3],
    /// Broadcast orbit values in file order (blank fields are 0).
    pub orbit: Vec<f64>,
    /// Line where the record starts.
    pub line: usize,
}

/// Klobuchar-type ionosphere parameters broadcast in the header or ION records.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Klobuchar {
    /// Amplitude coefficients α0–α3.
    pub alpha: [f64; 4],
    /// Period coefficients β0–β3.
    pub beta: [f64; 4],
}

/// A navigation file.
#[derive(Clone, Debug, Default)]
pub struct NavFile {
    /// The file read.
    pub path: PathBuf,
    /// RINEX version.
    pub version: f64,
    /// Ephemeris records in file order.
    pub records: Vec<NavRecord>,
    /// GPS Klobuchar parameters, when given.
    pub gps_iono: Option<Klobuchar>,
    /// BeiDou Klobuchar parameters, when given.
    pub bds_iono: Option<Klobuchar>,
    /// Leap seconds, when given.
    pub leap_seconds: Option<i32>,
    /// Records skipped with the reason (line, what).
    pub skipped: Vec<(usize, String)>,
}

fn toc_scale(sys: Constellation) -> TimeScale {
    match sys {
        Constellation::Glonass => TimeScale::UTC,
        Constellation::BeiDou => TimeScale::BDT,
        _ => TimeScale::GPST,
    }
}

fn reals4(line: &[u8], start: usize, out: &mut Vec<f64>) -> std::result::Result<(), ()> {
    for k in 0..4 {
        let a = start + 19 * k;
        out.push(parse_real(cols(line, a, a + 19))?.unwrap_or(0.0));
    }
    Ok(())
}

fn klob4(line: &[u8], start: usize, w: usize) -> Option<[f64; 4]> {
    let mut v = [0.0; 4];
    for (k, x) in v.iter_mut().enumerate() {
        let a = start + w * k;
        *x = parse_real(cols(line, a, a + w)).ok()??;
    }
    Some(v)
}

impl NavFile {
    /// Read a navigation file (RINEX 2.x, 3.x, 4.x; plain or gzip).
    pub fn read(path: &Path) -> Result<NavFile> {
        let mut src = Lines::open(path)?;
        let mut nav = NavFile {
            path: path.to_path_buf(),
            ..NavFile::default()
        };
        let first = src
            .next_line()?
            .ok_or_else(|| Error::input(path, "the file is empty"))?
            .to_vec();
        if label(&first) != b"RINEX VERSION / TYPE" {
            return Err(Error::input(
                path,
                "the first line is not 'RINEX VERSION / TYPE': this is not a RINEX file",
            ));
        }
        let v = parse_real(cols(&first, 0, 9))
            .ok()
            .flatten()
            .ok_or_else(|| Error::parse(path, 1, "unreadable RINEX version"))?;
        if !(2.0..5.0).contains(&v) {
            return Err(Error::input(
                path,
                format!("RINEX version {v} is not supported (2.x, 3.x and 4.x are)"),
            ));
        }
        nav.version = v;
        let kind = first.get(20).copied().unwrap_or(b' ');
        if kind == b'O' {
            return Err(Error::input(
                path,
                "this is an observation file, not navigation: give it as observations",
            ));
        }
        // RINEX 2: the file type names the system.
        let v2_sys = match kind {
            b'G' => Constellation::Glonass,
            b'H' => Constellation::Sbas,
            b'E' => Constellation::Galileo,
            _ => Constellation::Gps,
        };
        if !matches!(
            kind,
            b'N' | b'G' | b'H' | b'E' | b'C' | b'J' | b'I' | b'L' | b'M' | b'B'
        ) {
            return Err(Error::input(
                path,
                "not a navigation file (type in column 21 is not N, G, H …)",
            ));
        }
        // Header.
        let mut alpha_a = None;
        let mut beta_a = None;
        let mut bds_a = None;
        let mut bds_b = None;
        loop {
            let Some(line) = src.next_line()? else {
                return Err(Error::input(path, "the header has no END OF HEADER line"));
            };
            match label(line) {
                b"END OF HEADER" => break,
                b"ION ALPHA" => alpha_a = klob4(line, 2, 12),
                b"ION BETA" => beta_a = klob4(line, 2, 12),
                b"IONOSPHERIC CORR" => {
                    let v = klob4(line, 5, 12);
                    match cols(line, 0, 4) {
                        b"GPSA" => alpha_a = v,
                        b"GPSB" => beta_a = v,
                        b"BDSA" => bds_a = v,
                        b"BDSB" => bds_b = v,
                        _ => {}
                    }
                }
                b"LEAP SECONDS" => {
                    nav.leap_seconds = super::lines::parse_int(cols(line, 0, 6))
                        .ok()
                        .flatten()
                        .map(|x| x as i32)
                }
                _ => {}
            }
        }
        // Body.
        let mut held: Option<(Vec<u8>, usize)> = None;
        loop {
            let (line, ln) = match held.take() {
                Some(x) => x,
                None => match src.next_line()? {
                    Some(l) => (l.to_vec(), src.line_no),
                    None => break,
                },
            };
            if line.iter().all(|c| c.is_ascii_whitespace()) {
                continue;
            }
            if v < 3.0 {
                let prn = super::lines::parse_int(cols(&line, 0, 2)).ok().flatten();
                let rec = (|| {
                    let prn = prn.filter(|p| (1..=255).contains(p))?;
                    let sv = Sv::new(v2_sys, prn as u8);
                    let yy = super::lines::parse_int(cols(&line, 2, 5)).ok()??;
                    let y = super::body::full_year(yy);
                    let g = |a, b| super::lines::parse_int(cols(&line, a, b)).ok().flatten();
                    let toc = make_epoch(
                        y,
                        g(5, 8)?,
                        g(8, 11)?,
                        g(11, 14)?,
                        g(14, 17)?,
                        cols(&line, 17, 22),
                        toc_scale(sv.sys),
                    )?;
                    let mut clock = Vec::with_capacity(3);
                    for k in 0..3 {
                        let a = 22 + 19 * k;
                        clock.push(parse_real(cols(&line, a, a + 19)).ok()?.unwrap_or(0.0));
                    }
                    Some((sv, toc, [clock[0], clock[1], clock[2]]))
                })();
                let nlines = match v2_sys {
                    Constellation::Glonass | Constellation::Sbas => 3,
                    _ => 7,
                };
                let mut orbit = Vec::with_capacity(4 * nlines);
                let mut ok = true;
                for _ in 0..nlines {
                    match src.next_line()? {
                        Some(l) => ok &= reals4(l, 3, &mut orbit).is_ok(),
                        None => ok = false,
                    }
                }
                match rec {
                    Some((sv, toc, clock)) if ok => nav.records.push(NavRecord {
                        sv,
                        kind: match sv.sys {
                            Constellation::Glonass => NavKind::Glonass,
                            Constellation::Sbas => NavKind::Sbas,
                            _ => NavKind::Kepler,
                        },
                        toc,
                        clock,
                        orbit,
                        line: ln,
                    }),
                    _ => nav.skipped.push((ln, "unreadable ephemeris record".into())),
                }
                continue;
            }
            // RINEX 3/4.
            let mut kind4 = None;
            let mut line = line;
            let mut ln = ln;
            if line.first() == Some(&b'>') {
                let rtype = cols(&line, 2, 5).to_vec();
                let msg = super::lines::col_str(&line, 10, 15);
                if rtype == b"ION" {
                    // Klobuchar parameters of GPS/QZSS LNAV or BeiDou D1/D2.
                    let sys = line.get(6).copied();
                    let l1 = src.next_line()?.map(|l| l.to_vec()).unwrap_or_default();
                    let l2 = src.next_line()?.map(|l| l.to_vec()).unwrap_or_default();
                    let l3 = src.next_line()?.map(|l| l.to_vec()).unwrap_or_default();
                    if msg == "LNAV" || msg == "D1D2" || msg == "D1" || msg == "D2" {
                        let mut vals = Vec::new();
                        let _ = (|| -> std::result::Result<(), ()> {
                            for k in 0..3 {
                                let a = 23 + 19 * k;
                                vals.push(parse_real(cols(&l1, a, a + 19))?.unwrap_or(0.0));
                            }
                            reals4(&l2, 4, &mut vals)?;
                            reals4(&l3, 4, &mut vals)?;
                            Ok(())
                        })();
                        if vals.len() >= 8 {
                            let k = Klobuchar {
                                alpha: [vals[0], vals[1], vals[2], vals[3]],
                                beta: [vals[4], vals[5], vals[6], vals[7]],
                            };
                            match sys {
                                Some(b'G') => {
                                    alpha_a = Some(k.alpha);
                                    beta_a = Some(k.beta);
                                }
                                Some(b'C') => {
                                    bds_a = Some(k.alpha);
                                    bds_b = Some(k.beta);
                                }
                                _ => {}
                            }
                        }
                    }
                    continue;
                }
                // Skip non-ephemeris records (STO, EOP) up to the next '>' line.
                if rtype != b"EPH" {
                    loop {
                        match src.next_line()? {
                            Some(l) if l.first() == Some(&b'>') => {
                                held = Some((l.to_vec(), src.line_no));
                                break;
                            }
                            Some(_) => continue,
                            None => break,
                        }
                    }
                    continue;
                }
                kind4 = Some(msg);
                match src.next_line()? {
                    Some(l) => {
                        line = l.to_vec();
                        ln = src.line_no;
                    }
                    None => break,
                }
            }
            let Some(sv) = Sv::parse(cols(&line, 0, 3)) else {
                nav.skipped
                    .push((ln, "unreadable satellite identifier".into()));
                continue;
            };
            let g = |a, b| super::lines::parse_int(cols(&line, a, b)).ok().flatten();
            let toc = (|| {
                make_epoch(
                    g(4, 8)?,
                    g(9, 11)?,
                    g(12, 14)?,
                    g(15, 17)?,
                    g(18, 20)?,
                    cols(&line, 21, 23),
                    toc_scale(sv.sys),
                )
            })();
            let mut clock = [0.0; 3];
            let mut ok = toc.is_some();
            for (k, c) in clock.iter_mut().enumerate() {
                let a = 23 + 19 * k;
                match parse_real(cols(&line, a, a + 19)) {
                    Ok(v) => *c = v.unwrap_or(0.0),
                    Err(()) => ok = false,
                }
            }
            let mut orbit = Vec::with_capacity(32);
            loop {
                match src.next_line()? {
                    Some(l) if l.starts_with(b"    ") => {
                        ok &= reals4(l, 4, &mut orbit).is_ok();
                    }
                    Some(l) => {
                        held = Some((l.to_vec(), src.line_no));
                        break;
                    }
                    None => break,
                }
            }
            let kind = match (sv.sys, kind4.as_deref()) {
                (_, Some("CNAV" | "CNV1" | "CNV2" | "CNV3" | "L1OC" | "L3OC")) => NavKind::Other,
                (Constellation::Glonass, _) => NavKind::Glonass,
                (Constellation::Sbas, _) => NavKind::Sbas,
                _ => NavKind::Kepler,
            };
            match toc {
                Some(toc) if ok => nav.records.push(NavRecord {
                    sv,
                    kind,
                    toc,
                    clock,
                    orbit,
                    line: ln,
                }),
                _ => nav
                    .skipped
                    .push((ln, format!("unreadable ephemeris record of {sv}"))),
            }
        }
        if let (Some(a), Some(b)) = (alpha_a, beta_a) {
            nav.gps_iono = Some(Klobuchar { alpha: a, beta: b });
        }
        if let (Some(a), Some(b)) = (bds_a, bds_b) {
            nav.bds_iono = Some(Klobuchar { alpha: a, beta: b });
        }
        if nav.records.is_empty() {
            return Err(Error::input(path, "the navigation file holds no ephemeris"));
        }
        Ok(nav)
    }
}
