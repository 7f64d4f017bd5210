//! u-blox RXM-SFRBX: navigation subframes and pages into ephemerides.
//!
//! What enters: RXM-SFRBX payloads, and the receiver's time (from RXM-RAWX, once it knows the
//! GPS week). What leaves: each distinct ephemeris once, as a [`NavRecord`] (GPS and QZSS LNAV
//! through [`super::lnav`], Galileo I/NAV through [`super::inav`], BeiDou D1/D2 through
//! [`super::bds_nav`], GLONASS L1OF/L2OF through [`super::glo_nav`]), the GPS and BeiDou
//! Klobuchar parameters, and in [`NavStats`] every subframe, page or string that failed its checks and
//! every set left incomplete.
//!
//! u-blox packing, checked on the cold-start log of the shared data (849 of 849 GPS subframes
//! pass): a GPS L1 C/A subframe is ten 32-bit words, each holding the 30 bits of a word
//! (D1…D30) in bits 29…0 and the last two parity bits of the word before (D29*, D30*) in bits
//! 31 and 30. A Galileo I/NAV page is eight words: the even half in the first four, the odd
//! half in the last four, each 120 bits left-aligned (F9 receivers add a ninth word, not
//! read). A BeiDou subframe (B1I or B2I, D1 or D2 told by the PRN: GEO satellites 1–5 and
//! 59–63 broadcast D2) is ten words of 30 bits in bits 29…0, de-interleaved (checked on a
//! ZED-F9P log: 333 of 333 subframes pass their BCH checks). A GLONASS string is four words:
//! its 85 bits left-aligned in the first three, and in the fourth the superframe and frame
//! numbers the receiver counts (checked on NEO-M8T and ZED-F9P logs: 3221 of 3221 strings
//! pass their Hamming code); the frequency channel is the message's freqId − 7.

use super::bds_nav::{self, SUBFRAME_BYTES as BDS_BYTES};
use super::bits::bits_u;
use super::glo_nav::{self, G, STRING_BYTES};
use super::inav::{self, PageError, WORD_BYTES};
use super::lnav::{self, SetError, SUBFRAME_BYTES};
use super::rtcm_msm::WEEK_MS;
use super::{NavStats, RawStats};
use crate::rinex::nav::{Klobuchar, NavRecord};
use crate::sv::{Constellation, Sv};
use std::collections::HashMap;

/// What one SFRBX message gave.
#[derive(Clone, Debug)]
pub enum NavOut {
    /// A new ephemeris (one not given before with the same issue of data and times).
    Ephemeris(NavRecord),
    /// GPS Klobuchar parameters and leap seconds (subframe 4 page 18).
    GpsIono(Klobuchar, i32),
    /// BeiDou Klobuchar parameters (D1 subframe 1), when they differ from the last given.
    BdsIono(Klobuchar),
}

/// The parts collected for one satellite.
#[derive(Default)]
struct Parts {
    lnav: [Option<[u8; SUBFRAME_BYTES]>; 3],
    inav: [Option<[u8; WORD_BYTES]>; 5],
    e5b: bool,
    /// BeiDou D1 subframes 1–3 (the first three) or D2 subframe 1 pages 1–10.
    bds: [Option<[u8; BDS_BYTES]>; 10],
    /// GLONASS strings 1–4, each with the index of its frame ([`glonass_frame`]).
    glo: [Option<([u8; STRING_BYTES], i64)>; 4],
    /// The last tb of string 2, and the first and last frames that gave it.
    glo_tb: Option<(u32, i64, i64)>,
    /// Issue of data, toe and toc of the last ephemeris given.
    last: Option<(u32, u64, u64)>,
    /// The parts held form the last ephemeris given.
    complete: bool,
}

/// Decodes the SFRBX messages of one log.
#[derive(Default)]
pub struct NavDecoder {
    parts: HashMap<Sv, Parts>,
    bds_iono: Option<Klobuchar>,
}

impl NavDecoder {
    /// A decoder with nothing collected.
    pub fn new() -> Self {
        Self::default()
    }

