//! One SP3 precise-orbit file (SP3-a, -b, -c and -d; plain or gzip) as read: the epochs and,
//! per satellite, the position and clock at each epoch. Interpolation, and the merging of the
//! files of consecutive days, is [`super::precise::PreciseOrbits`]'s.
//!
//! SP3-a and -b files name GPS satellites without a system letter (`P  1` is GPS PRN 1); the
//! time system is GPS unless an SP3-c/d `%c` line names another. Positions are of the
//! satellite's centre of mass (ITRF-like frame named in the first line), clocks are in seconds.

use crate::error::{Error, Result};
use crate::rinex::body::DateCols;
use crate::rinex::lines::{cols, parse_real, Lines};
use crate::sv::Sv;
use hifitime::{Epoch, TimeScale};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Epoch line `*  yyyy mm dd hh mm ss.ssssssss`.
const EPOCH: DateCols = DateCols {
    ymdhm: [(3, 7), (8, 10), (11, 13), (14, 16), (17, 19)],
    sec: (20, 31),
    two_digit_years: false,
};

/// Marker of an absent clock (`999999.999999` µs) and beyond.
const BAD_CLOCK_US: f64 = 999_999.0;

/// The samples of one SP3 file.
#[derive(Clone, Debug, Default)]
pub struct Sp3 {
    /// The file.
    pub path: PathBuf,
    /// Format version letter (`a`, `b`, `c` or `d`).
    pub version: char,
    /// Coordinate system named in the first line (e.g. `IGb00`, `IGS14`).
    pub frame: String,
    /// The file's epochs (GPST), in file order.
    pub epochs: Vec<Epoch>,
    /// Nominal epoch interval, seconds (the most common step between epochs, else the header's).
    pub interval: f64,
    /// Per satellite: position (m) and clock (s) at each epoch; NaN where absent (a position
    /// of exactly 0, 0, 0 or a clock of 999999.999999 µs in the file).
    pub sats: BTreeMap<Sv, Vec<(Vector3<f64>, f64)>>,
}

/// Slots (satellite × epoch, 32 bytes each) allowed beyond four per position record read:
/// 32 MB for files where some satellites are absent at most epochs.
const MAX_SPARE_SLOTS: usize = 1_000_000;

impl Sp3 {
    /// Read an SP3 file (versions a to d, plain or gzip).
    pub fn read(path: &Path) -> Result<Sp3> {
        let mut src = Lines::open(path)?;
        let first = src
            .next_line()?
            .ok_or_else(|| Error::input(path, "the file is empty"))?
            .to_vec();
        let version = match (first.first(), first.get(1)) {
            (Some(b'#'), Some(&v @ (b'a' | b'b' | b'c' | b'd'))) => v as char,
            _ => {
                return Err(Error::input(
                    path,
                    "not an SP3 file (the first line does not start with #a, #b, #c or #d)",
                ))
            }
        };
        let mut sp3 = Sp3 {
            path: path.to_path_buf(),
            version,
            frame: String::from_utf8_lossy(cols(&first, 46, 51))
                .trim()
                .to_string(),
            ..Sp3::default()
        };
        let mut header_interval = None;
        let mut scale = TimeScale::GPST;
        // The first `%c` line names the time system (SP3-d headers grow with the satellites).
        let mut time_system_read = false;
        let mut records = 0usize;
        loop {
            let ln = src.line_no + 1;
            let Some(line) = src.next_line()? else { break };
            match line.first() {
                Some(b'#') if line.starts_with(b"##") => {
                    header_interval = parse_real(cols(line, 24, 38)).ok().flatten();
                }
                Some(b'%') if line.starts_with(b"%c") && !time_system_read => {
                    time_system_read = true;
                    scale = time_scale(cols(line, 9, 12)).unwrap_or(scale);
                }
                Some(b'*') => {
                    let e = EPOCH
                        .epoch(line, scale)
                        .ok_or_else(|| Error::parse(path, ln, "unreadable SP3 epoch line"))?;
                    sp3.epochs.push(e);
                }
                Some(b'P') if !sp3.epochs.is_empty() => {
                    records += 1;
                    // Every satellite holds a slot per epoch: bounded by the records read, so
                    // that epoch lines without positions cannot ask for gigabytes.
                    let slots = (sp3.sats.len() + 1).saturating_mul(sp3.epochs.len());
                    if slots > 4 * records + MAX_SPARE_SLOTS {
                        return Err(Error::parse(
                            path,
                            ln,
                            format!(
                                "{} epochs and {} satellites so far but only {records} positions: \
                                 not a usable SP3 file (epochs without positions?)",
                                sp3.epochs.len(),
                                sp3.sats.len() + 1
                            ),
                        ));
                    }
                    sp3.position_record(line, ln)?
                }
                Some(b'E') if line.starts_with(b"EOF") => break,
                _ => {}
            }
        }
        let n = sp3.epochs.len();
        if n == 0 {
            return Err(Error::input(path, "the file holds no epoch"));
        }
        for v in sp3.sats.values_mut() {
            v.resize(n, (Vector3::repeat(f64::NAN), f64::NAN));
        }
        let steps: Vec<f64> = sp3
            .epochs
            .windows(2)
            .map(|w| (w[1] - w[0]).to_seconds())
            .collect();
        sp3.interval = nominal_step(&steps)
            .or(header_interval.filter(|s| *s > 0.0))
            .unwrap_or(900.0);
        Ok(sp3)
    }

