//! IMU logs in plain text: a CSV whose header states each column's quantity and unit
//! (`--imu-format csv`), and KF-GINS' text increments (`--imu-format kf-gins`).
//!
//! The CSV's header names, in any order (other columns are ignored, `#` lines are comments):
//! - time, GPST: `gpst_week` and `gpst_tow` (s), or `gpst_s` (s since 1980-01-06), or
//!   `gpst_tow` alone (the week then is the GNSS trajectory's, said in the notes);
//! - rotation: rates `gx_radps gy_radps gz_radps` or `gx_dps …` (°/s), or increments
//!   `dthx_rad dthy_rad dthz_rad` or `dthx_deg …`;
//! - acceleration: specific force `ax_mps2 ay_mps2 az_mps2` or `ax_g …`, or increments
//!   `dvx_mps dvy_mps dvz_mps`.
//!
//! Each row after the first covers the interval since the row before: increments are over it,
//! rates its mean. The axes are the IMU's (`--mount` turns them into the body's). KF-GINS' file
//! is whitespace-separated `tow dθx dθy dθz dvx dvy dvz` (s, rad, m/s), axes forward, right,
//! down, with the week taken from the GNSS trajectory.
//!
//! Nothing is guessed silently: a header without a time, rotation or acceleration names what
//! it accepts; times that repeat or go back are named by line and skipped, gaps named; a file
//! whose specific force is not near g in the stated unit, whose rates are beyond any vehicle's
//! in rad/s (°/s written as rad/s), or whose rate is not an IMU's (times in ms) is an error
//! saying which unit it looks like.

use crate::error::{Error, Result};
use crate::imu::ImuSample;
use crate::rtklib_imu::{gap, median, saturated, ImuLog};
use crate::spec::G0;
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;
use std::path::Path;

/// Largest plausible angular rate, rad/s (500 °/s: beyond it rad/s columns hold °/s).
const MAX_RATE: f64 = 500.0 * std::f64::consts::PI / 180.0;

/// How a file's times read.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Time {
    /// Week and second-of-week columns.
    WeekTow(usize, usize),
    /// Seconds since the GPS epoch.
    Seconds(usize),
    /// Second of week, the week that of the nearest GNSS epoch.
    Tow(usize),
}

/// The columns of a plain IMU file and their units.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Layout {
    time: Time,
    gyro: [usize; 3],
    /// Factor to rad (or rad/s); whether the columns are increments.
    gyro_unit: (f64, bool),
    accel: [usize; 3],
    /// Factor to m/s (or m/s²); whether the columns are increments.
    accel_unit: (f64, bool),
}

/// The layout a CSV header states.
fn layout(header: &str) -> std::result::Result<Layout, String> {
    let names: Vec<String> = header
        .trim_start_matches('\u{feff}')
        .split(',')
        .map(|s| s.trim().to_ascii_lowercase())
        .collect();
    let col = |n: &str| names.iter().position(|x| x == n);
    let time = match (col("gpst_week"), col("gpst_tow"), col("gpst_s")) {
        (Some(w), Some(t), _) => Time::WeekTow(w, t),
        (_, _, Some(s)) => Time::Seconds(s),
        (None, Some(t), None) => Time::Tow(t),
        _ => {
            return Err(
                "no time: name gpst_week and gpst_tow, or gpst_s, or gpst_tow (GPST seconds)"
                    .into(),
            )
        }
    };
    let triple = |pat: &str, unit: &str| -> Option<[usize; 3]> {
        let mut out = [0; 3];
        for (k, a) in ["x", "y", "z"].iter().enumerate() {
            out[k] = col(&pat.replace('?', a).replace('#', unit))?;
        }
        Some(out)
    };
    let deg = std::f64::consts::PI / 180.0;
    let gyro = [
        ("g?_#", "radps", 1.0, false),
        ("g?_#", "dps", deg, false),
        ("dth?_#", "rad", 1.0, true),
        ("dth?_#", "deg", deg, true),
    ]
    .into_iter()
    .find_map(|(p, u, f, inc)| Some((triple(p, u)?, (f, inc))))
    .ok_or("no rotation: name gx_radps gy_radps gz_radps (or _dps), or dthx_rad dthy_rad dthz_rad (or _deg)")?;
    let accel = [
        ("a?_#", "mps2", 1.0, false),
        ("a?_#", "g", G0, false),
        ("dv?_#", "mps", 1.0, true),
    ]
    .into_iter()
    .find_map(|(p, u, f, inc)| Some((triple(p, u)?, (f, inc))))
    .ok_or("no acceleration: name ax_mps2 ay_mps2 az_mps2 (or _g), or dvx_mps dvy_mps dvz_mps")?;
    Ok(Layout {
        time,
        gyro: gyro.0,
        gyro_unit: gyro.1,
        accel: accel.0,
        accel_unit: accel.1,
    })
}