    /// Decode one RXM-SFRBX payload; `now_ms` is the receiver's time (GPST ms since the GPS
    /// epoch) from the latest RXM-RAWX that knew the week. Failed checks and unused signals
    /// are counted in `stats`.
    pub fn push(&mut self, p: &[u8], now_ms: Option<i64>, stats: &mut RawStats) -> Option<NavOut> {
        if p.len() < 8 || p.len() < 8 + 4 * p[4] as usize {
            *stats.malformed.entry("RXM-SFRBX".into()).or_default() += 1;
            return None;
        }
        stats.nav.messages += 1;
        let words: Vec<u32> = p[8..8 + 4 * p[4] as usize]
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let (gnss, sig) = (p[0], p[2]);
        // BeiDou PRNs up to 63 (GEO 59–63 broadcast D2); RXM-RAWX keeps convbin's 1–50.
        let sv = match (gnss, p[1]) {
            (3, prn @ 1..=63) => Some(Sv::new(Constellation::BeiDou, prn)),
            (g, id) => super::ubx_obs::satellite(g, id),
        };
        let week = now_ms.map(|t| t.div_euclid(WEEK_MS) as u16);
        match (sv, words.len()) {
            (Some(sv), 10)
                if matches!(sv.sys, Constellation::Gps | Constellation::Qzss) && sig == 0 =>
            {
                self.lnav(sv, &words, week, &mut stats.nav)
            }
            (Some(sv), 8 | 9) if sv.sys == Constellation::Galileo && (sig == 1 || sig == 5) => {
                self.inav(sv, &words[..8], sig == 5, &mut stats.nav)
            }
            (Some(sv), 10) if sv.sys == Constellation::BeiDou && sig <= 3 => {
                self.beidou(sv, &words, &mut stats.nav)
            }
            (Some(sv), 4) if sv.sys == Constellation::Glonass && sig <= 2 => {
                // freqId: the frequency channel + 7 (−7…+6)
                if p[3] > 13 {
                    stats.nav.page_errors += 1;
                    return None;
                }
                self.glonass(sv, &words, p[3] as i8 - 7, now_ms, &mut stats.nav)
            }
            _ => {
                let name = sv.map_or("unknown system".to_string(), |s| format!("{:?}", s.sys));
                *stats
                    .unused
                    .entry(format!("RXM-SFRBX {name} signal {sig}"))
                    .or_default() += 1;
                None
            }
        }
    }

    fn lnav(
        &mut self,
        sv: Sv,
        dwrd: &[u32],
        week: Option<u16>,
        st: &mut NavStats,
    ) -> Option<NavOut> {
        let mut data = [0u32; 10];
        for (d, &w) in data.iter_mut().zip(dwrd) {
            let Some(x) = lnav::check_word(w & 0x3FFF_FFFF, w >> 31 == 1, w >> 30 & 1 == 1) else {
                st.parity_failures += 1;
                return None;
            };
            *d = x;
        }
        let sf = lnav::subframe(&data);
        let id = lnav::subframe_id(&sf);
        if data[0] >> 16 != lnav::PREAMBLE || !(1..=5).contains(&id) {
            st.page_errors += 1;
            return None;
        }
        if id > 3 {
            return lnav::iono_utc(&sf).map(|(k, leap)| NavOut::GpsIono(k, leap));
        }
        let parts = self.parts.entry(sv).or_default();
        parts.lnav[id as usize - 1] = Some(sf);
        let [Some(s1), Some(s2), Some(s3)] = &parts.lnav else {
            parts.complete = false;
            return None;
        };
        match lnav::ephemeris(sv, [s1, s2, s3], week) {
            Ok(r) => parts.give(r, st),
            Err(SetError::Inconsistent) => {
                parts.complete = false;
                st.inconsistent += 1;
                None
            }
            Err(SetError::NoWeek) => {
                parts.complete = false;
                st.before_week_known += 1;
                None
            }
        }
    }

    fn inav(&mut self, sv: Sv, dwrd: &[u32], e5b: bool, st: &mut NavStats) -> Option<NavOut> {
        let mut halves = [[0u8; 16]; 2];
        for (k, w) in dwrd.iter().enumerate() {
            halves[k / 4][4 * (k % 4)..4 * (k % 4) + 4].copy_from_slice(&w.to_be_bytes());
        }
        let word = match inav::page_word(&halves[0], &halves[1]) {
            Ok(w) => w,
            Err(PageError::Crc) => {
                st.crc_failures += 1;
                return None;
            }
            Err(PageError::EvenOdd) => {
                st.page_errors += 1;
                return None;
            }
            Err(PageError::Alert) => {
                st.alert_pages += 1;
                return None;
            }
        };
        let t = inav::word_type(&word) as usize;
        if !(1..=5).contains(&t) {
            return None;
        }
        let parts = self.parts.entry(sv).or_default();
        parts.inav[t - 1] = Some(word);
        parts.e5b = e5b;
        let [Some(w1), Some(w2), Some(w3), Some(w4), Some(w5)] = &parts.inav else {
            parts.complete = false;
            return None;
        };
        match inav::ephemeris(sv, [w1, w2, w3, w4, w5], parts.e5b) {
            Some(r) => parts.give(r, st),
            None => {
                // Words of different issues of data while a new one is being broadcast.
                if t < 5 {
                    st.inconsistent += 1;
                }
                parts.complete = false;
                None
            }
        }
    }

