//! Exposure times: RINEX flag-5 events (receiver time, corrected by the receiver clock seen in
//! the trajectory), DJI `Timestamp.MRK`, or a CSV of times in GPST or UTC.
//!
//! Enters: an observation file with its trajectory, an MRK file or a CSV. Leaves:
//! [`ExposureEvent`]s in GPST (with the MRK's own position and offsets when given), sorting
//! and duplicate checks, and the test for UTC times declared as GPST.

use gnss::error::{Error, Result};
use gnss::frame::{Ecef, Geodetic};
use gnss::rinex::ObsFile;
use gnss::time::checked_week_tow;
use gnss::trajectory::Trajectory;
use hifitime::{Duration, Epoch, TimeScale};
use std::path::Path;

/// What a DJI MRK line adds to its time.
#[derive(Clone, Debug, PartialEq)]
pub struct MrkInfo {
    /// Antenna → camera offset north, east, up (metres; the file's V is positive down).
    pub offset_neu: [f64; 3],
    /// The drone's own position at the exposure.
    pub position: Geodetic,
    /// Its sigmas north, east, vertical (m).
    pub sigma: [f64; 3],
    /// 50 fixed, 34 float, 16 single, 0 none.
    pub quality: u8,
}

/// One exposure time.
#[derive(Clone, Debug)]
pub struct ExposureEvent {
    /// Name: `E0001`-style for RINEX events ([`generic`]), `DJI_NNNN` from an
    /// MRK index ([`dji`]), a CSV's `id` column; replaced by the photo's file
    /// name or a names file's line by [`super::names`].
    pub id: String,
    /// GPST.
    pub time: Epoch,
    /// Line in the source file (0 when not applicable).
    pub line: usize,
    /// What a DJI MRK line adds (None for other sources).
    pub mrk: Option<MrkInfo>,
}

/// Time system of a CSV of times.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeSystem {
    /// GPS time.
    Gpst,
    /// UTC (converted with the leap seconds).
    Utc,
}

/// Flag-5 events of a rover file. Event tags are in receiver time; the trajectory's epochs are
/// in true GPST (tag − clock offset), so the offset is read off the pairs of observation tags
/// and trajectory times and removed from each event. Returns the events and the largest
/// correction applied (s).
pub fn from_rinex(obs: &ObsFile, traj: &Trajectory) -> (Vec<ExposureEvent>, f64) {
    // Clock offset samples (tag, offset) where a trajectory epoch lies within 5 ms of a tag.
    let mut samples: Vec<(Epoch, f64)> = Vec::new();
    let tags: Vec<Epoch> = obs.epochs.iter().map(|e| e.time).collect();
    for p in &traj.epochs {
        let i = tags.partition_point(|t| *t < p.time);
        for j in [i.wrapping_sub(1), i] {
            if let Some(t) = tags.get(j) {
                let d = (*t - p.time).to_seconds();
                if d.abs() < 0.005 {
                    samples.push((*t, d));
                }
            }
        }
    }
    samples.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap_or(std::cmp::Ordering::Equal));
    let offset_at = |t: Epoch| -> f64 {
        if samples.is_empty() {
            return 0.0;
        }
        let i = samples.partition_point(|s| s.0 <= t);
        if i == 0 {
            return samples[0].1;
        }
        if i >= samples.len() {
            return samples[samples.len() - 1].1;
        }
        let (a, b) = (samples[i - 1], samples[i]);
        let f = (t - a.0).to_seconds() / (b.0 - a.0).to_seconds().max(1e-9);
        a.1 + (b.1 - a.1) * f
    };
    let mut max_corr: f64 = 0.0;
    let events = obs
        .exposure_events()
        .enumerate()
        .filter_map(|(k, e)| {
            let t = e.time?;
            let c = offset_at(t);
            max_corr = max_corr.max(c.abs());
            Some(ExposureEvent {
                id: generic(k),
                time: t - Duration::from_seconds(c),
                line: e.line,
                mrk: None,
            })
        })
        .collect();
    (events, max_corr)
}

fn num_before_comma(s: &str) -> Option<f64> {
    s.split(',').next()?.trim().parse().ok()
}