/// One row: its line, time, rotation and acceleration columns as written.
type Row = (usize, Epoch, [f64; 6]);

/// The rows of numbered `lines`, split at commas (or whitespace when `comma` is false);
/// seconds of week in the week nearest `near`.
fn rows<'a>(
    lines: impl Iterator<Item = (usize, &'a str)>,
    comma: bool,
    (l, near): (&Layout, Epoch),
    skipped: &mut Vec<String>,
) -> Vec<Row> {
    let mut out: Vec<Row> = Vec::new();
    for (n, line) in lines {
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = if comma {
            line.split(',').map(str::trim).collect()
        } else {
            line.split_whitespace().collect()
        };
        let num = |i: usize| f.get(i)?.parse::<f64>().ok().filter(|x| x.is_finite());
        let time = match l.time {
            Time::WeekTow(w, t) => {
                num(w).and_then(|w| gnss::time::checked_week_tow(w, num(t)?).ok())
            }
            Time::Seconds(s) => {
                num(s).map(|s| gnss::time::from_week_tow(0, 0.0) + Duration::from_seconds(s))
            }
            Time::Tow(t) => num(t)
                .filter(|t| (0.0..604_800.0).contains(t))
                .map(|t| gnss::time::from_week_tow(week_near(near, t), t)),
        };
        let mut v = [0.0; 6];
        let ok = l
            .accel
            .iter()
            .chain(&l.gyro)
            .enumerate()
            .all(|(k, &i)| num(i).map(|x| v[k] = x).is_some());
        match time.filter(|_| ok) {
            Some(t) if out.last().is_none_or(|r| t > r.1) => out.push((n, t, v)),
            Some(_) => skipped.push(format!("line {n}: its time does not follow the row before")),
            None => skipped.push(format!(
                "line {n}: a time or value does not read as a number"
            )),
        }
    }
    out
}

/// Samples from the rows, with the checks of units and rate (see the module's text).
fn samples(rs: &[Row], l: &Layout, path: &Path) -> Result<ImuLog> {
    let bad = |m: String| Error::Input {
        path: path.to_path_buf(),
        message: m,
    };
    if rs.len() < 2 {
        return Err(bad("fewer than two IMU rows".into()));
    }
    let mut dts: Vec<f64> = rs
        .windows(2)
        .map(|w| (w[1].1 - w[0].1).to_seconds())
        .collect();
    let nominal = median(&mut dts);
    if !(1e-4..=0.1).contains(&nominal) {
        return Err(bad(format!(
            "rows {nominal} s apart ({:.3} Hz): not an IMU's rate (10 Hz to 10 kHz); are the times in seconds?",
            1.0 / nominal
        )));
    }
    let mut log = ImuLog {
        stretch: 1.0,
        ..ImuLog::default()
    };
    let (mut force, mut rate) = (Vec::new(), Vec::new());
    for w in rs.windows(2) {
        let dt = (w[1].1 - w[0].1).to_seconds();
        log.gaps.extend(gap(w[1].0, dt, nominal));
        let v = w[1].2;
        let per = |inc: bool| if inc { 1.0 } else { dt };
        let dv = Vector3::new(v[0], v[1], v[2]) * l.accel_unit.0 * per(l.accel_unit.1);
        let th = Vector3::new(v[3], v[4], v[5]) * l.gyro_unit.0 * per(l.gyro_unit.1);
        force.push(dv.norm() / dt);
        rate.push(th.norm() / dt);
        log.samples.push(ImuSample {
            time: w[1].1,
            dt,
            dtheta: th,
            dv,
        });
    }
    let f = median(&mut force);
    if !(0.5 * G0..=2.0 * G0).contains(&f) {
        let hint = if (0.5..=2.0).contains(&f) {
            "it looks like g: name the columns ax_g ay_g az_g"
        } else if (0.5 * G0..=2.0 * G0).contains(&(f / G0)) {
            "it looks like m/s² written as g: name the columns ax_mps2 ay_mps2 az_mps2"
        } else {
            "check the unit and, for increments, the interval"
        };
        return Err(bad(format!(
            "the specific force's median magnitude is {f:.3} m/s² in the stated unit, not near g (9.8): {hint}"
        )));
    }
    rate.sort_by(f64::total_cmp);
    let top = rate[(rate.len() * 999) / 1000];
    if top > MAX_RATE {
        return Err(bad(format!(
            "angular rates up to {top:.1} rad/s in the stated unit, beyond any vehicle's (500 °/s): the columns hold °/s? name them gx_dps … (or dthx_deg …)"
        )));
    }
    let lines: Vec<(usize, [f64; 6])> = rs.iter().map(|r| (r.0, r.2)).collect();
    log.saturated = saturated(&lines);
    Ok(log)
}

