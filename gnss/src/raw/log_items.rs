//! The items of a UBX or RTCM 3 log, either alone or mixed with each other and with NMEA in
//! one stream ([`super::mixed`]), as a u-blox base logs RXM-RAWX beside the RTCM 3 it sends.
//!
//! What enters: the path of a log and the user's time hint. What leaves: each [`RawItem`]
//! handed to a callback, and the [`RawStats`] of everything read and dropped.
//!
//! The log is surveyed once first (`Survey`): whether it has RXM-RAWX with a known week,
//! MSM observations, and which ephemeris messages with which weeks. Then:
//! - observations come from RXM-RAWX when the log has them (richer: half-cycle flags, C/N0,
//!   lock times), else from the MSMs; the other kind is counted as not used, naming why;
//! - the time of MSM observations comes from the RAWX time, else from a `--date-hint` or the
//!   consensus of the ephemerides ([`super::rtcm_week`]): a date hint wins over a weak
//!   (GPS-only) consensus, with a warning when they differ; a contradiction with a strong one
//!   is an error naming both; a GPS-only consensus takes its 1024-week cycle from a year hint,
//!   else from the stale Galileo/BeiDou ephemerides' whole weeks, else the latest cycle not
//!   after today (the system clock: no log is from the future);
//! - ephemerides from RXM-SFRBX and from RTCM 1019/1020/1042/1044/1045/1046, each distinct one
//!   once; an RTCM ephemeris whose time of clock lies more than [`STALE`] from the log's time
//!   is stale (kept from an earlier day): counted, named and not used;
//! - the station from 1005/1006/1007/1008/1033; TIM-TM2 time marks; NMEA GGA as the
//!   receiver's own fixes ([`RawItem::Fix`]), other sentences counted.

use super::items::{marks, EpochOrder, RawItem};
use super::mixed::{MixedFrame, MixedReader};
use super::nmea::{gga_fix, is_gga, GgaSkip};
use super::rtcm::message_number;
use super::rtcm_eph::{decode_ephemeris, EphError};
use super::rtcm_msm::{decode_msm, leap_seconds, msm_kind, MsmDecoder, WEEK_MS};
use super::rtcm_week::{consensus, today_week, vote_of, Cycle, WeekVote};
use super::ubx::{self, Frame};
use super::ubx_nav::{NavDecoder, NavOut};
use super::ubx_obs::RawxConverter;
use super::{RawStats, TimeHint};
use crate::error::{Error, Result};
use crate::sv::Constellation;
use std::collections::HashMap;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// An RTCM ephemeris whose time of clock is farther than this (ms) from the log's time is
/// stale: no ephemeris is used so far from its time of clock.
pub const STALE: i64 = 6 * 3_600_000;
/// Stale ephemerides named in the report (the rest counted).
const STALE_NAMED: usize = 12;
const DAY_MS: i64 = 86_400_000;

/// What a first reading of a log found.
#[derive(Debug, Default)]
struct Survey {
    /// RXM-RAWX messages with a known week.
    rawx: u64,
    /// The first of them, GPST ms.
    rawx_start: Option<i64>,
    /// MSM messages.
    msm: u64,
    /// The first MSM's time of week (GPST ms), when its system tells it.
    msm_tow: Option<i64>,
    /// The ephemeris messages' week evidence.
    votes: Vec<WeekVote>,
}

/// The time of week (GPST ms) of an MSM epoch field: GPS, Galileo and QZSS carry it, BeiDou
/// in BDT, GLONASS as day of week (7: unknown) and Moscow time of day.
fn msm_tow(sys: Constellation, epoch: u32) -> Option<i64> {
    match sys {
        Constellation::Glonass => {
            let dow = (epoch >> 27) as i64;
            let tod = (epoch & 0x7ff_ffff) as i64;
            (dow < 7).then(|| (dow * DAY_MS + tod - 10_800_000 + 18_000).rem_euclid(WEEK_MS))
        }
        Constellation::BeiDou => Some((epoch as i64 + 14_000).rem_euclid(WEEK_MS)),
        _ => Some(epoch as i64),
    }
}

