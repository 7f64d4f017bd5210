//! Time helpers on `hifitime`: every epoch inside ppkat is a GPST [`Epoch`].

use hifitime::{Duration, Epoch, TimeScale};

/// Seconds in a GPS week.
pub const WEEK_SECONDS: f64 = 604_800.0;
/// BeiDou time is GPST − 14 s.
pub const BDT_MINUS_GPST_S: f64 = -14.0;

/// A GPST epoch from calendar fields; `nanos` is the sub-second part in nanoseconds. Panics
/// when they are no date and time: for fields from a file, use [`try_gpst`].
pub fn gpst(year: i32, month: u8, day: u8, hour: u8, minute: u8, second: u8, nanos: u32) -> Epoch {
    try_gpst(year, month, day, hour, minute, second, nanos).expect("a valid GPST date and time")
}

/// A GPST epoch from calendar fields read from a file: `None` when they are not a date and
/// time (30 February, second 60 — GPST has no leap seconds), where [`gpst`] would panic.
pub fn try_gpst(
    year: i32,
    month: u8,
    day: u8,
    hour: u8,
    minute: u8,
    second: u8,
    nanos: u32,
) -> Option<Epoch> {
    let e = Epoch::maybe_from_gregorian(
        year,
        month,
        day,
        hour,
        minute,
        second,
        nanos,
        TimeScale::GPST,
    );
    e.ok().filter(|_| second < 60)
}

/// Whether `year` is one a GNSS file can carry (1980–2200). Checked before the calendar:
/// hifitime walks a year of millions one year at a time (20 ms a date).
pub fn file_year(year: i64) -> bool {
    (1980..=2200).contains(&year)
}

/// Express any epoch in GPST (the scale used everywhere inside).
pub fn to_gpst(e: Epoch) -> Epoch {
    e.to_time_scale(TimeScale::GPST)
}

/// GPS week and seconds of week of an epoch.
pub fn week_tow(e: Epoch) -> (u32, f64) {
    let s = to_gpst(e).to_gpst_seconds();
    let week = (s / WEEK_SECONDS).floor();
    (week as u32, s - week * WEEK_SECONDS)
}

/// The week of seconds-of-week `sow` (an ephemeris' toe) given with `week`, the week of
/// `sent_sow` (its transmission, within half a week of it): `week` + 1 when `sow` lies early
/// in the next week, − 1 when it lies late in the previous one.
pub fn week_of(week: i64, sow: f64, sent_sow: f64) -> i64 {
    if sow < sent_sow - WEEK_SECONDS / 2.0 {
        week + 1
    } else if sow > sent_sow + WEEK_SECONDS / 2.0 {
        week - 1
    } else {
        week
    }
}

/// The GPST epoch of a GPS week and seconds of week.
pub fn from_week_tow(week: u32, tow: f64) -> Epoch {
    Epoch::from_gpst_seconds(week as f64 * WEEK_SECONDS) + Duration::from_seconds(tow)
}

/// The GPST epoch of a GPS week and seconds of week read from a file, checked first: the
/// week a whole number from 0 to 9999, the seconds finite and within the week (0 to
/// 604800). `Err` says which is wrong, for the caller to add file, line and column.
pub fn checked_week_tow(week: f64, tow: f64) -> Result<Epoch, String> {
    if !(week.is_finite() && week.fract() == 0.0 && (0.0..10_000.0).contains(&week)) {
        return Err(format!(
            "GPS week {week} is not a whole number from 0 to 9999"
        ));
    }
    if !(tow.is_finite() && (0.0..=WEEK_SECONDS).contains(&tow)) {
        return Err(format!(
            "seconds of week {tow} are not a number from 0 to 604800"
        ));
    }
    Ok(from_week_tow(week as u32, tow))
}

/// `a − b` in seconds.
pub fn diff_s(a: Epoch, b: Epoch) -> f64 {
    (a - b).to_seconds()
}

/// Median spacing of consecutive times in seconds, pairs that do not increase left out;
/// 1 when there is no such pair.
pub fn median_spacing(times: impl IntoIterator<Item = Epoch>) -> f64 {
    let mut d: Vec<f64> = Vec::new();
    let mut prev: Option<Epoch> = None;
    for t in times {
        if let Some(p) = prev {
            let x = (t - p).to_seconds();
            if x > 0.0 {
                d.push(x);
            }
        }
        prev = Some(t);
    }
    d.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    d.get(d.len() / 2).copied().unwrap_or(1.0)
}

/// Calendar string `yyyy/mm/dd hh:mm:ss.sss` in GPST, as RTKLIB writes it.
pub fn format_ymdhms(e: Epoch) -> String {
    // Round to the millisecond first so that 59.9996 s does not print as 60.000.
    let e = to_gpst(e);
    let ms = (e.to_gpst_seconds() * 1000.0).round() / 1000.0;
    let r = Epoch::from_gpst_seconds(ms);
    let (y, mo, d, h, mi, s, ns) = r.to_gregorian(TimeScale::GPST);
    let ms_part = ((ns as f64) / 1.0e6).round() as u32;
    let (s, ms_part) = if ms_part >= 1000 {
        (s + 1, 0)
    } else {
        (s, ms_part)
    };
    format!("{y:04}/{mo:02}/{d:02} {h:02}:{mi:02}:{s:02}.{ms_part:03}")
}

/// Calendar string `yyyy/mm/dd hh:mm:ss.ssssss` in GPST (microseconds: a trajectory at 60 m/s
/// moves 3 cm in the half millisecond a 3-decimal time would hide).
pub fn format_ymdhms_us(e: Epoch) -> String {
    let e = to_gpst(e);
    let us = (e.to_gpst_seconds() * 1e6).round() / 1e6;
    let whole = us.floor();
    let (y, mo, d, h, mi, s, _) = Epoch::from_gpst_seconds(whole).to_gregorian(TimeScale::GPST);
    let frac = ((us - whole) * 1e6).round() as u32;
    format!(
        "{y:04}/{mo:02}/{d:02} {h:02}:{mi:02}:{s:02}.{:06}",
        frac.min(999_999)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn week_and_tow_round_trip() {
        let e = gpst(2020, 6, 25, 12, 0, 0, 0);
        let (w, tow) = week_tow(e);
        assert_eq!(w, 2111);
        assert!((tow - (4.0 * 86400.0 + 12.0 * 3600.0)).abs() < 1e-9);
        assert_eq!(from_week_tow(w, tow), e);
        assert_eq!(format_ymdhms(e), "2020/06/25 12:00:00.000");
        let f = e + hifitime::Duration::from_seconds(0.000_581);
        assert_eq!(format_ymdhms_us(f), "2020/06/25 12:00:00.000581");
    }
}
