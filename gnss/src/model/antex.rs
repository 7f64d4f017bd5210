//! Receiver and satellite antenna phase-centre offsets and variations from ANTEX 1.3/1.4
//! files. Satellite entries are kept with their satellite (when the file names one, as
//! absolute-model files do) and validity span; old relative-model files list blocks only.

use crate::error::{Error, Result};
use crate::rinex::lines::{cols, label, parse_real, Lines};
use crate::sv::{Constellation, Sv};
use hifitime::Epoch;
use std::collections::BTreeMap;
use std::path::Path;

/// Offset and elevation-dependent variation of one frequency.
#[derive(Clone, Debug, PartialEq)]
pub struct FreqPcv {
    /// Phase-centre offset north, east, up from the antenna reference point, metres.
    pub neu: [f64; 3],
    /// First zenith angle, step (degrees) and the non-azimuthal variations (metres).
    pub zen1: f64,
    /// Zenith angle step of `noazi`, degrees.
    pub dzen: f64,
    /// Non-azimuthal variations from `zen1` in steps of `dzen`, metres.
    pub noazi: Vec<f64>,
}

impl FreqPcv {
    /// Variation at zenith angle `z` (degrees), linearly interpolated.
    pub fn pcv(&self, z: f64) -> f64 {
        if self.noazi.is_empty() || self.dzen <= 0.0 {
            return 0.0;
        }
        let x = ((z - self.zen1) / self.dzen).max(0.0);
        let i = (x.floor() as usize).min(self.noazi.len() - 1);
        let j = (i + 1).min(self.noazi.len() - 1);
        let f = (x - i as f64).clamp(0.0, 1.0);
        self.noazi[i] * (1.0 - f) + self.noazi[j] * f
    }
}

/// One receiver antenna (type and radome, as in ANTEX columns 1–20).
#[derive(Clone, Debug, PartialEq)]
pub struct AntennaPcv {
    /// Antenna type and radome (ANTEX columns 1–20).
    pub name: String,
    /// By ANTEX frequency code, e.g. `G01`.
    pub freqs: BTreeMap<String, FreqPcv>,
}

impl AntennaPcv {
    /// Range correction (m) to add to the geometric range to the reference point, for a
    /// signal of `sys` on `band` seen at azimuth `az` and elevation `el` (radians):
    /// −(offset · line of sight) + variation. Frequencies missing for a system fall back to
    /// the GPS frequency of the same band, as is usual.
    pub fn correction(&self, sys: Constellation, band: u8, az: f64, el: f64) -> f64 {
        let code = format!("{}0{}", sys.letter(), band as char);
        let gps = format!("G0{}", band as char);
        let Some(f) = self.freqs.get(&code).or_else(|| self.freqs.get(&gps)) else {
            return 0.0;
        };
        let (se, ce) = el.sin_cos();
        let (sa, ca) = az.sin_cos();
        let los = [ce * ca, ce * sa, se]; // north, east, up
        let off = f.neu[0] * los[0] + f.neu[1] * los[1] + f.neu[2] * los[2];
        -off + f.pcv(90.0 - el.to_degrees())
    }
}

/// One satellite antenna entry: a block (e.g. `BLOCK IIA`) and, in absolute-model files, the
/// satellite it describes and when.
#[derive(Clone, Debug, PartialEq)]
pub struct SatAntenna {
    /// Antenna type, the satellite block (ANTEX columns 1–20).
    pub block: String,
    /// The satellite (columns 21–23), absent in block-only (relative-model) files.
    pub sv: Option<Sv>,
    /// Start of validity (GPST), when given.
    pub valid_from: Option<Epoch>,
    /// End of validity (GPST), when given.
    pub valid_until: Option<Epoch>,
    /// By ANTEX frequency code: offsets x, y, z in the satellite body frame (stored in
    /// `neu`), metres, and variations by nadir angle.
    pub freqs: BTreeMap<String, FreqPcv>,
}

