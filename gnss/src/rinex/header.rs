//! RINEX observation header (2.x, 3.x, 4.x; also the header inside a CRINEX file).

use super::lines::{col_str, cols, label, parse_int, parse_real, Lines};
use super::record::ObsCode;
use crate::error::{Error, Result};
use crate::frame::Ecef;
use crate::sv::{Constellation, Sv};
use hifitime::TimeScale;
use std::collections::BTreeMap;
use std::path::Path;

/// Antenna reference point offset from the marker (RINEX "ANTENNA: DELTA H/E/N"), metres.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AntennaDelta {
    /// Up, metres.
    pub up: f64,
    /// East, metres.
    pub east: f64,
    /// North, metres.
    pub north: f64,
}

/// What a processor needs from an observation header.
#[derive(Clone, Debug)]
pub struct ObsHeader {
    /// RINEX version, e.g. 2.11 or 3.04.
    pub version: f64,
    /// Hatanaka (CRINEX) version when the file was compressed that way.
    pub crinex: Option<f64>,
    /// Satellite system of the file (`None` for mixed).
    pub file_system: Option<Constellation>,
    /// Marker name.
    pub marker: String,
    /// Marker number.
    pub marker_number: String,
    /// Receiver number, type and version.
    pub receiver: String,
    /// Antenna type and radome (as in ANTEX).
    pub antenna: String,
    /// Approximate marker position, ECEF, when given.
    pub approx_position: Option<Ecef>,
    /// Antenna reference point offset from the marker.
    pub antenna_delta: AntennaDelta,
    /// Nominal interval in seconds.
    pub interval: Option<f64>,
    /// Observation types per system, in the file's order (RINEX 2 types translated to 3-letter codes).
    pub obs_types: BTreeMap<Constellation, Vec<ObsCode>>,
    /// GLONASS frequency channel numbers by slot.
    pub glonass_channels: BTreeMap<u8, i8>,
    /// Systems with `SYS / PHASE SHIFT` records: their phases are aligned to each band's
    /// reference signal (RINEX 3.01 and later), so two receivers' different signals of one
    /// band differ by whole cycles only.
    pub phase_aligned: std::collections::BTreeSet<Constellation>,
    /// Time scale of the epochs (GPST unless the header says otherwise).
    pub time_scale: TimeScale,
    /// Leap seconds, when given.
    pub leap_seconds: Option<i32>,
    /// Header lines kept but not interpreted by ppkat (for `info`).
    pub notes: Vec<String>,
    /// Number of header lines (for line numbers after a CRINEX header).
    pub lines: usize,
}

impl ObsHeader {
    /// A header of RINEX `version` that says nothing else: no marker, receiver, antenna,
    /// position, interval or types; GPST.
    pub fn new(version: f64) -> Self {
        ObsHeader {
            version,
            crinex: None,
            file_system: None,
            marker: String::new(),
            marker_number: String::new(),
            receiver: String::new(),
            antenna: String::new(),
            approx_position: None,
            antenna_delta: AntennaDelta::default(),
            interval: None,
            obs_types: BTreeMap::new(),
            glonass_channels: BTreeMap::new(),
            phase_aligned: Default::default(),
            time_scale: TimeScale::GPST,
            leap_seconds: None,
            notes: Vec::new(),
            lines: 0,
        }
    }

    /// Observation types of a satellite's system.
    pub fn types_of(&self, sys: Constellation) -> &[ObsCode] {
        self.obs_types
            .get(&sys)
            .map(|v| v.as_slice())
            .unwrap_or(&[])
    }
    /// Whether the file is RINEX 2.x.
    pub fn is_v2(&self) -> bool {
        self.version < 3.0
    }
    /// GLONASS frequency channel of a satellite, when the header gives it.
    pub fn glonass_channel(&self, sv: Sv) -> Option<i8> {
        self.glonass_channels.get(&sv.prn).copied()
    }
}

/// Translate a RINEX 2 two-character type to the RINEX 3 code used inside ppkat.
pub fn v2_code(sys: Constellation, t: &[u8]) -> Option<ObsCode> {
    if t.len() != 2 {
        return None;
    }
    let (kind, band) = (t[0], t[1]);
    let attr = match (sys, kind, band) {
        (Constellation::Gps, b'P', b'1' | b'2') => b'W',
        (Constellation::Glonass, b'P', _) => b'P',
        (_, b'P', _) => b'W',
        (Constellation::Gps, b'C', b'2') => b'L',
        (Constellation::Gps | Constellation::Qzss, _, b'1') => b'C',
        (Constellation::Gps, _, b'2') => b'W',
        (Constellation::Glonass, _, _) => b'C',
        (Constellation::BeiDou, _, _) => b'I',
        _ => b'X',
    };
    let kind = match kind {
        b'P' | b'C' => b'C',
        b'L' | b'D' | b'S' => kind,
        _ => return None,
    };
    Some(ObsCode([kind, band, attr]))
}