/// Read a DJI `Timestamp.MRK`. Each exposure is named after the photograph DJI writes for
/// its index (`DJI_0001` for index 1).
pub fn read_mrk(path: &Path) -> Result<Vec<ExposureEvent>> {
    let text = std::fs::read_to_string(path).map_err(Error::io(path))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let bad = |what: &str| Error::parse(path, i + 1, what);
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() < 11 {
            return Err(bad("an MRK line has 11 tab-separated fields (index, seconds of week, [week], N, E, V, lat, lon, height, sigmas, quality)"));
        }
        let tow: f64 = f[1]
            .trim()
            .parse()
            .map_err(|_| bad("column 2: unreadable GPS seconds of week"))?;
        let week: f64 = f[2]
            .trim()
            .trim_matches(['[', ']'])
            .parse()
            .map_err(|_| bad("column 3: unreadable [week]"))?;
        let time = checked_week_tow(week, tow).map_err(|e| bad(&format!("columns 2–3: {e}")))?;
        let (n, e, v) = (
            num_before_comma(f[3]),
            num_before_comma(f[4]),
            num_before_comma(f[5]),
        );
        let (lat, lon, h) = (
            num_before_comma(f[6]),
            num_before_comma(f[7]),
            num_before_comma(f[8]),
        );
        let sig: Vec<f64> = f[9]
            .split(',')
            .filter_map(|x| x.trim().parse().ok())
            .collect();
        let q = num_before_comma(f[10]).unwrap_or(0.0) as u8;
        let (Some(n), Some(e), Some(v), Some(lat), Some(lon), Some(h)) = (n, e, v, lat, lon, h)
        else {
            return Err(bad("columns 4–9: unreadable offsets or position"));
        };
        if sig.len() != 3 {
            return Err(bad("column 10: three sigmas expected (N, E, V)"));
        }
        let sane = [n, e, v, h]
            .iter()
            .chain(&sig)
            .all(|x| x.is_finite() && x.abs() < 1e7)
            && (-90.0..=90.0).contains(&lat)
            && (-360.0..=360.0).contains(&lon);
        if !sane {
            return Err(bad(
                "columns 4–10: offsets, position or sigmas not finite or out of range",
            ));
        }
        let index = f[0].trim();
        out.push(ExposureEvent {
            id: index
                .parse::<u32>()
                .map(dji)
                .unwrap_or_else(|_| index.to_string()),
            time,
            line: i + 1,
            mrk: Some(MrkInfo {
                offset_neu: [n / 1000.0, e / 1000.0, -v / 1000.0],
                position: Geodetic::from_degrees(lat, lon, h),
                sigma: [sig[0], sig[1], sig[2]],
                quality: q,
            }),
        });
    }
    if out.is_empty() {
        return Err(Error::input(path, "no exposure in the MRK file"));
    }
    Ok(out)
}

/// Read a CSV of times: a header naming `id` (optional: without it the rows are named
/// `E0001` …) and either `week`,`tow` or `time` (ISO `YYYY-MM-DDTHH:MM:SS.sss`), in the
/// declared time system.
pub fn read_times_csv(path: &Path, system: TimeSystem) -> Result<Vec<ExposureEvent>> {
    let text = std::fs::read_to_string(path).map_err(Error::io(path))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
    let Some((_, head)) = lines.next() else {
        return Err(Error::input(path, "empty file"));
    };
    let cols: Vec<String> = head
        .split(',')
        .map(|c| c.trim().to_ascii_lowercase())
        .collect();
    let col = |name: &str| cols.iter().position(|c| c == name);
    let (id, week, tow, iso) = (col("id"), col("week"), col("tow"), col("time"));
    if !(week.is_some() && tow.is_some()) && iso.is_none() {
        return Err(Error::input(
            path,
            "the header must name `week` and `tow`, or `time` (ISO)",
        ));
    }
    let scale = match system {
        TimeSystem::Gpst => TimeScale::GPST,
        TimeSystem::Utc => TimeScale::UTC,
    };
    let mut out = Vec::new();
    for (i, line) in lines {
        let f: Vec<&str> = line.split(',').map(|x| x.trim()).collect();
        let bad = |what: &str| Error::parse(path, i + 1, what);
        let t = if let (Some(w), Some(s)) = (week, tow) {
            let col_num = |c: usize, what: &str| -> Result<f64> {
                f.get(c)
                    .and_then(|x| x.parse().ok())
                    .ok_or_else(|| bad(&format!("column {} ({what}): unreadable", c + 1)))
            };
            let (w, s) = (col_num(w, "week")?, col_num(s, "tow")?);
            let g = checked_week_tow(w, s).map_err(|e| bad(e.as_str()))?;
            if system == TimeSystem::Utc {
                calendar_as_utc(g)
            } else {
                g
            }
        } else {
            let s = f.get(iso.unwrap_or(0)).ok_or_else(|| bad("missing time"))?;
            parse_iso(s, scale)
                .ok_or_else(|| bad("unreadable time (YYYY-MM-DDTHH:MM:SS.sss expected)"))?
        };
        let name = id
            .and_then(|k| f.get(k))
            .map(|s| s.to_string())
            .unwrap_or_else(|| generic(out.len()));
        out.push(ExposureEvent {
            id: name,
            time: gnss::time::to_gpst(t),
            line: i + 1,
            mrk: None,
        });
    }
    Ok(out)
}

fn parse_iso(s: &str, scale: TimeScale) -> Option<Epoch> {
    let (date, time) = s.split_once(['T', ' '])?;
    let d: Vec<i64> = date
        .split('-')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let mut tp = time.trim_end_matches('Z').split(':');
    let (h, m, sec) = (
        tp.next()?.parse::<u8>().ok()?,
        tp.next()?.parse::<u8>().ok()?,
        tp.next()?.parse::<f64>().ok()?,
    );
    if d.len() != 3 || !gnss::time::file_year(d[0]) || !(0.0..61.0).contains(&sec) {
        return None;
    }
    let whole = sec.floor();
    let ns = ((sec - whole) * 1e9).round() as u32;
    Epoch::maybe_from_gregorian(
        i32::try_from(d[0]).ok()?,
        u8::try_from(d[1]).ok()?,
        u8::try_from(d[2]).ok()?,
        h,
        m,
        whole as u8,
        ns.min(999_999_999),
        scale,
    )
    .ok()
}