impl SatAntenna {
    /// Whether the entry is valid at `t`.
    pub fn valid_at(&self, t: Epoch) -> bool {
        self.valid_from.is_none_or(|f| f <= t) && self.valid_until.is_none_or(|u| t <= u)
    }

    /// Offset (body x, y, z, metres) and variation at nadir angle `nadir_deg` of `band`
    /// of `sys` (falling back to the GPS frequency of the same band); None when absent.
    pub fn offset_pcv(
        &self,
        sys: Constellation,
        band: u8,
        nadir_deg: f64,
    ) -> Option<([f64; 3], f64)> {
        let code = format!("{}0{}", sys.letter(), band as char);
        let gps = format!("G0{}", band as char);
        let f = self.freqs.get(&code).or_else(|| self.freqs.get(&gps))?;
        Some((f.neu, f.pcv(nadir_deg)))
    }
}

/// The antennas of an ANTEX file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Antex {
    /// The receiver antennas, in file order.
    pub antennas: Vec<AntennaPcv>,
    /// The satellite antennas, in file order.
    pub satellites: Vec<SatAntenna>,
    /// Whether the file holds a relative model (`PCV TYPE / REFANT` R) rather than absolute.
    pub relative: bool,
}

impl Antex {
    /// Read the receiver antennas of an ANTEX file.
    pub fn read(path: &Path) -> Result<Antex> {
        let mut src = Lines::open(path)?;
        let mut out = Antex::default();
        let mut cur: Option<AntennaPcv> = None;
        let mut satellite = false;
        let mut sat: Option<SatAntenna> = None;
        let mut freq: Option<(String, FreqPcv)> = None;
        let (mut zen1, mut dzen) = (0.0, 5.0);
        let mut saw_version = false;
        loop {
            let ln = src.line_no + 1;
            let Some(line) = src.next_line()? else { break };
            let lab = label(line);
            let bad = |what: &str| Error::parse(path, ln, what.to_string());
            match lab {
                b"ANTEX VERSION / SYST" => saw_version = true,
                b"PCV TYPE / REFANT" => out.relative = line.first() == Some(&b'R'),
                b"START OF ANTENNA" => {
                    cur = Some(AntennaPcv {
                        name: String::new(),
                        freqs: BTreeMap::new(),
                    });
                    satellite = false;
                }
                b"TYPE / SERIAL NO" => {
                    if let Some(a) = cur.as_mut() {
                        let s = type_serial(a, line);
                        satellite = s.is_some();
                        if s.is_some() {
                            sat = s;
                        }
                    }
                }
                b"VALID FROM" | b"VALID UNTIL" => {
                    let t = valid_time(line).ok_or_else(|| bad("unreadable validity date"))?;
                    if let Some(s) = sat.as_mut() {
                        if lab == b"VALID FROM" {
                            s.valid_from = Some(t);
                        } else {
                            s.valid_until = Some(t);
                        }
                    }
                }
                b"ZEN1 / ZEN2 / DZEN" => {
                    zen1 = parse_real(cols(line, 2, 8)).ok().flatten().unwrap_or(0.0);
                    dzen = parse_real(cols(line, 14, 20)).ok().flatten().unwrap_or(5.0);
                }
                b"START OF FREQUENCY" => freq = Some(start_frequency(line, zen1, dzen)),
                b"NORTH / EAST / UP" => {
                    if let Some((_, f)) = freq.as_mut() {
                        read_neu(line, &mut f.neu)
                            .ok_or_else(|| bad("unreadable NORTH / EAST / UP"))?;
                    }
                }
                b"END OF FREQUENCY" => {
                    if let (Some((code, f)), Some(a)) = (freq.take(), cur.as_mut()) {
                        if let Some(s) = sat.as_mut() {
                            s.freqs.insert(code.clone(), f.clone());
                        }
                        a.freqs.insert(code, f);
                    }
                }
                b"END OF ANTENNA" => {
                    if let Some(a) = cur.take() {
                        if !satellite && !a.name.is_empty() {
                            out.antennas.push(a);
                        }
                    }
                    out.satellites.extend(sat.take());
                }
                _ => {
                    if let Some((_, f)) = freq.as_mut() {
                        if cols(line, 3, 8) == b"NOAZI" {
                            f.noazi = noazi(line).ok_or_else(|| bad("unreadable NOAZI values"))?;
                        }
                    }
                }
            }
        }
        if !saw_version {
            return Err(Error::input(
                path,
                "not an ANTEX file (no 'ANTEX VERSION / SYST' line)",
            ));
        }
        Ok(out)
    }

