//! RINEX navigation files (2.x GPS/GLONASS, 3.x and 4.x mixed) read into plain records: the
//! satellite, its time of clock, the three clock terms and the broadcast-orbit values in file
//! order. The `orbit` module turns them into typed ephemerides.

use super::body::DateCols;
use super::lines::{cols, label, parse_int, parse_real, Lines};
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
    /// Records skipped with the reason (line, what): the first [`MAX_LISTED_SKIPS`], then one
    /// entry with the count of the others.
    pub skipped: Vec<(usize, String)>,
    /// Skipped records beyond the first [`MAX_LISTED_SKIPS`] (counted, not listed).
    pub skipped_unlisted: usize,
}

/// Skipped records listed one by one; a file of garbage must not become a list of millions.
pub const MAX_LISTED_SKIPS: usize = 1000;

impl NavFile {
    /// Note a skipped record: listed while fewer than [`MAX_LISTED_SKIPS`] are, counted after.
    fn skip(&mut self, line: usize, what: String) {
        if self.skipped.len() < MAX_LISTED_SKIPS {
            self.skipped.push((line, what));
        } else {
            self.skipped_unlisted += 1;
        }
    }
}

fn toc_scale(sys: Constellation) -> TimeScale {
    match sys {
        Constellation::Glonass => TimeScale::UTC,
        Constellation::BeiDou => TimeScale::BDT,
        _ => TimeScale::GPST,
    }
}

/// Time of clock of a RINEX 2 record: `pp yy mm dd hh mm ss.s` (two-digit year).
const TOC_V2: DateCols = DateCols {
    ymdhm: [(2, 5), (5, 8), (8, 11), (11, 14), (14, 17)],
    sec: (17, 22),
    two_digit_years: true,
};

/// Time of clock of a RINEX 3/4 record: `Snn yyyy mm dd hh mm ss`.
const TOC_V3: DateCols = DateCols {
    ymdhm: [(4, 8), (9, 11), (12, 14), (15, 17), (18, 20)],
    sec: (21, 23),
    two_digit_years: false,
};

/// `n` D19.12 fields from column `start` appended to `out`; blank fields are 0. `Err` at the
/// first unreadable field (the fields before it stay appended).
fn reals(line: &[u8], start: usize, n: usize, out: &mut Vec<f64>) -> std::result::Result<(), ()> {
    for k in 0..n {
        let a = start + 19 * k;
        out.push(parse_real(cols(line, a, a + 19))?.unwrap_or(0.0));
    }
    Ok(())
}

fn reals4(line: &[u8], start: usize, out: &mut Vec<f64>) -> std::result::Result<(), ()> {
    reals(line, start, 4, out)
}

/// Clock bias, drift and drift rate: three D19.12 fields from column `start`.
fn clock_terms(line: &[u8], start: usize) -> Option<[f64; 3]> {
    let mut clock = Vec::with_capacity(3);
    reals(line, start, 3, &mut clock).ok()?;
    Some([clock[0], clock[1], clock[2]])
}

fn klob4(line: &[u8], start: usize, w: usize) -> Option<[f64; 4]> {
    let mut v = [0.0; 4];
    for (k, x) in v.iter_mut().enumerate() {
        let a = start + w * k;
        *x = parse_real(cols(line, a, a + w)).ok()??;
    }
    Some(v)
}

fn is_blank(line: &[u8]) -> bool {
    line.iter().all(|c| c.is_ascii_whitespace())
}

/// Klobuchar halves as they are found (header lines or RINEX 4 ION records); a set is
/// complete when both its α and β were given.
#[derive(Default)]
struct IonoHalves {
    gps_alpha: Option<[f64; 4]>,
    gps_beta: Option<[f64; 4]>,
    bds_alpha: Option<[f64; 4]>,
    bds_beta: Option<[f64; 4]>,
}

impl IonoHalves {
    fn gps(&self) -> Option<Klobuchar> {
        Some(Klobuchar {
            alpha: self.gps_alpha?,
            beta: self.gps_beta?,
        })
    }
    fn bds(&self) -> Option<Klobuchar> {
        Some(Klobuchar {
            alpha: self.bds_alpha?,
            beta: self.bds_beta?,
        })
    }
}

/// What a RINEX 4 record label (`> EPH G01 LNAV`, `> ION …`, `> STO …`) led to.
enum V4Label {
    /// An ephemeris follows: its message type, its first line and that line's number.
    Ephemeris(String, Vec<u8>, usize),
    /// A record that is not an ephemeris was read (kept or skipped); the label line that
    /// ended it, when one did, is the next line to read.
    Consumed(Option<(Vec<u8>, usize)>),
    /// The file ends inside the record.
    End,
}

