//! The items of a Septentrio SBF log: observation epochs from MeasEpoch, ephemerides from
//! GPSNav, GALNav, BDSNav and GLONav, GPS Klobuchar parameters and leap seconds from GPSIon
//! and GPSUtc, and camera events from ExtEvent.
//!
//! What enters: the path of a log. What leaves: each [`RawItem`] handed to a callback as it
//! is decoded (memory stays bounded) and the [`RawStats`] of everything read and dropped:
//! blocks of other numbers are counted by name as not used (MeasExtra among them: its
//! variances have no place in RINEX), blocks too short for their fields as malformed.
//!
//! Every SBF block carries the full GPS week (WNc) and time of week, so no hint is needed.
//! ExtEvent blocks become events numbered in file order (SBF has no edge counter); each is a
//! flag-5 record whatever its polarity, since the receiver times only the edge it is set to.

use super::items::{Edge, EpochOrder, EventMark, RawItem};
use super::sbf::{self, FrameReader, EXT_EVENT, MEAS_EPOCH};
use super::sbf_nav::NavBlocks;
use super::sbf_obs::SbfConverter;
use super::RawStats;
use crate::error::{Error, Result};
use crate::rinex::nav::Klobuchar;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// GPSIon block number.
pub const GPS_ION: u16 = 5893;
/// GPSUtc block number.
pub const GPS_UTC: u16 = 5894;

/// The Klobuchar parameters of a GPSIon block (α0–α3 at 16, β0–β3 at 32, f4 each).
pub fn decode_gps_ion(b: &[u8]) -> Option<Klobuchar> {
    if b.len() < 48 {
        return None;
    }
    let f = sbf::Le(b);
    let mut k = Klobuchar::default();
    for i in 0..4 {
        k.alpha[i] = f.f32(16 + 4 * i) as f64;
        k.beta[i] = f.f32(32 + 4 * i) as f64;
    }
    Some(k)
}

/// The current leap seconds (ΔtLS, i1 at 33) of a GPSUtc block.
pub fn decode_gps_utc(b: &[u8]) -> Option<i32> {
    (b.len() >= 37).then(|| sbf::Le(b).i8(33) as i32)
}

/// Read every item of an SBF log, calling `f` on each; returns what was read and dropped.
pub fn for_each_sbf(path: &Path, mut f: impl FnMut(RawItem)) -> Result<RawStats> {
    let io = Error::io(path);
    let mut r = FrameReader::new(BufReader::new(File::open(path).map_err(io)?));
    let mut st = RawStats::default();
    let mut conv = SbfConverter::new();
    let mut nav = NavBlocks::default();
    let (mut iono, mut leap): (Option<Klobuchar>, Option<i32>) = (None, None);
    let mut order = EpochOrder::default();
    let mut count = 0u16;
    while let Some(b) = r.next_block(&mut st).map_err(io)? {
        let malformed = |st: &mut RawStats| {
            *st.malformed.entry(sbf::type_name(b.number)).or_default() += 1;
        };
        match b.number {
            MEAS_EPOCH => {
                let Some(m) = super::sbf_meas::decode_meas_epoch(b.bytes) else {
                    malformed(&mut st);
                    continue;
                };
                if let Some(e) = conv.epoch(&m, &mut st) {
                    order.emit(e, &mut st, &mut f);
                }
            }
            EXT_EVENT => {
                let Some(ev) = sbf::decode_ext_event(b.bytes) else {
                    malformed(&mut st);
                    continue;
                };
                let Some((week, tow)) = ev.time() else {
                    st.drop("ExtEvent without a time (do-not-use TOW or WNc)");
                    continue;
                };
                count = count.wrapping_add(1);
                st.events += 1;
                f(RawItem::Event(EventMark {
                    week,
                    tow,
                    edge: if ev.polarity == 1 {
                        Edge::Falling
                    } else {
                        Edge::Rising
                    },
                    count,
                    valid: true,
                    record: true,
                }));
            }
            sbf::GPS_NAV | sbf::GAL_NAV | sbf::BDS_NAV | sbf::GLO_NAV => {
                if let Some(rec) = nav.push(b.number, b.bytes, &mut st) {
                    f(RawItem::Ephemeris(rec));
                }
            }
            GPS_ION | GPS_UTC => {
                let got = if b.number == GPS_ION {
                    decode_gps_ion(b.bytes).map(|k| iono = Some(k)).is_some()
                } else {
                    decode_gps_utc(b.bytes).map(|l| leap = Some(l)).is_some()
                };
                if !got {
                    malformed(&mut st);
                } else if let (Some(k), Some(l)) = (iono, leap) {
                    f(RawItem::GpsIono(k, l));
                }
            }
            n => *st.unused.entry(sbf::type_name(n)).or_default() += 1,
        }
    }
    Ok(st)
}
