//! Satellite orbits and clocks: our own broadcast-ephemeris computation on records read from
//! RINEX navigation files (Keplerian systems and GLONASS), an ephemeris index with correct
//! selection, and precise orbits as an alternative source: any number of SP3 files (the
//! previous, current and next day cover a day's edges) merged per satellite, with clocks from
//! the SP3 files or from RINEX clock files (see [`precise`]).

pub mod clk;
pub mod glonass;
pub mod kepler;
pub mod precise;
pub mod sp3;
pub mod sp3_write;

pub use clk::ClockFile;
pub use glonass::GlonassEph;
pub use kepler::{GalMessage, KeplerEph, SatPosClock, C};
pub use precise::{relativistic_clock, ClockSource, MergeReport, PreciseOrbits, Unavailable};
pub use sp3::Sp3;
pub use sp3_write::sp3_text;

use crate::frame::Ecef;
use crate::rinex::nav::{Klobuchar, NavFile, NavKind, NavRecord};
use crate::sv::{Constellation, Sv};
use hifitime::Epoch;
use std::collections::BTreeMap;

/// One broadcast ephemeris of any system.
#[derive(Clone, Debug)]
pub enum Eph {
    /// GPS, Galileo, BeiDou or QZSS Keplerian elements.
    Kepler(KeplerEph),
    /// GLONASS state vector.
    Glonass(GlonassEph),
}

impl Eph {
    /// Reference time of the ephemeris (GPST).
    pub fn toe(&self) -> Epoch {
        match self {
            Eph::Kepler(k) => k.toe,
            Eph::Glonass(g) => g.toe,
        }
    }
    /// Whether the satellite is flagged healthy.
    pub fn healthy(&self) -> bool {
        match self {
            Eph::Kepler(k) => k.healthy(),
            Eph::Glonass(g) => g.healthy(),
        }
    }
    /// Whether the ephemeris may be used at `t` (inside its fit / validity window).
    pub fn valid_at(&self, t: Epoch) -> bool {
        let dt = (t - self.toe()).to_seconds();
        match self {
            Eph::Kepler(k) => -k.valid_before <= dt && dt <= k.valid_after,
            Eph::Glonass(_) => dt.abs() <= 1800.0,
        }
    }
    /// Position, velocity and clock at transmission time `t` (GPST).
    pub fn compute(&self, t: Epoch) -> SatPosClock {
        match self {
            Eph::Kepler(k) => k.compute(t),
            Eph::Glonass(g) => g.compute(t),
        }
    }
    /// Position and clock at transmission time `t` (GPST), as [`Self::compute`] gives
    /// them, without the velocity where it costs extra orbit evaluations.
    pub fn position_clock(&self, t: Epoch) -> (Ecef, f64) {
        match self {
            Eph::Kepler(k) => k.position_clock(t),
            Eph::Glonass(g) => {
                let pv = g.compute(t);
                (pv.pos, pv.clock)
            }
        }
    }
    /// Broadcast group delay (s) for a signal on `band` (0 for GLONASS).
    pub fn group_delay(&self, band: u8) -> f64 {
        match self {
            Eph::Kepler(k) => k.group_delay(band),
            Eph::Glonass(_) => 0.0,
        }
    }
    /// When the message was transmitted, if the record says so (Keplerian systems only).
    pub fn transmitted(&self) -> Option<Epoch> {
        match self {
            Eph::Kepler(k) => k.transmitted,
            Eph::Glonass(_) => None,
        }
    }
    fn preference(&self) -> u8 {
        match self {
            Eph::Kepler(KeplerEph {
                gal: Some(GalMessage::FNav),
                ..
            }) => 1,
            _ => 0,
        }
    }
}