    /// The entry of satellite `sv` valid at `t` (files naming satellites).
    pub fn satellite(&self, sv: Sv, t: Epoch) -> Option<&SatAntenna> {
        self.satellites
            .iter()
            .find(|a| a.sv == Some(sv) && a.valid_at(t))
    }

    /// The block-only entry (no satellite named) of block `name`, as relative-model files
    /// hold them.
    pub fn block(&self, name: &str) -> Option<&SatAntenna> {
        let norm = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
        self.satellites
            .iter()
            .find(|a| a.sv.is_none() && norm(&a.block) == norm(name))
    }

    /// The calibration of the antenna type `rinex_type` of the `role` receiver (rover, base,
    /// receiver): a missing radome entry falls back to radome NONE, a missing type gives none;
    /// each is told in `warnings`.
    pub fn calibration(
        &self,
        rinex_type: &str,
        role: &str,
        warnings: &mut Vec<String>,
    ) -> Option<&AntennaPcv> {
        let name = rinex_type.trim();
        match self.find(name) {
            Some((a, fallback)) => {
                if fallback {
                    warnings.push(format!(
                        "{role} antenna '{name}': no calibration with this radome, using '{}'",
                        a.name
                    ));
                }
                Some(a)
            }
            None => {
                warnings.push(format!("{role} antenna '{name}' is not in the ANTEX file: no phase-centre correction for it"));
                None
            }
        }
    }

    /// The antenna of a RINEX header type (type + radome); a missing radome entry falls back
    /// to the same type with radome NONE. Returns the entry and whether it was a fallback.
    pub fn find(&self, rinex_type: &str) -> Option<(&AntennaPcv, bool)> {
        let norm = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
        let want = norm(rinex_type);
        if let Some(a) = self.antennas.iter().find(|a| norm(&a.name) == want) {
            return Some((a, false));
        }
        let bare = want.split(' ').next().unwrap_or("");
        self.antennas
            .iter()
            .find(|a| norm(&a.name) == format!("{bare} NONE") || norm(&a.name) == bare)
            .map(|a| (a, true))
    }
}

/// Name antenna `a` from its `TYPE / SERIAL NO` line; the satellite entry to fill when the
/// antenna is a satellite's (a satellite code in columns 21–23, or a block name as
/// relative-model files give without a satellite), None for a receiver antenna.
fn type_serial(a: &mut AntennaPcv, line: &[u8]) -> Option<SatAntenna> {
    a.name = String::from_utf8_lossy(cols(line, 0, 20))
        .trim_end()
        .to_string();
    // Satellite antennas carry a satellite code in columns 21–23.
    let serial = cols(line, 20, 23);
    let satellite =
        serial.len() == 3 && serial[1].is_ascii_digit() && serial[0].is_ascii_uppercase();
    // Relative-model files name blocks without a satellite.
    (satellite || a.name.starts_with("BLOCK") || a.name.starts_with("GLONASS")).then(|| {
        SatAntenna {
            block: a.name.clone(),
            sv: Sv::parse(serial),
            valid_from: None,
            valid_until: None,
            freqs: BTreeMap::new(),
        }
    })
}

/// The frequency code of a `START OF FREQUENCY` line and its empty calibration, with the
/// antenna's zenith grid `zen1`, `dzen` (degrees).
fn start_frequency(line: &[u8], zen1: f64, dzen: f64) -> (String, FreqPcv) {
    let code = String::from_utf8_lossy(cols(line, 3, 6)).trim().to_string();
    (
        code,
        FreqPcv {
            neu: [0.0; 3],
            zen1,
            dzen,
            noazi: Vec::new(),
        },
    )
}

