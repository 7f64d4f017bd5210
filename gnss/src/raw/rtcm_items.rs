//! The items of an RTCM 3 log: observation epochs from MSM4/5/6/7, ephemerides from 1019,
//! 1020, 1042, 1044, 1045 and 1046, GLONASS frequency channels from 1020, the reference
//! station from 1005/1006/1007/1008/1033, and the GPS week.
//!
//! What enters: the path of a log and the user's time hint. What leaves: each [`RawItem`]
//! handed to a callback and the [`RawStats`] of everything read and dropped (the station and
//! where the week came from among them), or an error when the week cannot be determined.
//!
//! MSM epochs carry only the time of week (of day for GLONASS). The week comes, in this order,
//! from a date hint (`--date-hint`; checked against the log's first ephemeris), else from the
//! first ephemeris message of the log carrying one: Galileo 1045/1046 and BeiDou 1042 carry
//! the whole week, GPS 1019 and QZSS 1044 the week modulo 1024, taken in the cycle nearest a
//! year hint (`--year-hint`) or, without one, in the cycle that began on 2019-04-07. The log
//! is scanned once for it before decoding (ephemerides are often sent after the first
//! observations). A log with observations and neither is refused with what to give.
//! Each distinct ephemeris (a payload differing from the satellite's last of that message)
//! is handed on once; repeats are counted among the navigation messages.

use super::bits::bits_u;
use super::items::{EpochOrder, RawItem};
use super::rtcm::{message_number, FrameReader};
use super::rtcm_eph::{decode_ephemeris, gps_week, EphError, BDT_WEEK0};
use super::rtcm_msm::{decode_msm, msm_kind, MsmDecoder, WEEK_MS};
use super::{RawStats, TimeHint};
use crate::error::{Error, Result};
use std::collections::HashMap;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// The time (GPST ms since the GPS epoch) an ephemeris message gives, its week and time of
/// clock, with the name of the message; `week_ref` resolves the 10-bit GPS and QZSS weeks
/// (see [`gps_week`]). `None` for other messages, or one too short.
pub fn ephemeris_hint(p: &[u8], week_ref: Option<i64>) -> Option<(i64, &'static str)> {
    let (week, toc_s, need, name) = match message_number(p) {
        1019 => (
            gps_week(bits_u(p, 18, 10), week_ref),
            bits_u(p, 56, 16) as i64 * 16,
            9,
            "RTCM 1019 (GPS ephemeris, week modulo 1024)",
        ),
        1044 => (
            gps_week(bits_u(p, 446, 10), week_ref),
            bits_u(p, 16, 16) as i64 * 16,
            57,
            "RTCM 1044 (QZSS ephemeris, week modulo 1024)",
        ),
        1042 => (
            BDT_WEEK0 + bits_u(p, 18, 13) as i64,
            bits_u(p, 54, 17) as i64 * 8,
            9,
            "RTCM 1042 (BeiDou ephemeris)",
        ),
        1045 | 1046 => (
            1024 + bits_u(p, 18, 12) as i64,
            bits_u(p, 62, 14) as i64 * 60,
            10,
            "RTCM 1045/1046 (Galileo ephemeris)",
        ),
        _ => return None,
    };
    (p.len() >= need).then_some((week * WEEK_MS + toc_s * 1000, name))
}