/// What happened to the navigation records.
#[derive(Clone, Debug, Default)]
pub struct EphStats {
    /// Navigation records read.
    pub records: usize,
    /// Ephemerides flagged unhealthy (not used).
    pub unhealthy: usize,
    /// Records of messages ppkat does not use (SBAS, CNAV …).
    pub unused: usize,
    /// Records that could not be read or were incomplete (file, line, why).
    pub skipped: Vec<String>,
    /// Healthy ephemerides passed over for a later upload's (see [`supersedes`]): files that
    /// span an upload hold both (0.4–2 m apart on ESBC's day, up to 11 m on BELL–EBRE's).
    pub superseded: usize,
}

/// All broadcast ephemerides, indexed per satellite and sorted by toe.
#[derive(Clone, Debug, Default)]
pub struct Ephemerides {
    by_sv: BTreeMap<Sv, Vec<Eph>>,
    /// GPS Klobuchar ionosphere parameters, from the first file that has them.
    pub gps_iono: Option<Klobuchar>,
    /// BeiDou Klobuchar ionosphere parameters, from the first file that has them.
    pub bds_iono: Option<Klobuchar>,
    /// What happened to the records.
    pub stats: EphStats,
}

/// Why a broadcast record cannot be a satellite's orbit and clock, if it cannot: a value that
/// is not a finite number (a raw log's NaN, a corrupted file), or, for Keplerian elements, an
/// orbit no navigation satellite flies or clock terms seconds off. Such a record would put NaN
/// or nonsense into every solution it touched; it is counted as skipped instead.
fn implausible(r: &NavRecord) -> Option<String> {
    if !r.clock.iter().chain(&r.orbit).all(|v| v.is_finite()) {
        return Some("a value is not a finite number".into());
    }
    let o = &r.orbit;
    match r.kind {
        NavKind::Kepler if o.len() >= 24 => {
            // √A of MEO, IGSO and GEO navigation satellites: 5,100–6,500 √m.
            if !(3000.0..=8000.0).contains(&o[7]) {
                return Some(format!(
                    "√A = {} √m is no navigation satellite's orbit",
                    o[7]
                ));
            }
            if !(0.0..0.5).contains(&o[5]) {
                return Some(format!(
                    "eccentricity {} is no navigation satellite's",
                    o[5]
                ));
            }
            let [a0, a1, a2] = r.clock;
            if a0.abs() > 1.0 || a1.abs() > 1e-3 || a2.abs() > 1e-6 || o[22].abs() > 1e-3 {
                return Some("clock terms or group delay seconds off".into());
            }
            None
        }
        NavKind::Glonass if o.len() >= 9 => {
            let km = (o[0] * o[0] + o[4] * o[4] + o[8] * o[8]).sqrt();
            if !(10_000.0..=50_000.0).contains(&km) || r.clock[0].abs() > 1.0 {
                return Some(format!(
                    "position {km:.0} km from the geocentre or clock seconds off"
                ));
            }
            None
        }
        _ => None,
    }
}

/// Whether ephemeris `newer` makes `older` stale: the same message, transmitted later, and
/// either for the same or an earlier toe (a re-upload of the span) or a set of a new upload
/// (GPS marks the first sets after an upload with a toe off the hour grid,
/// BELL–EBRE's hh:59:44) less than two hours after `older`'s toe, i.e. not its regular
/// successor: such a set's predictions are fresher than any sent before it.
pub fn supersedes(newer: &Eph, older: &Eph) -> bool {
    let (Some(tn), Some(to)) = (newer.transmitted(), older.transmitted()) else {
        return false;
    };
    let ahead = (newer.toe() - older.toe()).to_seconds();
    tn > to
        && newer.preference() == older.preference()
        && (ahead <= 0.0 || (opens_upload(newer) && ahead < REGULAR_SPACING_S - 1.0))
}

/// The spacing of successive GPS ephemerides of one upload, seconds.
const REGULAR_SPACING_S: f64 = 7200.0;

