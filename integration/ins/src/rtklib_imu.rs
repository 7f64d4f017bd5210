//! The RTKLIB-style raw IMU log of `../shared/data/ins` (rtklibexplorer's GNSS_IMU): a CSV
//! without header, `ax, ay, az` in g, `gx, gy, gz` in °/s, then the IMU's tick in ms, in the
//! IMU's own axes; and its RTKLIB time-tag file (`.tag`: a 60-byte text header, a uint32, the
//! start as uint32 seconds since 1970 in GPST and a float64 fraction, then (uint32 tick ms
//! since the start, uint32 file offset) pairs, little-endian).
//!
//! Time: the first row is placed at the tag's start and the IMU's ticks are stretched so that
//! the last row falls at the tag's last tick — as the data's own tools convert it (their
//! converted walk agrees with this to 0.5 µs); the stretch, the IMU oscillator against the
//! logger's clock, is returned (141 ppm on the walk) and refused beyond 0.1 %.
//!
//! Rows that do not parse (the first and last may be cut), ticks that do not increase and
//! gaps are counted and named by line; a file whose accelerations do not look like g (the
//! median magnitude far from 1) is an error saying so.

use crate::error::{Error, Result};
use crate::imu::ImuSample;
use crate::spec::G0;
use hifitime::{Duration, Epoch, TimeScale};
use nalgebra::Vector3;
use std::path::Path;

/// Largest stretch of the IMU's ticks against the tags (0.1 %).
const MAX_STRETCH: f64 = 1e-3;
/// An interval longer than this many nominal ones (the median) is a gap.
const GAP_FACTOR: f64 = 3.0;

/// The median of `v` (sorted in place; not empty).
pub(crate) fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The gap before the row on `line`, `dt` seconds after the row before, when longer than
/// [`GAP_FACTOR`] `nominal` intervals: `line N: … s`.
pub(crate) fn gap(line: usize, dt: f64, nominal: f64) -> Option<String> {
    (dt > GAP_FACTOR * nominal).then(|| format!("line {line}: {dt:.3} s"))
}

/// Consecutive rows at an axis' largest magnitude that make a saturation.
pub const SATURATED_RUN: usize = 3;

/// An IMU log read: samples in the IMU's axes, and what was left out.
#[derive(Clone, Debug, Default)]
pub struct ImuLog {
    /// One sample per row after the first (rates times the interval since the row before).
    pub samples: Vec<ImuSample>,
    /// Rows left out, each `line N: why`.
    pub skipped: Vec<String>,
    /// Gaps longer than three nominal intervals ([`gap`]), each `line N: … s`.
    pub gaps: Vec<String>,
    /// Runs of [`SATURATED_RUN`] rows or more at an axis' largest magnitude (its full scale:
    /// the sensor clipped), each `lines A–B: …`; kept, but wrong.
    pub saturated: Vec<String>,
    /// The IMU ticks' stretch to the logger's clock (1 + ppm·10⁻⁶).
    pub stretch: f64,
}

/// One parsed row: accelerations (g), rates (°/s), tick (ms).
type Row = (usize, [f64; 6], u64);

fn rows(text: &str, skipped: &mut Vec<String>) -> Vec<Row> {
    let mut out: Vec<Row> = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed = (f.len() == 7).then(|| {
            let mut v = [0.0; 6];
            for (i, x) in f[..6].iter().enumerate() {
                v[i] = x.parse::<f64>().ok().filter(|x| x.is_finite())?;
            }
            Some((v, f[6].parse::<u64>().ok()?))
        });
        match parsed.flatten() {
            Some((v, tick)) if out.last().is_none_or(|l| tick > l.2) => out.push((n + 1, v, tick)),
            Some(_) => skipped.push(format!(
                "line {}: its tick does not follow the row before",
                n + 1
            )),
            None if line.trim().is_empty() => {}
            None => skipped.push(format!(
                "line {}: not seven numbers (ax, ay, az in g, gx, gy, gz in °/s, tick in ms)",
                n + 1
            )),
        }
    }
    out
}