impl NavFile {
    /// Read a navigation file (RINEX 2.x, 3.x, 4.x; plain or gzip).
    pub fn read(path: &Path) -> Result<NavFile> {
        let mut src = Lines::open(path)?;
        let (version, v2_sys) = read_version_line(&mut src, path)?;
        let mut nav = NavFile {
            path: path.to_path_buf(),
            version,
            ..NavFile::default()
        };
        let mut iono = IonoHalves::default();
        nav.leap_seconds = read_header(&mut src, path, &mut iono)?;
        if version < 3.0 {
            read_body_v2(&mut src, v2_sys, &mut nav)?;
        } else {
            read_body_v3(&mut src, &mut nav, &mut iono)?;
        }
        if nav.skipped_unlisted > 0 {
            let n = nav.skipped_unlisted;
            nav.skipped.push((
                src.line_no,
                format!("and {n} more unreadable records (not listed)"),
            ));
        }
        nav.gps_iono = iono.gps();
        nav.bds_iono = iono.bds();
        if nav.records.is_empty() {
            return Err(Error::input(path, "the navigation file holds no ephemeris"));
        }
        Ok(nav)
    }
}

/// The `RINEX VERSION / TYPE` line: the version, and the system a RINEX 2 file type names
/// (N GPS, G GLONASS, H SBAS, E Galileo). Refuses observation files and unknown types.
fn read_version_line(src: &mut Lines, path: &Path) -> Result<(f64, Constellation)> {
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
    let kind = first.get(20).copied().unwrap_or(b' ');
    if kind == b'O' {
        return Err(Error::input(
            path,
            "this is an observation file, not navigation: give it as observations",
        ));
    }
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
    Ok((v, v2_sys))
}

/// The header up to `END OF HEADER`: Klobuchar halves into `iono`; returns the leap seconds.
fn read_header(src: &mut Lines, path: &Path, iono: &mut IonoHalves) -> Result<Option<i32>> {
    let mut leap_seconds = None;
    loop {
        let Some(line) = src.next_line()? else {
            return Err(Error::input(path, "the header has no END OF HEADER line"));
        };
        match label(line) {
            b"END OF HEADER" => break,
            b"ION ALPHA" => iono.gps_alpha = klob4(line, 2, 12),
            b"ION BETA" => iono.gps_beta = klob4(line, 2, 12),
            b"IONOSPHERIC CORR" => {
                let v = klob4(line, 5, 12);
                match cols(line, 0, 4) {
                    b"GPSA" => iono.gps_alpha = v,
                    b"GPSB" => iono.gps_beta = v,
                    b"BDSA" => iono.bds_alpha = v,
                    b"BDSB" => iono.bds_beta = v,
                    _ => {}
                }
            }
            b"LEAP SECONDS" => {
                leap_seconds = parse_int(cols(line, 0, 6)).ok().flatten().map(|x| x as i32)
            }
            _ => {}
        }
    }
    Ok(leap_seconds)
}

/// RINEX 2 records: a line with the PRN, time of clock and clock terms, then 7 lines of four
/// orbit values (3 for GLONASS and SBAS). The file type gives the system.
fn read_body_v2(src: &mut Lines, sys: Constellation, nav: &mut NavFile) -> Result<()> {
    let nlines = match sys {
        Constellation::Glonass | Constellation::Sbas => 3,
        _ => 7,
    };
    while let Some(l) = src.next_line()? {
        let (line, ln) = (l.to_vec(), src.line_no);
        if is_blank(&line) {
            continue;
        }
        let head = record_head_v2(&line, sys);
        let mut orbit = Vec::with_capacity(4 * nlines);
        let mut ok = true;
        for _ in 0..nlines {
            match src.next_line()? {
                Some(l) => ok &= reals4(l, 3, &mut orbit).is_ok(),
                None => ok = false,
            }
        }
        match head {
            Some((sv, toc, clock)) if ok => nav.records.push(NavRecord {
                sv,
                kind: kind_of(sv.sys, None),
                toc,
                clock,
                orbit,
                line: ln,
            }),
            _ => nav.skip(ln, "unreadable ephemeris record".into()),
        }
    }
    Ok(())
}

/// Satellite, time of clock and clock terms of a RINEX 2 record's first line.
fn record_head_v2(line: &[u8], sys: Constellation) -> Option<(Sv, Epoch, [f64; 3])> {
    let prn = parse_int(cols(line, 0, 2)).ok().flatten();
    let prn = prn.filter(|p| (1..=255).contains(p))?;
    let sv = Sv::new(sys, prn as u8);
    let toc = TOC_V2.epoch(line, toc_scale(sv.sys))?;
    Some((sv, toc, clock_terms(line, 22)?))
}

/// RINEX 3/4 records: a line with the satellite, time of clock and clock terms, then
/// continuation lines (four leading blanks) of four orbit values each. RINEX 4 puts a label
/// line before every record; ION labels carry Klobuchar parameters, other non-ephemeris
/// records (STO, EOP) are skipped.
fn read_body_v3(src: &mut Lines, nav: &mut NavFile, iono: &mut IonoHalves) -> Result<()> {
    let mut held: Option<(Vec<u8>, usize)> = None;
    loop {
        let (line, ln) = match held.take() {
            Some(x) => x,
            None => match src.next_line()? {
                Some(l) => (l.to_vec(), src.line_no),
                None => break,
            },
        };
        if is_blank(&line) {
            continue;
        }
        let (line, ln, msg) = if line.first() == Some(&b'>') {
            match read_v4_label(src, &line, iono)? {
                V4Label::Ephemeris(msg, line, ln) => (line, ln, Some(msg)),
                V4Label::Consumed(next) => {
                    held = next;
                    continue;
                }
                V4Label::End => break,
            }
        } else {
            (line, ln, None)
        };
        held = read_ephemeris_v3(src, &line, ln, msg.as_deref(), nav)?;
    }
    Ok(())
}