/// Observation types as the header lists them, gathered over continuation lines.
#[derive(Default)]
struct TypeLists {
    /// RINEX 2 two-character types (one list for every system).
    v2: Vec<[u8; 2]>,
    /// How many RINEX 2 types the first `# / TYPES OF OBSERV` line announced.
    v2_count: usize,
    /// RINEX 3/4: the system being listed and how many types it announced.
    v3_sys: Option<(Constellation, usize)>,
}

/// Read the header, stopping after END OF HEADER, from the first line on.
pub(crate) fn read_header(src: &mut Lines, crinex: Option<f64>) -> Result<ObsHeader> {
    let path = src.path.clone();
    let mut h = ObsHeader {
        crinex,
        ..ObsHeader::new(0.0)
    };
    let mut types = TypeLists::default();
    let mut saw_version = false;
    loop {
        let line_no = src.line_no + 1;
        let Some(line) = src.next_line()? else {
            if !saw_version {
                return Err(Error::input(&path, "the file is empty"));
            }
            return Err(Error::input(
                &path,
                "the header has no END OF HEADER line; the file is truncated or not RINEX",
            ));
        };
        let lab = label(line);
        let bad = |what: &str| {
            Error::parse(
                &path,
                line_no,
                format!(
                    "{what} in header line '{}'",
                    String::from_utf8_lossy(line).trim_end()
                ),
            )
        };
        if !saw_version {
            if lab != b"RINEX VERSION / TYPE" {
                return Err(Error::input(
                    &path,
                    "the first line is not 'RINEX VERSION / TYPE': this is not a RINEX file",
                ));
            }
            saw_version = true;
            read_version_line(&mut h, line, &path, bad)?;
            continue;
        }
        if lab == b"END OF HEADER" {
            break;
        }
        read_header_line(&mut h, &mut types, lab, line, bad)?;
    }
    h.lines = src.line_no;
    set_obs_types(&mut h, &types.v2, &path)?;
    Ok(h)
}

/// `RINEX VERSION / TYPE`: the version (2.x–4.x) and the file's system; anything but an
/// observation file is refused, saying what it is.
fn read_version_line(
    h: &mut ObsHeader,
    line: &[u8],
    path: &Path,
    bad: impl Fn(&str) -> Error,
) -> Result<()> {
    let v = parse_real(cols(line, 0, 9))
        .ok()
        .flatten()
        .ok_or_else(|| bad("unreadable version"))?;
    if !(2.0..5.0).contains(&v) {
        return Err(Error::input(
            path,
            format!("RINEX version {v} is not supported (2.x, 3.x and 4.x are)"),
        ));
    }
    h.version = v;
    let kind = cols(line, 20, 21).first().copied().unwrap_or(b' ');
    if kind != b'O' {
        let what = match kind {
            b'N' | b'G' | b'H' | b'L' | b'C' | b'E' | b'J' | b'I' => {
                "a navigation file, not observations: give it with --nav"
            }
            b'M' => "a meteorological file, not observations",
            _ => "not an observation file (type in column 21 is not 'O')",
        };
        return Err(Error::input(path, format!("this is {what}")));
    }
    let sys = cols(line, 40, 41).first().copied().unwrap_or(b'G');
    h.file_system = if sys == b'M' {
        None
    } else {
        Constellation::from_letter(sys).or(Some(Constellation::Gps))
    };
    Ok(())
}

/// One header line after the version line, by its label; labels ppkat does not use are
/// ignored.
fn read_header_line(
    h: &mut ObsHeader,
    types: &mut TypeLists,
    lab: &[u8],
    line: &[u8],
    bad: impl Fn(&str) -> Error,
) -> Result<()> {
    match lab {
        b"MARKER NAME" => h.marker = col_str(line, 0, 60),
        b"MARKER NUMBER" => h.marker_number = col_str(line, 0, 20),
        b"REC # / TYPE / VERS" => {
            h.receiver = format!("{} {}", col_str(line, 20, 40), col_str(line, 40, 60))
                .trim()
                .to_string()
        }
        b"ANT # / TYPE" => h.antenna = col_str(line, 20, 40),
        b"APPROX POSITION XYZ" => {
            let f = |a| parse_real(cols(line, a, a + 14)).ok().flatten();
            if let (Some(x), Some(y), Some(z)) = (f(0), f(14), f(28)) {
                if x != 0.0 || y != 0.0 || z != 0.0 {
                    h.approx_position = Some(Ecef::new(x, y, z));
                }
            }
        }
        b"ANTENNA: DELTA H/E/N" => {
            let f = |a| {
                parse_real(cols(line, a, a + 14))
                    .ok()
                    .flatten()
                    .unwrap_or(0.0)
            };
            h.antenna_delta = AntennaDelta {
                up: f(0),
                east: f(14),
                north: f(28),
            };
        }
        b"INTERVAL" => h.interval = parse_real(cols(line, 0, 10)).ok().flatten(),
        b"LEAP SECONDS" => {
            h.leap_seconds = parse_int(cols(line, 0, 6)).ok().flatten().map(|v| v as i32)
        }
        b"TIME OF FIRST OBS" => {
            h.time_scale = match cols(line, 48, 51) {
                b"GLO" => TimeScale::UTC,
                b"GAL" => TimeScale::GST,
                b"BDT" => TimeScale::BDT,
                _ => TimeScale::GPST,
            };
        }
        b"# / TYPES OF OBSERV" => read_v2_types(types, line, bad)?,
        b"SYS / # / OBS TYPES" => read_v3_types(h, types, line, bad)?,
        b"GLONASS SLOT / FRQ #" => {
            for k in 0..8 {
                let a = 4 + 7 * k;
                if let Some(sv) = Sv::parse(cols(line, a, a + 3)) {
                    if let Ok(Some(ch)) = parse_int(cols(line, a + 4, a + 6)) {
                        h.glonass_channels.insert(sv.prn, ch as i8);
                    }
                }
            }
        }
        b"SYS / PHASE SHIFT" => {
            if let Some(sys) = line.first().copied().and_then(Constellation::from_letter) {
                if line[0] != b' ' {
                    h.phase_aligned.insert(sys);
                }
            }
        }
        b"SYS / SCALE FACTOR" => h.notes.push(
            "SYS / SCALE FACTOR present: observations are used as written (factor not applied)"
                .into(),
        ),
        _ => {}
    }
    Ok(())
}