/// Runs of rows where an axis sits at its largest magnitude (see [`ImuLog::saturated`]):
/// each row its line and `ax, ay, az, gx, gy, gz` in any units.
pub(crate) fn saturated(rs: &[(usize, [f64; 6])]) -> Vec<String> {
    const AXES: [&str; 6] = ["ax", "ay", "az", "gx", "gy", "gz"];
    let mut out = Vec::new();
    for (j, name) in AXES.iter().enumerate() {
        let full = rs.iter().map(|r| r.1[j].abs()).fold(0.0f64, f64::max);
        let least = rs
            .iter()
            .map(|r| r.1[j].abs())
            .fold(f64::INFINITY, f64::min);
        // An axis that never changes (a file written by hand, a dead sensor) clips nothing.
        if full == 0.0 || least == full {
            continue;
        }
        let mut run: Option<(usize, usize)> = None;
        let mut flush = |run: &mut Option<(usize, usize)>| {
            if let Some((a, b)) = run.take() {
                if b - a + 1 >= SATURATED_RUN {
                    out.push(format!(
                        "lines {}–{}: {name} at ±{full}, its largest value, {} rows running: the sensor clipped (kept, but wrong)",
                        rs[a].0,
                        rs[b].0,
                        b - a + 1
                    ));
                }
            }
        };
        for (k, r) in rs.iter().enumerate() {
            if r.1[j].abs() == full {
                run = Some(run.map_or((k, k), |(a, _)| (a, k)));
            } else {
                flush(&mut run);
            }
        }
        flush(&mut run);
    }
    out
}