/// The GPST ms of a RAWX message with a known week.
fn rawx_ms(x: &ubx::Rawx) -> Option<i64> {
    (x.week != 0).then(|| {
        x.week as i64 * WEEK_MS + (x.rcv_tow.clamp(0.0, 604_800.0) * 1000.0).round() as i64
    })
}

fn survey(path: &Path) -> Result<Survey> {
    let file = File::open(path).map_err(Error::io(path))?;
    let mut r = MixedReader::new(BufReader::new(file));
    let mut st = RawStats::default();
    let mut s = Survey::default();
    while let Some(fr) = r.next_frame(&mut st).map_err(Error::io(path))? {
        match fr {
            MixedFrame::Ubx(Frame {
                class: 0x02,
                id: 0x15,
                payload,
            }) => {
                if let Some(t) = ubx::decode_rawx(payload).as_ref().and_then(rawx_ms) {
                    s.rawx += 1;
                    s.rawx_start.get_or_insert(t);
                }
            }
            MixedFrame::Rtcm(p) => {
                if msm_kind(message_number(p)).is_some() {
                    s.msm += 1;
                    if s.msm_tow.is_none() {
                        s.msm_tow = decode_msm(p).and_then(|m| msm_tow(m.sys, m.epoch));
                    }
                } else if let Some(v) = vote_of(p) {
                    s.votes.push(v);
                }
            }
            _ => {}
        }
    }
    Ok(s)
}

/// The start time (GPST ms) of a log's MSM observations and where it came from; `None` for a
/// log whose observations are not MSMs. Errors when it cannot be settled or the date hint
/// contradicts a strong consensus.
fn msm_start(
    path: &Path,
    s: &Survey,
    hint: Option<TimeHint>,
    st: &mut RawStats,
) -> Result<Option<i64>> {
    if s.msm == 0 || s.rawx > 0 {
        return Ok(None);
    }
    let tow = s.msm_tow.unwrap_or(0);
    let reference = hint.map(TimeHint::week);
    let c = consensus(&s.votes, tow, reference, today_week());
    let date = match hint {
        Some(h @ TimeHint::Date(..)) => Some(h),
        _ => None,
    };
    let at = |week: i64| week * WEEK_MS + tow;
    let (start, how) = match (date, c) {
        (Some(h), Some(c)) if c.strong && (at(c.week) - h.gpst_ms()).abs() > 4 * DAY_MS => {
            return Err(Error::input(
                path,
                format!(
                    "--date-hint {h} (GPS week {}) contradicts the log: its ephemerides date it \
                     to GPS week {c}; correct the hint or leave it out",
                    h.week()
                ),
            ))
        }
        (Some(_), Some(c)) if c.strong => (at(c.week), format!("{c}, as --date-hint says")),
        (Some(h), c) => {
            let near = |w: i64| msm_week_near(tow, h.gpst_ms(), w);
            if let Some(c) = c.filter(|c| !near(c.week)) {
                st.warnings.push(format!(
                    "--date-hint {h} taken over the log's GPS-only ephemerides, which point \
                     at GPS week {c}"
                ));
            }
            let t = super::rtcm_msm::msm_time(Constellation::Gps, tow as u32, h.gpst_ms());
            (t, format!("{} from --date-hint {h}", t.div_euclid(WEEK_MS)))
        }
        (None, Some(c)) => {
            let cycle = match (c.cycle, hint) {
                (Cycle::Reference, Some(h)) => {
                    format!(", in the 1024-week cycle of --year-hint {h}")
                }
                _ => String::new(),
            };
            (at(c.week), format!("{c}{cycle}"))
        }
        (None, None) => {
            return Err(Error::input(
                path,
                format!(
                    "the GPS week of the observations cannot be determined: RTCM 3 MSM carry \
                     the time of week only and no ephemeris message of the log (1019, 1042, \
                     1044, 1045, 1046) is of the observations' time{}; give --date-hint \
                     YYYY-MM-DD, the day the log was recorded",
                    if hint.is_some() {
                        ", and a year alone cannot place them"
                    } else {
                        ""
                    }
                ),
            ))
        }
    };
    st.time_source = Some(how);
    Ok(Some(start))
}