/// Read a plain CSV with a header (see the module's text); a file with `gpst_tow` alone is
/// put in the GPS week nearest `near` (the GNSS trajectory's start). Returns the log and what
/// was assumed.
pub fn read_csv(path: &Path, near: Epoch) -> Result<(ImuLog, Vec<String>)> {
    let text = read_text(path)?;
    let mut lines = text.lines().enumerate().map(|(n, l)| (n + 1, l));
    let (_, header) = lines
        .by_ref()
        .find(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'))
        .ok_or_else(|| Error::Input {
            path: path.to_path_buf(),
            message: "empty: no header line".into(),
        })?;
    let l = layout(header).map_err(|m| Error::Input {
        path: path.to_path_buf(),
        message: format!("header: {m}"),
    })?;
    let mut skipped = Vec::new();
    let rs = rows(lines, true, (&l, near), &mut skipped);
    let mut log = samples(&rs, &l, path)?;
    log.skipped = skipped;
    let notes = match l.time {
        Time::Tow(_) => vec![week_note(&log, "the IMU's")],
        _ => Vec::new(),
    };
    Ok((log, notes))
}

/// Read KF-GINS' text increments (`tow dθx dθy dθz dvx dvy dvz`; s, rad, m/s) in the GPS
/// week nearest `near` (the GNSS trajectory's start). Returns the log and what was assumed.
pub fn read_kf_gins(path: &Path, near: Epoch) -> Result<(ImuLog, Vec<String>)> {
    let text = read_text(path)?;
    let l = Layout {
        time: Time::Tow(0),
        gyro: [1, 2, 3],
        gyro_unit: (1.0, true),
        accel: [4, 5, 6],
        accel_unit: (1.0, true),
    };
    let mut skipped = Vec::new();
    let lines = text.lines().enumerate().map(|(n, l)| (n + 1, l));
    let rs = rows(lines, false, (&l, near), &mut skipped);
    let mut log = samples(&rs, &l, path)?;
    log.skipped = skipped;
    let notes = vec![week_note(&log, "KF-GINS'")];
    Ok((log, notes))
}

/// What was assumed of the week of a file holding seconds of week.
fn week_note(log: &ImuLog, whose: &str) -> String {
    let week = |s: Option<&ImuSample>| s.map_or(0, |s| gnss::time::week_tow(s.time).0);
    let (a, b) = (week(log.samples.first()), week(log.samples.last()));
    let weeks = if a == b {
        format!("GPS week {a}")
    } else {
        format!("GPS weeks {a}–{b}")
    };
    format!("{weeks} assumed for {whose} seconds of week (the GNSS trajectory's)")
}

fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|cause| Error::Io {
        path: path.to_path_buf(),
        cause,
    })
}

/// The GPS week of the GNSS epoch `near`, moved by one when a second of week `tow` lies more
/// than half a week from it.
pub fn week_near(near: Epoch, tow: f64) -> u32 {
    let (w, t) = gnss::time::week_tow(near);
    if tow - t > 302_400.0 {
        w.saturating_sub(1)
    } else if t - tow > 302_400.0 {
        w + 1
    } else {
        w
    }
}

#[cfg(test)]
mod tests;