    fn beidou(&mut self, sv: Sv, dwrd: &[u32], st: &mut NavStats) -> Option<NavOut> {
        let mut w = [0u32; 10];
        for (k, (d, &x)) in w.iter_mut().zip(dwrd).enumerate() {
            if !bds_nav::check_word(k, x) {
                st.parity_failures += 1;
                return None;
            }
            *d = x & 0x3FFF_FFFF;
        }
        let sf = bds_nav::subframe(&w);
        let id = bds_nav::subframe_id(&sf);
        if bits_u(&sf, 0, 11) != bds_nav::PREAMBLE || !(1..=5).contains(&id) {
            st.page_errors += 1;
            return None;
        }
        let d2 = bds_nav::is_d2(sv.prn);
        let slot = match (d2, id) {
            (false, 1..=3) => id as usize - 1,
            (true, 1) => match bds_nav::d2_page(&sf) {
                p @ 1..=10 => p as usize - 1,
                _ => {
                    st.page_errors += 1;
                    return None;
                }
            },
            // almanac, health, time offsets: not used
            _ => return None,
        };
        let iono = (!d2 && id == 1).then(|| bds_nav::klobuchar(&sf));
        let parts = self.parts.entry(sv).or_default();
        parts.bds[slot] = Some(sf);
        if iono.is_some() && iono != self.bds_iono {
            self.bds_iono = iono;
            return iono.map(NavOut::BdsIono);
        }
        let n = if d2 { 10 } else { 3 };
        // A set is tried when the last part of a frame arrives.
        if slot + 1 != n {
            return None;
        }
        let set: Option<Vec<&[u8; BDS_BYTES]>> =
            parts.bds[..n].iter().map(|s| s.as_ref()).collect();
        let Some(set) = set else {
            parts.complete = false;
            return None;
        };
        match bds_nav::ephemeris(sv, &set, d2) {
            Ok(r) => parts.give(r, st),
            Err(bds_nav::SetError::Inconsistent) => {
                parts.complete = false;
                st.inconsistent += 1;
                None
            }
        }
    }

    fn glonass(
        &mut self,
        sv: Sv,
        dwrd: &[u32],
        channel: i8,
        now_ms: Option<i64>,
        st: &mut NavStats,
    ) -> Option<NavOut> {
        let mut b = [0u8; 12];
        for (k, w) in dwrd.iter().take(3).enumerate() {
            b[4 * k..4 * k + 4].copy_from_slice(&w.to_be_bytes());
        }
        let mut s = [0u8; STRING_BYTES];
        s.copy_from_slice(&b[..STRING_BYTES]);
        s[STRING_BYTES - 1] &= 0xF8; // bits past the 85th
        if !glo_nav::hamming_ok(&s) {
            st.parity_failures += 1;
            return None;
        }
        let m = glo_nav::string_number(&s);
        if m == 0 {
            st.page_errors += 1;
            return None;
        }
        let frame = glonass_frame(dwrd.get(3).copied().unwrap_or(0), now_ms);
        let parts = self.parts.entry(sv).or_default();
        if m == 2 {
            // tb: a new value starts a new span of frames of one ephemeris.
            let tb = bits_u(&s, glo_nav::FIELDS[G::Tb as usize].3, 7);
            parts.glo_tb = match parts.glo_tb {
                Some((t, first, last)) if t == tb && frame >= first => {
                    Some((t, first, last.max(frame)))
                }
                _ => Some((tb, frame, frame)),
            };
        }
        if m > 4 {
            return None;
        }
        parts.glo[m as usize - 1] = Some((s, frame));
        let [Some(s1), Some(s2), Some(s3), Some(s4)] = &parts.glo else {
            return None;
        };
        // Strings of different frames carry one ephemeris when every one lies within the
        // frames whose string 2 gave the same tb (the content changes only with tb).
        let (_, first, last) = parts.glo_tb?;
        if [s1, s2, s3, s4].iter().any(|x| x.1 < first || x.1 > last) {
            return None;
        }
        let (s1, s2, s3, s4) = (&s1.0, &s2.0, &s3.0, &s4.0);
        match glo_nav::ephemeris(sv, channel, [s1, s2, s3, s4], now_ms) {
            Ok(r) => parts.give(r, st),
            Err(e) => {
                parts.complete = false;
                match e {
                    glo_nav::SetError::Slot => st.inconsistent += 1,
                    glo_nav::SetError::NoTime => st.before_week_known += 1,
                }
                None
            }
        }
    }

    /// Count the satellites whose last parts never formed an ephemeris (the log ended, or
    /// parts were lost to failed checks). Call once at the end of the log.
    pub fn finish(&self, stats: &mut RawStats) {
        stats.nav.incomplete += self.parts.values().filter(|p| !p.complete).count() as u64;
    }
}

/// A GLONASS frame's index from the fourth SFRBX word (superframe number in bits 31–16, frame
/// number 1–5 in bits 7–0), or, when the receiver gives none, from the receiver's time: the
/// 30-s frame it falls in (GLONASS time = UTC + 3 h, frames start on its whole half-minutes).
fn glonass_frame(word: u32, now_ms: Option<i64>) -> i64 {
    if word != 0 {
        return (word >> 16) as i64 * 5 + (word & 0xFF) as i64;
    }
    now_ms.map_or(0, |t| {
        (t - super::rtcm_msm::leap_seconds(t) * 1000).div_euclid(30_000)
    })
}

impl Parts {
    /// Give `r` unless it is the ephemeris given last.
    fn give(&mut self, r: NavRecord, st: &mut NavStats) -> Option<NavOut> {
        self.complete = true;
        let key = (
            r.orbit[0] as u32,
            r.orbit[8].to_bits(),
            r.toc.to_gpst_nanoseconds().unwrap_or(0),
        );
        if self.last == Some(key) {
            return None;
        }
        self.last = Some(key);
        st.ephemerides += 1;
        Some(NavOut::Ephemeris(r))
    }
}