/// A GPS ephemeris whose toe is off the hour grid: one of the first sets after an upload.
fn opens_upload(e: &Eph) -> bool {
    match e {
        Eph::Kepler(k) if k.sys == Constellation::Gps => {
            crate::time::week_tow(k.toe).1.rem_euclid(3600.0) > 0.5
        }
        _ => false,
    }
}

impl Ephemerides {
    /// Index the ephemerides of navigation files (one satellite's records sorted by toe).
    pub fn from_nav(navs: &[NavFile]) -> Self {
        let mut e = Ephemerides::default();
        for nav in navs {
            e.gps_iono = e.gps_iono.or(nav.gps_iono);
            e.bds_iono = e.bds_iono.or(nav.bds_iono);
            for (line, what) in &nav.skipped {
                e.stats
                    .skipped
                    .push(format!("{}:{line}: {what}", nav.path.display()));
            }
            for r in &nav.records {
                e.stats.records += 1;
                if matches!(r.kind, NavKind::Sbas | NavKind::Other) {
                    e.stats.unused += 1;
                    continue;
                }
                // Checked before the record is read: a NaN toe panics in the time library.
                let eph = match implausible(r) {
                    Some(why) => Err(why),
                    None => match r.kind {
                        NavKind::Kepler => KeplerEph::from_record(r).map(Eph::Kepler),
                        _ => GlonassEph::from_record(r).map(Eph::Glonass),
                    }
                    .ok_or_else(|| "incomplete".to_string()),
                };
                let eph = match eph {
                    Ok(eph) => eph,
                    Err(why) => {
                        e.stats.skipped.push(format!(
                            "{}:{}: record of {} not used: {why}",
                            nav.path.display(),
                            r.line,
                            r.sv
                        ));
                        continue;
                    }
                };
                if !eph.healthy() {
                    e.stats.unhealthy += 1;
                }
                e.by_sv.entry(r.sv).or_default().push(eph);
            }
        }
        for v in e.by_sv.values_mut() {
            v.sort_by(|a, b| {
                a.toe()
                    .partial_cmp(&b.toe())
                    .unwrap_or(std::cmp::Ordering::Equal)
                    .then(a.preference().cmp(&b.preference()))
                    .then(a.transmitted().cmp(&b.transmitted()))
            });
            // Of records with the same toe and message (files repeat them; a new upload may
            // reuse a toe) keep the last transmitted; with equal or unknown transmission
            // times the first in file order, as before.
            v.dedup_by(|later, kept| {
                let same = later.toe() == kept.toe() && later.preference() == kept.preference();
                if same && later.transmitted() > kept.transmitted() {
                    std::mem::swap(later, kept);
                }
                same
            });
        }
        e.stats.superseded = e.passed_over();
        e
    }

    /// How many healthy ephemerides are not the one [`Self::select`] gives at their own toe:
    /// superseded by a fresher upload.
    fn passed_over(&self) -> usize {
        self.by_sv
            .iter()
            .flat_map(|(sv, v)| v.iter().map(move |e| (*sv, e)))
            .filter(|(sv, e)| {
                e.healthy()
                    && self
                        .select(*sv, e.toe())
                        .is_some_and(|s| !std::ptr::eq(s, *e) && s.preference() == e.preference())
            })
            .count()
    }

    /// Satellites with at least one ephemeris.
    pub fn satellites(&self) -> impl Iterator<Item = &Sv> {
        self.by_sv.keys()
    }

    /// All ephemerides of a satellite.
    pub fn of(&self, sv: Sv) -> &[Eph] {
        self.by_sv.get(&sv).map(|v| v.as_slice()).unwrap_or(&[])
    }

