//! u-blox RXM-SFRBX: navigation subframes and pages into ephemerides.
//!
//! What enters: RXM-SFRBX payloads, and the GPS week the receiver knows (from RXM-RAWX).
//! What leaves: each distinct ephemeris once, as a [`NavRecord`] (GPS and QZSS LNAV through
//! [`super::lnav`], Galileo I/NAV through [`super::inav`]), the GPS Klobuchar parameters, and
//! in [`NavStats`] every subframe or page that failed its checks and every set left incomplete.
//!
//! u-blox packing, checked on the cold-start log of the shared data (849 of 849 GPS subframes
//! pass): a GPS L1 C/A subframe is ten 32-bit words, each holding the 30 bits of a word
//! (D1…D30) in bits 29…0 and the last two parity bits of the word before (D29*, D30*) in bits
//! 31 and 30. A Galileo I/NAV page is eight words: the even half in the first four, the odd
//! half in the last four, each 120 bits left-aligned.

use super::inav::{self, PageError, WORD_BYTES};
use super::lnav::{self, SetError, SUBFRAME_BYTES};
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
}

/// The parts collected for one satellite.
#[derive(Default)]
struct Parts {
    lnav: [Option<[u8; SUBFRAME_BYTES]>; 3],
    inav: [Option<[u8; WORD_BYTES]>; 5],
    e5b: bool,
    /// Issue of data, toe and toc of the last ephemeris given.
    last: Option<(u32, u64, u64)>,
    /// The parts held form the last ephemeris given.
    complete: bool,
}

/// Decodes the SFRBX messages of one log.
#[derive(Default)]
pub struct NavDecoder {
    parts: HashMap<Sv, Parts>,
}

impl NavDecoder {
    /// A decoder with nothing collected.
    pub fn new() -> Self {
        Self::default()
    }

    /// Decode one RXM-SFRBX payload; `week` is the GPS week from the latest RXM-RAWX that
    /// knew it. Failed checks and unused signals are counted in `stats`.
    pub fn push(&mut self, p: &[u8], week: Option<u16>, stats: &mut RawStats) -> Option<NavOut> {
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
        let sv = super::ubx_obs::satellite(gnss, p[1]);
        match (sv, words.len()) {
            (Some(sv), 10)
                if matches!(sv.sys, Constellation::Gps | Constellation::Qzss) && sig == 0 =>
            {
                self.lnav(sv, &words, week, &mut stats.nav)
            }
            (Some(sv), 8) if sv.sys == Constellation::Galileo && (sig == 1 || sig == 5) => {
                self.inav(sv, &words, sig == 5, &mut stats.nav)
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

    /// Count the satellites whose last parts never formed an ephemeris (the log ended, or
    /// parts were lost to failed checks). Call once at the end of the log.
    pub fn finish(&self, stats: &mut RawStats) {
        stats.nav.incomplete += self.parts.values().filter(|p| !p.complete).count() as u64;
    }
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