/// Whether observations at time of week `tow` of week `week` lie within 4 days of `hint_ms`.
fn msm_week_near(tow: i64, hint_ms: i64, week: i64) -> bool {
    (week * WEEK_MS + tow - hint_ms).abs() <= 4 * DAY_MS
}

/// RTCM ephemeris messages turned into records, each distinct one once, stale ones counted.
#[derive(Default)]
struct EphDecoder {
    last: HashMap<(u16, u32), Vec<u8>>,
}

impl EphDecoder {
    fn push(
        &mut self,
        p: &[u8],
        now: Option<i64>,
        week_ref: Option<i64>,
        st: &mut RawStats,
        f: &mut dyn FnMut(RawItem),
    ) {
        let n = message_number(p);
        st.nav.messages += 1;
        let key = (n, super::bits::bits_u(p, 12, if n == 1044 { 4 } else { 6 }));
        if self.last.get(&key).is_some_and(|l| l.as_slice() == p) {
            return;
        }
        self.last.insert(key, p.to_vec());
        match decode_ephemeris(p, now, week_ref) {
            Ok(r) => {
                let toc_ms = (r.toc.to_gpst_seconds() * 1000.0).round() as i64;
                if let Some(now) = now.filter(|now| (toc_ms - now).abs() > STALE) {
                    st.nav.stale += 1;
                    if st.nav.stale_named.len() < STALE_NAMED {
                        let days = (toc_ms - now) as f64 / DAY_MS as f64;
                        st.nav.stale_named.push(format!(
                            "{} (RTCM {n}, toc {}, {days:+.1} days)",
                            r.sv,
                            crate::time::format_ymdhms(r.toc)
                        ));
                    }
                    return;
                }
                st.nav.ephemerides += 1;
                f(RawItem::Ephemeris(r));
            }
            Err(EphError::Short) => *st.malformed.entry(format!("RTCM {n}")).or_default() += 1,
            Err(EphError::Satellite(_)) => {
                *st.malformed
                    .entry(format!("RTCM {n} (satellite id out of range)"))
                    .or_default() += 1
            }
            Err(EphError::NoTime) => st.nav.before_week_known += 1,
        }
    }
}

/// The state of one reading of a log.
struct Reader {
    rawx_obs: bool,
    conv: RawxConverter,
    nav: NavDecoder,
    msm: MsmDecoder,
    eph: EphDecoder,
    /// The log's time (GPST ms): the last RAWX's, else the MSM decoder's.
    rawx_now: Option<i64>,
    /// GPST − UTC from RAWX, when the receiver knew it.
    leap: Option<i8>,
    week_ref: Option<i64>,
    order: EpochOrder,
}

impl Reader {
    fn now(&self) -> Option<i64> {
        self.rawx_now.or(self.msm.time())
    }

    fn ubx(&mut self, fr: Frame, st: &mut RawStats, f: &mut dyn FnMut(RawItem)) {
        match (fr.class, fr.id) {
            (0x02, 0x15) => {
                let Some(x) = ubx::decode_rawx(fr.payload) else {
                    *st.malformed.entry("RXM-RAWX".into()).or_default() += 1;
                    return;
                };
                if x.leap_valid {
                    self.leap = Some(x.leap_s);
                }
                if let Some(t) = rawx_ms(&x) {
                    self.rawx_now = Some(t);
                }
                if let Some(e) = self.conv.epoch(&x, st) {
                    self.order.emit(e, st, f);
                }
            }
            (0x0d, 0x03) => {
                let Some(t) = ubx::decode_tm2(fr.payload) else {
                    *st.malformed.entry("TIM-TM2".into()).or_default() += 1;
                    return;
                };
                for ev in marks(&t, self.leap.unwrap_or(18)) {
                    st.events += 1;
                    f(RawItem::Event(ev));
                }
            }
            (0x02, 0x13) => match self.nav.push(fr.payload, self.now(), st) {
                Some(NavOut::Ephemeris(r)) => f(RawItem::Ephemeris(r)),
                Some(NavOut::GpsIono(k, l)) => f(RawItem::GpsIono(k, l)),
                Some(NavOut::BdsIono(k)) => f(RawItem::BdsIono(k)),
                None => {}
            },
            (c, i) => *st.unused.entry(ubx::type_name(c, i)).or_default() += 1,
        }
    }