/// A header's count of observation types when it is one a file can hold: 0 to 999 (RINEX 3's
/// three digits; no receiver logs more than about a hundred for one system). A negative or
/// larger count would size every satellite's record, so it is refused.
fn type_count(n: i64) -> Option<usize> {
    usize::try_from(n).ok().filter(|&n| n <= 999)
}

/// A RINEX 2 `# / TYPES OF OBSERV` line (the first gives the count, nine types a line).
fn read_v2_types(types: &mut TypeLists, line: &[u8], bad: impl Fn(&str) -> Error) -> Result<()> {
    if types.v2.is_empty() {
        let n = parse_int(cols(line, 0, 6))
            .ok()
            .flatten()
            .ok_or_else(|| bad("missing count"))?;
        types.v2_count =
            type_count(n).ok_or_else(|| bad("count of observation types not in 0..=999"))?;
    }
    for k in 0..9 {
        let t = cols(line, 10 + 6 * k, 12 + 6 * k);
        if t.len() == 2 && t != b"  " && types.v2.len() < types.v2_count {
            types.v2.push([t[0], t[1]]);
        }
    }
    Ok(())
}

/// A RINEX 3/4 `SYS / # / OBS TYPES` line: a system letter and count start a list, a blank
/// letter continues it (13 types a line).
fn read_v3_types(
    h: &mut ObsHeader,
    types: &mut TypeLists,
    line: &[u8],
    bad: impl Fn(&str) -> Error,
) -> Result<()> {
    let first = cols(line, 0, 1).first().copied().unwrap_or(b' ');
    if first != b' ' {
        let sys =
            Constellation::from_letter(first).ok_or_else(|| bad("unknown satellite system"))?;
        let n = parse_int(cols(line, 3, 6))
            .ok()
            .flatten()
            .ok_or_else(|| bad("missing count"))?;
        let n = type_count(n).ok_or_else(|| bad("count of observation types not in 0..=999"))?;
        h.obs_types.insert(sys, Vec::with_capacity(n.min(64)));
        types.v3_sys = Some((sys, n));
    }
    let Some((sys, n)) = types.v3_sys else {
        return Err(bad("continuation without a system"));
    };
    let list = h.obs_types.entry(sys).or_default();
    for k in 0..13 {
        let t = cols(line, 7 + 4 * k, 10 + 4 * k);
        if t.len() == 3 && list.len() < n {
            list.push(ObsCode([t[0], t[1], t[2]]));
        }
    }
    Ok(())
}

/// The observation types per system once the header is read: RINEX 2 types translated to
/// 3-letter codes for every system; an error when the header lists none.
fn set_obs_types(h: &mut ObsHeader, v2_types: &[[u8; 2]], path: &Path) -> Result<()> {
    if h.is_v2() {
        if v2_types.is_empty() {
            return Err(Error::input(
                path,
                "the header has no '# / TYPES OF OBSERV': cannot read observations",
            ));
        }
        for sys in Constellation::ALL {
            let codes: Vec<ObsCode> = v2_types
                .iter()
                .map(|t| v2_code(sys, t).unwrap_or(ObsCode([t[0], t[1], b'?'])))
                .collect();
            h.obs_types.insert(sys, codes);
        }
    } else if h.obs_types.is_empty() {
        return Err(Error::input(
            path,
            "the header has no 'SYS / # / OBS TYPES': cannot read observations",
        ));
    }
    Ok(())
}