/// A RINEX 4 label line: an ION record is read into `iono`, another non-ephemeris record is
/// skipped up to the next label, an EPH label yields the record's first line.
fn read_v4_label(src: &mut Lines, label: &[u8], iono: &mut IonoHalves) -> Result<V4Label> {
    let rtype = cols(label, 2, 5).to_vec();
    let msg = super::lines::col_str(label, 10, 15);
    if rtype == b"ION" {
        read_ion_record(src, label.get(6).copied(), &msg, iono)?;
        return Ok(V4Label::Consumed(None));
    }
    if rtype != b"EPH" {
        loop {
            match src.next_line()? {
                Some(l) if l.first() == Some(&b'>') => {
                    return Ok(V4Label::Consumed(Some((l.to_vec(), src.line_no))))
                }
                Some(_) => continue,
                None => return Ok(V4Label::Consumed(None)),
            }
        }
    }
    Ok(match src.next_line()? {
        Some(l) => V4Label::Ephemeris(msg, l.to_vec(), src.line_no),
        None => V4Label::End,
    })
}

/// The three lines of a RINEX 4 ION record; Klobuchar parameters of GPS/QZSS LNAV or BeiDou
/// D1/D2 (system letter `sys`) go into `iono`.
fn read_ion_record(
    src: &mut Lines,
    sys: Option<u8>,
    msg: &str,
    iono: &mut IonoHalves,
) -> Result<()> {
    let l1 = src.next_line()?.map(|l| l.to_vec()).unwrap_or_default();
    let l2 = src.next_line()?.map(|l| l.to_vec()).unwrap_or_default();
    let l3 = src.next_line()?.map(|l| l.to_vec()).unwrap_or_default();
    if !(msg == "LNAV" || msg == "D1D2" || msg == "D1" || msg == "D2") {
        return Ok(());
    }
    let mut vals = Vec::new();
    let _ = reals(&l1, 23, 3, &mut vals)
        .and_then(|()| reals4(&l2, 4, &mut vals))
        .and_then(|()| reals4(&l3, 4, &mut vals));
    if vals.len() >= 8 {
        let alpha = [vals[0], vals[1], vals[2], vals[3]];
        let beta = [vals[4], vals[5], vals[6], vals[7]];
        match sys {
            Some(b'G') => {
                iono.gps_alpha = Some(alpha);
                iono.gps_beta = Some(beta);
            }
            Some(b'C') => {
                iono.bds_alpha = Some(alpha);
                iono.bds_beta = Some(beta);
            }
            _ => {}
        }
    }
    Ok(())
}

/// One RINEX 3/4 ephemeris whose first line is `line` (number `ln`), of RINEX 4 message type
/// `msg` when labelled. Returns the line read after its continuation lines, if any.
fn read_ephemeris_v3(
    src: &mut Lines,
    line: &[u8],
    ln: usize,
    msg: Option<&str>,
    nav: &mut NavFile,
) -> Result<Option<(Vec<u8>, usize)>> {
    let Some(sv) = Sv::parse(cols(line, 0, 3)) else {
        nav.skip(ln, "unreadable satellite identifier".into());
        return Ok(None);
    };
    let toc = TOC_V3.epoch(line, toc_scale(sv.sys));
    let clock = toc.and(clock_terms(line, 23));
    let mut ok = clock.is_some();
    let mut orbit = Vec::with_capacity(32);
    let mut next = None;
    loop {
        match src.next_line()? {
            Some(l) if l.starts_with(b"    ") => {
                ok &= reals4(l, 4, &mut orbit).is_ok();
            }
            Some(l) => {
                next = Some((l.to_vec(), src.line_no));
                break;
            }
            None => break,
        }
    }
    match (toc, clock) {
        (Some(toc), Some(clock)) if ok => nav.records.push(NavRecord {
            sv,
            kind: kind_of(sv.sys, msg),
            toc,
            clock,
            orbit,
            line: ln,
        }),
        _ => nav.skip(ln, format!("unreadable ephemeris record of {sv}")),
    }
    Ok(next)
}

/// The message kind of a record of system `sys`, with its RINEX 4 message type when labelled.
fn kind_of(sys: Constellation, msg: Option<&str>) -> NavKind {
    match (sys, msg) {
        (_, Some("CNAV" | "CNV1" | "CNV2" | "CNV3" | "L1OC" | "L3OC")) => NavKind::Other,
        (Constellation::Glonass, _) => NavKind::Glonass,
        (Constellation::Sbas, _) => NavKind::Sbas,
        _ => NavKind::Kepler,
    }
}