    fn rtcm(&mut self, p: &[u8], st: &mut RawStats, f: &mut dyn FnMut(RawItem)) {
        let n = message_number(p);
        if msm_kind(n).is_some() {
            if self.rawx_obs {
                *st.unused
                    .entry(format!("RTCM {n} (observations taken from RXM-RAWX)"))
                    .or_default() += 1;
                return;
            }
            let Some(m) = decode_msm(p) else {
                *st.malformed.entry(format!("RTCM {n}")).or_default() += 1;
                return;
            };
            if let Some(e) = self.msm.push(&m, st) {
                self.order.emit(e, st, f);
            }
            return;
        }
        match n {
            1019 | 1020 | 1042 | 1044 | 1045 | 1046 => {
                if n == 1020 && p.len() >= 3 {
                    let ch = super::bits::bits_u(p, 18, 5) as i8 - 7;
                    self.msm
                        .set_glonass_channel(super::bits::bits_u(p, 12, 6) as u8, ch);
                }
                let now = self.now();
                let week_ref = now.map(|t| t.div_euclid(WEEK_MS)).or(self.week_ref);
                self.eph.push(p, now, week_ref, st, f);
            }
            1005 | 1006 | 1007 | 1008 | 1033 => {
                if !st.station.add(p) {
                    *st.malformed.entry(format!("RTCM {n}")).or_default() += 1;
                }
            }
            _ => *st.unused.entry(format!("RTCM {n}")).or_default() += 1,
        }
    }

    fn nmea(&mut self, s: &str, st: &mut RawStats, f: &mut dyn FnMut(RawItem)) {
        let name = format!(
            "NMEA {}",
            s.split(',').next().unwrap_or("").get(2..).unwrap_or("")
        );
        if !is_gga(s) {
            *st.unused.entry(name).or_default() += 1;
            return;
        }
        let Some(now) = self.now() else {
            st.drop("NMEA GGA before the log's time was known");
            return;
        };
        let leap = self.leap.map_or(leap_seconds(now), i64::from);
        match gga_fix(s, now, leap) {
            Ok(fix) => {
                st.nmea_fixes += 1;
                f(RawItem::Fix(fix))
            }
            Err(GgaSkip::NoFix) => st.drop("NMEA GGA without a fix"),
            Err(GgaSkip::Malformed) => *st.malformed.entry(name).or_default() += 1,
        }
    }
}

/// Read every item of a UBX and/or RTCM 3 log (NMEA between them), calling `f` on each;
/// returns what was read and dropped. `hint` settles the week of MSM observations.
pub fn for_each_log_item(
    path: &Path,
    hint: Option<TimeHint>,
    mut f: impl FnMut(RawItem),
) -> Result<RawStats> {
    let io = Error::io(path);
    let s = survey(path)?;
    let mut st = RawStats::default();
    let start = msm_start(path, &s, hint, &mut st)?;
    let mut rd = Reader {
        rawx_obs: s.rawx > 0,
        conv: RawxConverter::new(),
        nav: NavDecoder::new(),
        msm: MsmDecoder::new(start.or(s.rawx_start)),
        eph: EphDecoder::default(),
        rawx_now: None,
        leap: None,
        week_ref: s
            .rawx_start
            .map(|t| t.div_euclid(WEEK_MS))
            .or(hint.map(TimeHint::week)),
        order: EpochOrder::default(),
    };
    let mut r = MixedReader::new(BufReader::new(File::open(path).map_err(io)?));
    while let Some(fr) = r.next_frame(&mut st).map_err(Error::io(path))? {
        match fr {
            MixedFrame::Ubx(u) => rd.ubx(u, &mut st, &mut f),
            MixedFrame::Rtcm(p) => rd.rtcm(p, &mut st, &mut f),
            MixedFrame::Nmea(s) => rd.nmea(s, &mut st, &mut f),
        }
    }
    if let Some(e) = rd.msm.finish() {
        rd.order.emit(e, &mut st, &mut f);
    }
    rd.nav.finish(&mut st);
    Ok(st)
}