/// The tag file's start (GPST) and last tick (ms).
fn tag(path: &Path) -> Result<(Epoch, u64)> {
    let b = std::fs::read(path).map_err(|cause| Error::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    let bad = |m: &str| Error::Input {
        path: path.to_path_buf(),
        message: m.to_string(),
    };
    if b.len() < 84 || !b.starts_with(b"TIMETAG") {
        return Err(bad(
            "not an RTKLIB time-tag file (no TIMETAG header, or no tags)",
        ));
    }
    let u32_at = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    let secs = u32_at(64);
    let frac = f64::from_le_bytes(b[68..76].try_into().expect("8 bytes"));
    let pairs = (b.len() - 76) / 8;
    let last = u32_at(76 + 8 * (pairs - 1));
    // Seconds since 1970 counted in GPST: the epoch 1970-01-01 in GPST plus them.
    let start = Epoch::from_gregorian(1970, 1, 1, 0, 0, 0, 0, TimeScale::GPST)
        + Duration::from_seconds(f64::from(secs) + frac);
    Ok((start, u64::from(last)))
}

/// Read a CSV and its tag file.
pub fn read(csv: &Path, tag_path: &Path) -> Result<ImuLog> {
    let text = std::fs::read_to_string(csv).map_err(|cause| Error::Io {
        path: csv.to_path_buf(),
        cause,
    })?;
    let (start, last_tag) = tag(tag_path)?;
    let mut log = ImuLog::default();
    let rs = rows(&text, &mut log.skipped);
    let bad = |m: String| Error::Input {
        path: csv.to_path_buf(),
        message: m,
    };
    if rs.len() < 2 {
        return Err(bad("fewer than two IMU rows".into()));
    }
    let mut mags: Vec<f64> = rs
        .iter()
        .map(|r| Vector3::new(r.1[0], r.1[1], r.1[2]).norm())
        .collect();
    let in_g = median(&mut mags);
    if !(0.5..=2.0).contains(&in_g) {
        return Err(bad(format!(
            "the accelerations' median magnitude is {in_g:.3}: not in g (m/s² would read 9.8); convert the file to g"
        )));
    }
    let lines: Vec<(usize, [f64; 6])> = rs.iter().map(|r| (r.0, r.1)).collect();
    log.saturated = saturated(&lines);
    let (t0, t1) = (rs[0].2, rs[rs.len() - 1].2);
    log.stretch = last_tag as f64 / (t1 - t0) as f64;
    if (log.stretch - 1.0).abs() > MAX_STRETCH {
        return Err(bad(format!(
            "the IMU's ticks span {:.3} s, the tags {:.3} s ({:+.0} ppm): they do not belong together",
            (t1 - t0) as f64 / 1e3,
            last_tag as f64 / 1e3,
            (log.stretch - 1.0) * 1e6
        )));
    }
    let time = |tick: u64| start + Duration::from_seconds((tick - t0) as f64 / 1e3 * log.stretch);
    let mut intervals: Vec<f64> = rs.windows(2).map(|w| (w[1].2 - w[0].2) as f64).collect();
    let nominal = median(&mut intervals) * 1e-3 * log.stretch;
    for w in rs.windows(2) {
        let dt = (w[1].2 - w[0].2) as f64 * 1e-3 * log.stretch;
        log.gaps.extend(gap(w[1].0, dt, nominal));
        let v = w[1].1;
        let deg = std::f64::consts::PI / 180.0;
        log.samples.push(ImuSample::from_rates(
            time(w[1].2),
            dt,
            Vector3::new(v[3], v[4], v[5]) * deg,
            Vector3::new(v[0], v[1], v[2]) * G0,
        ));
    }
    Ok(log)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An RTKLIB time-tag file: header, start (s since 1970 GPST + fraction), the last tick.
    fn tag_bytes(last_tick: u32) -> Vec<u8> {
        let mut b = b"TIMETAG RTKLIB demo5".to_vec();
        b.resize(60, 0);
        b.extend(1000u32.to_le_bytes());
        b.extend(1_750_000_000u32.to_le_bytes());
        b.extend(0.25f64.to_le_bytes());
        for (tick, off) in [(0u32, 0u32), (last_tick, 999)] {
            b.extend(tick.to_le_bytes());
            b.extend(off.to_le_bytes());
        }
        b
    }

    fn write(name: &str, csv: &str, last_tick: u32) -> (std::path::PathBuf, std::path::PathBuf) {
        let c = testkit::scratch_file(name, csv);
        let t = testkit::scratch_file(&format!("{name}.tag"), tag_bytes(last_tick));
        (c, t)
    }

    /// A cut first line, a repeated tick, a tick that goes back and a 0.5 s gap are named by
    /// line; the rest is read, on the tags' clock.
    #[test]
    fn bad_rows_and_gaps_are_named_by_line() {
        let mut csv = String::from("0.01,1.0,0.02,0.1,0.2,0.3\n");
        let mut tick = 1000;
        for k in 0..20 {
            if k == 10 {
                tick += 500;
            }
            csv += &format!("0.01,0.02,1.0,0.1,0.2,0.3,{tick}\n");
            if k == 5 {
                csv += &format!("0.01,0.02,1.0,0.1,0.2,0.3,{tick}\n");
                csv += &format!("0.01,0.02,1.0,0.1,0.2,0.3,{}\n", tick - 10);
            }
            tick += 10;
        }
        let span = tick - 10 - 1000;
        let (c, t) = write("imu_bad.csv", &csv, span);
        let log = read(&c, &t).unwrap();
        assert_eq!(log.samples.len(), 19);
        assert_eq!(log.skipped.len(), 3, "{:?}", log.skipped);
        assert!(log.skipped[0].starts_with("line 1:"));
        assert!(log.skipped[1].starts_with("line 8:") && log.skipped[2].starts_with("line 9:"));
        assert_eq!(log.gaps.len(), 1, "{:?}", log.gaps);
        assert!(log.gaps[0].contains("0.510 s"), "{:?}", log.gaps);
        let s = &log.samples[0];
        assert!(
            (s.dv.z - G0 * 0.01).abs() < 1e-9
                && (s.dtheta.x - 0.1f64.to_radians() * 0.01).abs() < 1e-12
        );
    }

    /// Four rows at an axis' largest value are a saturation, named by line; two are not.
    #[test]
    fn clipped_samples_are_named() {
        let csv: String = (0..20)
            .map(|k| {
                let ax = if (5..9).contains(&k) {
                    4.0
                } else if k == 15 || k == 16 {
                    -2.0
                } else {
                    0.1
                };
                let gz = if k == 12 || k == 13 { 250.0 } else { 0.3 };
                format!("{ax},0.02,1.0,0.1,0.2,{gz},{}\n", 1000 + 10 * k)
            })
            .collect();
        let (c, t) = write("imu_clip.csv", &csv, 190);
        let log = read(&c, &t).unwrap();
        assert_eq!(log.saturated.len(), 1, "{:?}", log.saturated);
        assert!(
            log.saturated[0].starts_with("lines 6–9: ax at ±4"),
            "{:?}",
            log.saturated
        );
    }

    /// Accelerations in m/s² where g is expected, and ticks that do not span the tags, are
    /// errors that say what to do.
    #[test]
    fn wrong_units_and_foreign_tags_are_refused() {
        let csv: String = (0..10)
            .map(|k| format!("0.1,0.2,9.8,0.1,0.2,0.3,{}\n", 1000 + 10 * k))
            .collect();
        let (c, t) = write("imu_ms2.csv", &csv, 90);
        let e = read(&c, &t).unwrap_err().to_string();
        assert!(e.contains("imu_ms2.csv") && e.contains("not in g"), "{e}");
        let csv = csv.replace(",9.8,", ",1.0,");
        let (c, t) = write("imu_tags.csv", &csv, 200);
        let e = read(&c, &t).unwrap_err().to_string();
        assert!(e.contains("do not belong together"), "{e}");
        let (c, _) = write("imu_notag.csv", &csv, 90);
        let e = read(&c, &c).unwrap_err().to_string();
        assert!(e.contains("not an RTKLIB time-tag file"), "{e}");
    }
}
