//! The items of an RTCM 3 log: observation epochs from MSM4/5/6/7, GLONASS frequency
//! channels from 1020, the station position from 1005/1006, and the GPS week.
//!
//! What enters: the path of a log. What leaves: each [`RawItem`] handed to a callback and the
//! [`RawStats`] of everything read and dropped (the station position among them).
//!
//! MSM epochs carry only the time of week (of day for GLONASS); the week comes from the
//! first ephemeris message of the log that carries one: Galileo 1045/1046 and BeiDou 1042
//! carry the whole week, GPS 1019 the week modulo 1024, taken in the cycle that began on
//! 2019-04-07. The log is scanned once for it before decoding (ephemerides are often sent
//! after the first observations). Ephemerides are not decoded into orbits yet: they are
//! counted among the unused messages.

use super::bits::{bits_s, bits_u};
use super::items::RawItem;
use super::rtcm::{message_number, FrameReader};
use super::rtcm_msm::{decode_msm, msm_kind, MsmDecoder, WEEK_MS};
use super::RawStats;
use crate::error::{Error, Result};
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// The time hint (GPST ms since the GPS epoch) an ephemeris message gives: its week and
/// time of clock. `None` for other messages, or one too short.
pub fn ephemeris_hint(p: &[u8]) -> Option<i64> {
    let (week, toc_s, need) = match message_number(p) {
        1019 => (
            2048 + bits_u(p, 18, 10) as i64,
            bits_u(p, 56, 16) as i64 * 16,
            9,
        ),
        1042 => (
            1356 + bits_u(p, 18, 13) as i64,
            bits_u(p, 54, 17) as i64 * 8,
            9,
        ),
        1045 | 1046 => (
            1024 + bits_u(p, 18, 12) as i64,
            bits_u(p, 62, 14) as i64 * 60,
            10,
        ),
        _ => return None,
    };
    (p.len() >= need).then_some(week * WEEK_MS + toc_s * 1000)
}

/// The station's ECEF position (m) of a 1005/1006 payload.
pub fn station_position(p: &[u8]) -> Option<[f64; 3]> {
    if !matches!(message_number(p), 1005 | 1006) || p.len() < 19 {
        return None;
    }
    let f38 = |pos: usize| {
        (bits_s(p, pos, 6) as i64 * (1 << 32) + bits_u(p, pos + 6, 32) as i64) as f64 * 1e-4
    };
    Some([f38(34), f38(74), f38(114)])
}

/// The time hint of a log: that of its first ephemeris message carrying a week.
fn week_hint(path: &Path) -> Result<Option<i64>> {
    let file = File::open(path).map_err(Error::io(path))?;
    let mut r = FrameReader::new(BufReader::new(file));
    let mut st = RawStats::default();
    while let Some(p) = r.next_frame(&mut st).map_err(Error::io(path))? {
        if let Some(h) = ephemeris_hint(p) {
            return Ok(Some(h));
        }
    }
    Ok(None)
}

/// Read every item of an RTCM 3 log, calling `f` on each; returns what was read and dropped.
pub fn for_each_rtcm(path: &Path, mut f: impl FnMut(RawItem)) -> Result<RawStats> {
    let io = Error::io(path);
    let hint = week_hint(path)?;
    let mut r = FrameReader::new(BufReader::new(File::open(path).map_err(io)?));
    let mut st = RawStats::default();
    let mut dec = MsmDecoder::new(hint);
    let mut last: Option<(u16, f64)> = None;
    let mut emit = |e: super::ubx_obs::RawEpoch, st: &mut RawStats, f: &mut dyn FnMut(RawItem)| {
        let t = (e.week, e.tow);
        if last.is_some_and(|l| l >= t) {
            st.time_jumps += 1;
        }
        last = Some(t);
        st.epochs += 1;
        f(RawItem::Epoch(e));
    };
    while let Some(p) = r.next_frame(&mut st).map_err(io)? {
        let n = message_number(p);
        if msm_kind(n).is_some() {
            let Some(m) = decode_msm(p) else {
                *st.malformed.entry(format!("RTCM {n}")).or_default() += 1;
                continue;
            };
            if let Some(e) = dec.push(&m, &mut st) {
                emit(e, &mut st, &mut f);
            }
            continue;
        }
        match n {
            1020 if p.len() >= 3 => {
                let ch = bits_u(p, 18, 5) as i8 - 7;
                dec.set_glonass_channel(bits_u(p, 12, 6) as u8, ch);
                *st.unused
                    .entry("RTCM 1020 (frequency channel used; orbit not decoded)".into())
                    .or_default() += 1;
            }
            1005 | 1006 => match station_position(p) {
                Some(x) => st.station = Some(x),
                None => *st.malformed.entry(format!("RTCM {n}")).or_default() += 1,
            },
            1019 | 1042 | 1045 | 1046 => {
                *st.unused
                    .entry(format!("RTCM {n} (ephemeris, not decoded)"))
                    .or_default() += 1
            }
            _ => *st.unused.entry(format!("RTCM {n}")).or_default() += 1,
        }
    }
    if let Some(e) = dec.finish() {
        emit(e, &mut st, &mut f);
    }
    Ok(st)
}