    /// The ephemeris to use at `t`: healthy, within its validity, not superseded (see
    /// [`supersedes`]), toe nearest to `t`; for Galileo I/NAV is preferred over F/NAV.
    /// Daily merged files hold sets of an older upload beside the fresh ones (BELL–EBRE
    /// 2002-01-30: PRN 15's 14:00 set, sent at 12:00, lies 9 m from the 13:59:44 set of the
    /// upload sent at 12:05): chosen by toe alone, the stale set puts a satellite metres off
    /// for an hour — centimetres in double differences at 100 km.
    pub fn select(&self, sv: Sv, t: Epoch) -> Option<&Eph> {
        let v = self.by_sv.get(&sv)?;
        let i = v.partition_point(|e| e.toe() <= t);
        let lo = i.saturating_sub(4);
        let hi = (i + 4).min(v.len());
        let usable = || v[lo..hi].iter().filter(|e| e.healthy() && e.valid_at(t));
        usable()
            .filter(|e| !usable().any(|o| supersedes(o, e)))
            .min_by(|a, b| {
                a.preference()
                    .cmp(&b.preference())
                    .then((t - a.toe()).abs().cmp(&(t - b.toe()).abs()))
            })
    }

    /// First and last toe over all satellites.
    pub fn span(&self) -> Option<(Epoch, Epoch)> {
        let mut it = self.by_sv.values().flatten().map(|e| e.toe());
        let first = it.next()?;
        Some(it.fold((first, first), |(a, b), t| (a.min(t), b.max(t))))
    }

    /// GLONASS frequency channel broadcast for a slot.
    pub fn glonass_channel(&self, slot: u8) -> Option<i8> {
        let sv = Sv::new(Constellation::Glonass, slot);
        self.by_sv.get(&sv)?.iter().find_map(|e| match e {
            Eph::Glonass(g) => Some(g.channel),
            _ => None,
        })
    }
}

/// Where satellite positions and clocks come from.
#[derive(Clone, Debug)]
pub struct Orbits {
    /// Broadcast ephemerides (their group delays apply to precise orbits too; they may be
    /// empty when precise orbits are given).
    pub broadcast: Ephemerides,
    /// Precise orbits and clocks, used instead of the broadcast ones when given: a satellite
    /// without a precise position or clock at a time is not used then, even if it has a
    /// broadcast ephemeris.
    pub precise: Option<PreciseOrbits>,
}

/// A satellite at its transmission time, ready for a range model.
#[derive(Clone, Copy, Debug)]
pub struct SatInfo {
    /// Position, ECEF at transmission time, metres.
    pub pos: Ecef,
    /// Clock offset in seconds, relativistic correction included, group delay not applied.
    pub clock: f64,
    /// Group delay (s) to subtract from the clock for the band asked.
    pub group_delay: f64,
}

impl Orbits {
    /// Orbits from broadcast ephemerides only.
    pub fn broadcast(e: Ephemerides) -> Self {
        Orbits {
            broadcast: e,
            precise: None,
        }
    }

    /// Position and clock of `sv` at GPST transmission time `t`, with the group delay of `band`.
    pub fn sat(&self, sv: Sv, t: Epoch, band: u8) -> Option<SatInfo> {
        self.sat_or_why(sv, t, band).ok()
    }

    /// As [`Orbits::sat`], or why the satellite cannot be used at `t`. With precise orbits the
    /// broadcast group delay of `band` is applied when a navigation file gives it (0 otherwise).
    pub fn sat_or_why(&self, sv: Sv, t: Epoch, band: u8) -> Result<SatInfo, Unavailable> {
        let eph = self.broadcast.select(sv, t);
        if let Some(p) = &self.precise {
            let pv = p.compute(sv, t)?;
            return Ok(SatInfo {
                pos: pv.pos,
                clock: pv.clock,
                group_delay: eph.map(|e| e.group_delay(band)).unwrap_or(0.0),
            });
        }
        let eph = eph.ok_or(Unavailable::NoOrbit)?;
        let (pos, clock) = eph.position_clock(t);
        Ok(SatInfo {
            pos,
            clock,
            group_delay: eph.group_delay(band),
        })
    }
}