/// Read the offsets of a `NORTH / EAST / UP` line (millimetres) into `neu` in metres; None
/// at the first unreadable value.
fn read_neu(line: &[u8], neu: &mut [f64; 3]) -> Option<()> {
    for (k, v) in neu.iter_mut().enumerate() {
        *v = parse_real(cols(line, 10 * k, 10 * k + 10)).ok().flatten()? / 1000.0;
    }
    Some(())
}

/// The non-azimuthal variations of a `NOAZI` line (millimetres), in metres; None when one is
/// unreadable.
fn noazi(line: &[u8]) -> Option<Vec<f64>> {
    let txt = String::from_utf8_lossy(cols(line, 8, line.len()));
    txt.split_whitespace()
        .map(|t| t.parse::<f64>().map(|v| v / 1000.0))
        .collect::<std::result::Result<_, _>>()
        .ok()
}

/// The GPST epoch of a `VALID FROM` / `VALID UNTIL` line (year, month, day, hour, minute,
/// seconds).
fn valid_time(line: &[u8]) -> Option<Epoch> {
    let txt = String::from_utf8_lossy(cols(line, 0, 60));
    let v: Vec<f64> = txt
        .split_whitespace()
        .map(|t| t.parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .ok()?;
    let [y, mo, d, h, mi, s] = v.as_slice() else {
        return None;
    };
    let ok = (1950.0..2200.0).contains(y)
        && (1.0..=12.0).contains(mo)
        && (1.0..=31.0).contains(d)
        && (0.0..24.0).contains(h)
        && (0.0..60.0).contains(mi)
        && (0.0..61.0).contains(s);
    if !ok {
        return None;
    }
    let whole = s.floor();
    crate::time::try_gpst(
        *y as i32,
        *mo as u8,
        *d as u8,
        *h as u8,
        *mi as u8,
        whole as u8,
        ((s - whole) * 1e9).round().min(999_999_999.0) as u32,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_receiver_antennas_and_corrects_ranges() {
        let path =
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/test.atx");
        let atx = Antex::read(&path).unwrap();
        assert_eq!(atx.antennas.len(), 1, "the satellite antenna is kept apart");
        assert_eq!(atx.satellites.len(), 1);
        let g05 = Sv::new(Constellation::Gps, 5);
        let t = crate::time::gpst(2020, 1, 1, 0, 0, 0, 0);
        let s = atx
            .satellite(g05, t)
            .expect("G05 is listed without a validity span");
        assert_eq!(s.block, "BLOCK IIR-M");
        assert!(atx.satellite(Sv::new(Constellation::Gps, 6), t).is_none());
        assert!(!atx.relative);
        let (a, fallback) = atx.find("PPKATTEST").unwrap();
        assert!(fallback, "no radome given: the NONE entry is used");
        assert_eq!(a.freqs["G01"].neu, [0.0, 0.0, 0.1]);
        // A phase centre 10 cm up shortens the range to a zenith satellite by 10 cm, and by
        // 10 cm·sin(30°) at 30° elevation.
        let z = a.correction(Constellation::Gps, b'1', 0.0, std::f64::consts::FRAC_PI_2);
        assert!((z + 0.1).abs() < 1e-12);
        let low = a.correction(Constellation::Galileo, b'1', 1.0, 30f64.to_radians());
        assert!(
            (low + 0.05).abs() < 1e-12,
            "Galileo falls back to G01: {low}"
        );
        let f = FreqPcv {
            neu: [0.0; 3],
            zen1: 0.0,
            dzen: 5.0,
            noazi: vec![0.0, 0.002, 0.004],
        };
        assert!((f.pcv(7.5) - 0.003).abs() < 1e-12);
        assert!((f.pcv(30.0) - 0.004).abs() < 1e-12);
    }
}
