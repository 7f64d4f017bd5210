//! The items of a raw log in file order: measurement epochs, camera events (time marks),
//! ephemerides and ionosphere parameters, as the format readers ([`super::log_items`],
//! [`super::sbf_items`]) hand them out, and the epoch-order bookkeeping they share. The
//! reading itself is [`super::read_items`]'s.

use super::ubx::Tm2;
use super::ubx_obs::RawEpoch;
use super::RawStats;
use crate::rinex::nav::{Klobuchar, NavFile, NavRecord};
use hifitime::Epoch;
use std::path::Path;

/// Which edge of a time-mark pulse.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    /// Rising edge.
    Rising,
    /// Falling edge.
    Falling,
}

/// One time-mark edge of TIM-TM2: a camera event.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventMark {
    /// GPS week.
    pub week: u16,
    /// GPS time of week, seconds (converted from UTC when the receiver reported UTC).
    pub tow: f64,
    /// The edge.
    pub edge: Edge,
    /// The receiver's edge counter.
    pub count: u16,
    /// The receiver marked the time valid.
    pub valid: bool,
    /// The edge becomes a flag-5 event record: UBX falling edges (as convbin writes them),
    /// every SBF ExtEvent (the receiver times only the edge it is set to).
    pub record: bool,
}

/// One item of a raw log, in file order.
#[derive(Clone, Debug)]
pub enum RawItem {
    /// A measurement epoch.
    Epoch(RawEpoch),
    /// A time-mark edge.
    Event(EventMark),
    /// An ephemeris decoded from navigation subframes (each distinct one once).
    Ephemeris(NavRecord),
    /// GPS Klobuchar parameters and leap seconds (GPS − UTC) from the navigation message.
    GpsIono(Klobuchar, i32),
    /// BeiDou Klobuchar parameters from the navigation message.
    BdsIono(Klobuchar),
    /// The receiver's own position fix (NMEA GGA).
    Fix(super::nmea::NmeaFix),
}

/// The navigation data of a log, gathered from its items.
#[derive(Clone, Debug, Default)]
pub struct LogNav {
    /// Ephemerides in the order they were decoded.
    pub records: Vec<NavRecord>,
    /// The last GPS Klobuchar parameters broadcast.
    pub gps_iono: Option<Klobuchar>,
    /// The last leap seconds broadcast.
    pub leap_seconds: Option<i32>,
    /// The last BeiDou Klobuchar parameters broadcast.
    pub bds_iono: Option<Klobuchar>,
}

impl LogNav {
    /// Keep what `it` holds of navigation data.
    pub fn add(&mut self, it: &RawItem) {
        match it {
            RawItem::Ephemeris(r) => self.records.push(r.clone()),
            RawItem::GpsIono(k, leap) => {
                self.gps_iono = Some(*k);
                self.leap_seconds = Some(*leap);
            }
            RawItem::BdsIono(k) => self.bds_iono = Some(*k),
            _ => {}
        }
    }

    /// As a navigation file read from `path` (the log), for [`crate::orbit::Ephemerides`].
    pub fn to_nav_file(&self, path: &Path) -> NavFile {
        NavFile {
            path: path.to_path_buf(),
            version: 3.04,
            records: self.records.clone(),
            gps_iono: self.gps_iono,
            bds_iono: self.bds_iono,
            leap_seconds: self.leap_seconds,
            skipped: Vec::new(),
            skipped_unlisted: 0,
        }
    }
}

/// GPST epoch of a week and time of week. Out-of-range inputs from a hostile log (a week of
/// 65535, a time of week of 10¹¹ s or ±inf; NaN counts as 0) saturate at the ends of the GPST
/// nanosecond range instead of overflowing.
pub fn gpst(week: u16, tow: f64) -> Epoch {
    Epoch::from_gpst_nanoseconds(gpst_ns(week, tow))
}

/// The GPST nanoseconds [`gpst`] gives (for ordering without the time library).
pub fn gpst_ns(week: u16, tow: f64) -> u64 {
    let ticks = (tow * 1e7).round() as i64; // 100 ns, as RINEX prints
    let ns = i128::from(week) * 604_800_000_000_000 + i128::from(ticks) * 100;
    ns.clamp(0, i128::from(u64::MAX)) as u64
}

/// Hands decoded epochs on in file order, counting them and the time jumps (an epoch not
/// after the one before it); one for every log format.
#[derive(Default)]
pub(crate) struct EpochOrder {
    last: Option<(u16, f64)>,
}

impl EpochOrder {
    /// Count `e` (and a time jump if it is not after the last epoch) and hand it to `f`.
    pub(crate) fn emit(&mut self, e: RawEpoch, st: &mut RawStats, f: &mut dyn FnMut(RawItem)) {
        let t = (e.week, e.tow);
        if self.last.is_some_and(|l| l >= t) {
            st.time_jumps += 1;
        }
        self.last = Some(t);
        st.epochs += 1;
        f(RawItem::Epoch(e));
    }
}

/// The new edges of a TIM-TM2 message as events in GPST.
pub(crate) fn marks(t: &Tm2, leap: i8) -> Vec<EventMark> {
    let mut v = Vec::new();
    for (new, edge, (week, tow)) in [
        (t.new_rising, Edge::Rising, t.rising),
        (t.new_falling, Edge::Falling, t.falling),
    ] {
        if !new {
            continue;
        }
        let mut tow = tow;
        let mut week = week;
        if t.time_base == 2 {
            tow += leap as f64;
            if tow >= 604_800.0 {
                tow -= 604_800.0;
                week = week.saturating_add(1);
            }
        }
        v.push(EventMark {
            week,
            tow,
            edge,
            count: t.count,
            valid: t.time_valid,
            record: edge == Edge::Falling,
        });
    }
    v
}