/// The start time of a log's observations (GPST ms) and where it came from; `None` for a log
/// without observations. Errors when the week cannot be determined or the date hint
/// contradicts the log.
fn start_time(path: &Path, hint: Option<TimeHint>) -> Result<Option<(i64, String)>> {
    let file = File::open(path).map_err(Error::io(path))?;
    let mut r = FrameReader::new(BufReader::new(file));
    let mut st = RawStats::default();
    let week_ref = hint.map(TimeHint::week);
    let (mut from_eph, mut msm) = (None, false);
    while let Some(p) = r.next_frame(&mut st).map_err(Error::io(path))? {
        msm |= msm_kind(message_number(p)).is_some();
        if from_eph.is_none() {
            from_eph = ephemeris_hint(p, week_ref);
        }
        if from_eph.is_some() && msm {
            break;
        }
    }
    let week_of = |t: i64| t.div_euclid(WEEK_MS);
    match (hint, from_eph) {
        (Some(h @ TimeHint::Date(..)), eph) => {
            if let Some((t, name)) = eph {
                if (t - h.gpst_ms()).abs() > 4 * 86_400_000 {
                    return Err(Error::input(
                        path,
                        format!(
                            "--date-hint {h} (GPS week {}) contradicts the log: its first                              ephemeris, {name}, is of GPS week {}; correct the hint or leave                              it out",
                            h.week(),
                            week_of(t)
                        ),
                    ));
                }
            }
            Ok(Some((
                h.gpst_ms(),
                format!("--date-hint {h} (week {})", h.week()),
            )))
        }
        (_, Some((t, name))) => {
            let how = match hint {
                Some(h) if name.contains("1024") => format!(", cycle of --year-hint {h}"),
                None if name.contains("1024") => {
                    ", taken in the cycle 2019-04-07 to 2038-11-20 (give --year-hint \
                     otherwise)"
                        .to_string()
                }
                _ => String::new(),
            };
            Ok(Some((
                t,
                format!("{} from the first {name}{how}", week_of(t)),
            )))
        }
        (_, None) if msm => Err(Error::input(
            path,
            format!(
                "the GPS week of the observations cannot be determined: RTCM 3 MSM carry the \
                 time of week only and the log has no ephemeris message giving the week (1019, \
                 1042, 1044, 1045, 1046){}; give --date-hint YYYY-MM-DD, the day the log was \
                 recorded",
                if hint.is_some() {
                    ", and a year alone cannot place them"
                } else {
                    ""
                }
            ),
        )),
        (_, None) => Ok(None),
    }
}

/// Ephemeris messages turned into records, each distinct one once.
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
        let key = (n, bits_u(p, 12, if n == 1044 { 4 } else { 6 }));
        if self.last.get(&key).is_some_and(|l| l.as_slice() == p) {
            return;
        }
        match decode_ephemeris(p, now, week_ref) {
            Ok(r) => {
                self.last.insert(key, p.to_vec());
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

/// Read every item of an RTCM 3 log, calling `f` on each; returns what was read and dropped.
pub fn for_each_rtcm(
    path: &Path,
    hint: Option<TimeHint>,
    mut f: impl FnMut(RawItem),
) -> Result<RawStats> {
    let io = Error::io(path);
    let start = start_time(path, hint)?;
    let week_ref = hint.map(TimeHint::week);
    let mut r = FrameReader::new(BufReader::new(File::open(path).map_err(io)?));
    let mut st = RawStats {
        time_source: start.as_ref().map(|s| s.1.clone()),
        ..RawStats::default()
    };
    let mut dec = MsmDecoder::new(start.map(|s| s.0));
    let mut eph = EphDecoder::default();
    let mut order = EpochOrder::default();
    while let Some(p) = r.next_frame(&mut st).map_err(io)? {
        let n = message_number(p);
        if msm_kind(n).is_some() {
            let Some(m) = decode_msm(p) else {
                *st.malformed.entry(format!("RTCM {n}")).or_default() += 1;
                continue;
            };
            if let Some(e) = dec.push(&m, &mut st) {
                order.emit(e, &mut st, &mut f);
            }
            continue;
        }
        match n {
            1019 | 1020 | 1042 | 1044 | 1045 | 1046 => {
                if n == 1020 && p.len() >= 3 {
                    let ch = bits_u(p, 18, 5) as i8 - 7;
                    dec.set_glonass_channel(bits_u(p, 12, 6) as u8, ch);
                }
                eph.push(p, dec.time(), week_ref, &mut st, &mut f);
            }
            1005 | 1006 | 1007 | 1008 | 1033 => {
                if !st.station.add(p) {
                    *st.malformed.entry(format!("RTCM {n}")).or_default() += 1;
                }
            }
            _ => *st.unused.entry(format!("RTCM {n}")).or_default() += 1,
        }
    }
    if let Some(e) = dec.finish() {
        order.emit(e, &mut st, &mut f);
    }
    Ok(st)
}