/// For MRK events: does the drone's own position match the trajectory better about 18 s
/// (the leap seconds) later? That is the signature of UTC times declared as GPST. Returns the
/// shift (s) when it does.
pub fn utc_as_gpst_shift(events: &[ExposureEvent], traj: &Trajectory) -> Option<f64> {
    let leap = gpst_minus_utc(events.first()?.time);
    let misfit = |shift: f64| -> Option<f64> {
        let mut s = 0.0;
        let mut n = 0;
        for e in events {
            let Some(m) = &e.mrk else { continue };
            let Ok(p) =
                traj.interpolate(e.time + Duration::from_seconds(shift), 10.0 * traj.interval)
            else {
                continue;
            };
            s += p.pos.distance(&m.position.to_ecef());
            n += 1;
        }
        (n >= 3).then(|| s / n as f64)
    };
    let (a, b) = (misfit(0.0)?, misfit(leap)?);
    (b < a / 3.0).then_some(leap)
}

/// GPST − UTC (the leap seconds since 1980) at `t`, seconds.
pub fn gpst_minus_utc(t: Epoch) -> f64 {
    (calendar_as_utc(t) - t).to_seconds()
}

/// The epoch whose UTC calendar reading is `t`'s GPST calendar reading (a GPST time that was
/// really UTC).
fn calendar_as_utc(t: Epoch) -> Epoch {
    let (y, mo, d, h, mi, se, ns) = t.to_gregorian(TimeScale::GPST);
    Epoch::from_gregorian(y, mo, d, h, mi, se, ns, TimeScale::UTC)
}

/// Sort by time; report unsorted input and refuse duplicate times (kept: the first).
pub fn sort_and_dedup(events: &mut Vec<ExposureEvent>) -> (bool, Vec<ExposureEvent>) {
    let unsorted = events.windows(2).any(|w| w[1].time < w[0].time);
    events.sort_by(|a, b| {
        a.time
            .partial_cmp(&b.time)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut dups = Vec::new();
    let mut kept: Vec<ExposureEvent> = Vec::with_capacity(events.len());
    for e in events.drain(..) {
        match kept.last() {
            Some(l) if (e.time - l.time).to_seconds().abs() < 1e-6 => dups.push(e),
            _ => kept.push(e),
        }
    }
    *events = kept;
    (unsorted, dups)
}

/// The position implied by an MRK line for its camera (for checks).
pub fn mrk_ecef(m: &MrkInfo) -> Ecef {
    m.position.to_ecef()
}

/// The name of the `k`-th exposure (0-based) when nothing better is known: `E0001`, `E0002` …
pub fn generic(k: usize) -> String {
    format!("E{:04}", k + 1)
}

/// The photograph a DJI drone writes for MRK index `index`: `DJI_0001` (zero-padded to 4 as
/// DJI does; wider indices keep all their digits).
pub fn dji(index: u32) -> String {
    format!("DJI_{index:04}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `text` written to `name` in the scratch folder `folder`.
    fn temp_file(folder: &str, name: &str, text: &str) -> std::path::PathBuf {
        testkit::scratch_file(&format!("{folder}/{name}"), text)
    }

    #[test]
    fn parses_a_dji_mrk_line() {
        let p = temp_file("mrk", "Timestamp.MRK", "1\t275295.301059\t[2024]\t   -26,N\t    19,E\t   191,V\t-36.41144502,Lat\t174.63075195,Lon\t170.415,Ellh\t1.492559, 1.368525, 3.180128\t16,Q\n");
        let ev = read_mrk(&p).unwrap();
        assert_eq!(ev.len(), 1);
        let e = &ev[0];
        assert_eq!(e.id, "DJI_0001", "named as DJI names the photo");
        let (w, tow) = gnss::time::week_tow(e.time);
        assert_eq!(w, 2024);
        assert!((tow - 275295.301059).abs() < 1e-8, "{tow}");
        let m = e.mrk.as_ref().unwrap();
        assert_eq!(m.offset_neu, [-0.026, 0.019, -0.191]);
        assert!((m.position.lat.to_degrees() + 36.41144502).abs() < 1e-12);
        assert!((m.position.lon.to_degrees() - 174.63075195).abs() < 1e-12);
        assert_eq!(m.position.h, 170.415);
        assert_eq!(m.sigma, [1.492559, 1.368525, 3.180128]);
        assert_eq!(m.quality, 16);
    }

    #[test]
    fn utc_times_are_shifted_by_the_leap_seconds() {
        let p = temp_file("csv", "t.csv", "id,time\nA,2024-06-12T09:00:00.5\n");
        let g = read_times_csv(&p, TimeSystem::Gpst).unwrap();
        let u = read_times_csv(&p, TimeSystem::Utc).unwrap();
        assert!(((u[0].time - g[0].time).to_seconds() - 18.0).abs() < 1e-9);
    }
}