    /// A `P` record (position and clock of one satellite) at the latest epoch.
    fn position_record(&mut self, line: &[u8], ln: usize) -> Result<()> {
        let Some(sv) = Sv::parse(cols(line, 1, 4)) else {
            return Ok(()); // a system ppkat does not know (LEO, …)
        };
        let f = |a| parse_real(cols(line, a, a + 14)).ok().flatten();
        let (Some(x), Some(y), Some(z)) = (f(4), f(18), f(32)) else {
            return Err(Error::parse(&self.path, ln, "unreadable SP3 position"));
        };
        let clk = f(46)
            .filter(|c| c.abs() < BAD_CLOCK_US)
            .map(|c| c * 1e-6)
            .unwrap_or(f64::NAN);
        let pos = if x == 0.0 && y == 0.0 && z == 0.0 {
            Vector3::repeat(f64::NAN)
        } else {
            Vector3::new(x, y, z) * 1e3
        };
        let n = self.epochs.len();
        let v = self.sats.entry(sv).or_default();
        v.resize(n, (Vector3::repeat(f64::NAN), f64::NAN));
        v[n - 1] = (pos, clk);
        Ok(())
    }

    /// Time span covered.
    pub fn span(&self) -> Option<(Epoch, Epoch)> {
        Some((*self.epochs.first()?, *self.epochs.last()?))
    }
}

/// The time scale named by a three-letter time-system field (SP3 `%c`, RINEX clock
/// `TIME SYSTEM ID`); `None` for blanks and unknown names.
pub(crate) fn time_scale(field: &[u8]) -> Option<TimeScale> {
    Some(match crate::rinex::lines::trim(field) {
        b"GPS" => TimeScale::GPST,
        b"UTC" | b"GLO" => TimeScale::UTC,
        b"GAL" | b"GST" => TimeScale::GST,
        b"BDT" | b"BDS" => TimeScale::BDT,
        b"TAI" => TimeScale::TAI,
        b"QZS" => TimeScale::QZSST,
        _ => return None,
    })
}

/// The most common of `steps` (seconds, compared to the millisecond; ties go to the shorter),
/// ignoring non-positive ones; `None` when there is none.
pub(crate) fn nominal_step(steps: &[f64]) -> Option<f64> {
    let mut ms: Vec<i64> = steps
        .iter()
        .filter(|s| s.is_finite() && **s > 0.0)
        .map(|s| (s * 1e3).round() as i64)
        .filter(|m| *m > 0)
        .collect();
    ms.sort_unstable();
    let mut best: Option<(i64, usize)> = None;
    for run in ms.chunk_by(|a, b| a == b) {
        if best.is_none_or(|(_, n)| run.len() > n) {
            best = Some((run[0], run.len()));
        }
    }
    best.map(|(m, _)| m as f64 * 1e-3)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small SP3 text: `plus` extra `+` header lines before the `%c` line (as in SP3-d
    /// files of many satellites), time system `ts`, two epochs of PRN 1 written `id`.
    fn text(plus: usize, ts: &str, id: &str) -> String {
        let mut t = String::from("#dP2020  6 25  0  0  0.00000000       2 ORBIT IGS14 FIT  TEST\n");
        t += "## 2111 345600.00000000   900.00000000 59025 0.0000000000000\n";
        for _ in 0..plus {
            t += "+        G01  0  0  0  0  0  0  0  0  0  0  0  0  0  0  0  0\n";
        }
        t += &format!("%c M  cc {ts} ccc cccc cccc cccc cccc ccccc ccccc ccccc ccccc\n");
        for m in [0, 15] {
            t += &format!("*  2020  6 25  0 {m:2}  0.00000000\n");
            t += &format!("P{id}  15202.734861   1913.732043 -21514.720553 999999.999999\n");
        }
        t + "EOF\n"
    }

    fn read_text(name: &str, t: &str) -> Result<Sp3> {
        Sp3::read(&testkit::scratch_file(name, t))
    }

    #[test]
    fn time_system_ids_and_absent_clocks() {
        let sv = Sv::new(crate::sv::Constellation::Gps, 1);
        for (plus, id) in [(0, "G01"), (20, "  1")] {
            let f = read_text("utc.sp3", &text(plus, "UTC", id)).unwrap();
            // 00:00 UTC in 2020 is 00:00:18 GPST.
            assert_eq!(f.epochs[0], crate::time::gpst(2020, 6, 25, 0, 0, 18, 0));
            assert_eq!(
                (f.version, f.frame.as_str(), f.interval),
                ('d', "IGS14", 900.0)
            );
            let (p, c) = f.sats[&sv][1];
            assert_eq!(p.x, 15202.734861 * 1e3);
            assert!(c.is_nan(), "999999.999999 is an absent clock");
        }
        let bad = text(0, "GPS", "G01").replace("-21514.720553", "-21514.7205x3");
        let e = read_text("bad.sp3", &bad).unwrap_err().to_string();
        assert!(
            e.contains("bad.sp3:5:") && e.contains("unreadable SP3 position"),
            "{e}"
        );
        let e = read_text("not.sp3", "hello\n").unwrap_err().to_string();
        assert!(e.contains("not an SP3 file"), "{e}");
    }

    #[test]
    fn nominal_step_is_the_most_common() {
        assert_eq!(nominal_step(&[900.0, 900.0, 1800.0, 900.0]), Some(900.0));
        assert_eq!(nominal_step(&[30.0, 60.0]), Some(30.0));
        assert_eq!(nominal_step(&[0.0, -1.0]), None);
        assert_eq!(nominal_step(&[]), None);
    }
}
