//! The GPS week of an RTCM 3 log's observations, by the consensus of its ephemeris messages.
//!
//! MSM observations carry the time of week only. The ephemerides tell the week, but not all
//! alike: Galileo 1045/1046 (12-bit GST week) and BeiDou 1042 (13-bit BDT week) are whole
//! weeks; GPS 1019 and QZSS 1044 carry the week modulo 1024. And a log may carry stale
//! ephemerides the receiver kept from earlier days (a DJI `PPKRAW.bin` holds 1019s of weeks
//! 2018, 2019 and 2022 beside the current ones of week 2024), so the first ephemeris of a log
//! is no witness.
//!
//! Rule: an ephemeris votes only when its time of clock lies within [`CURRENT`] of the
//! observations' time of week (the week wrapped), as a broadcast ephemeris in use does; it
//! votes for the week the observations then fall in. Whole-week votes are strong; modulo-1024
//! votes are weak and take their 1024-week cycle from the caller's reference. The week with
//! the most strong votes wins; without strong votes the residue with the most weak votes.
//!
//! What enters: the votes ([`vote_of`] reads one from a message payload) and the observations'
//! time of week. What leaves: a [`Consensus`] (or none without a current ephemeris).

use super::bits::bits_u;
use super::rtcm::message_number;
use super::rtcm_eph::BDT_WEEK0;
use super::rtcm_msm::WEEK_MS;
use crate::sv::{Constellation, Sv};
use std::collections::BTreeMap;

/// How far from the observations (time of week, wrapped) a time of clock may lie for its
/// ephemeris to vote: GPS and QZSS ephemerides are used up to 2 h from toc and sent up to 2 h
/// before it; Galileo ones up to 4 h after.
pub const CURRENT: i64 = 5 * 3_600_000;

/// The week field of an ephemeris message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeekField {
    /// A whole GPS week (Galileo's and BeiDou's moved to the GPS week numbering).
    Whole(i64),
    /// A GPS week modulo 1024 (GPS, QZSS).
    Mod1024(i64),
}

/// One ephemeris message's evidence of the week.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WeekVote {
    /// The satellite.
    pub sv: Sv,
    /// Its week field.
    pub week: WeekField,
    /// Time of clock, GPST ms of that week.
    pub toc_ms: i64,
}

/// The vote of an ephemeris message payload (1019, 1042, 1044, 1045, 1046), when it is one
/// long enough to hold its week and time of clock.
pub fn vote_of(p: &[u8]) -> Option<WeekVote> {
    let n = message_number(p);
    let (sys, id_bits, week, toc_ms, need) = match n {
        1019 => (
            Constellation::Gps,
            6,
            WeekField::Mod1024(bits_u(p, 18, 10) as i64),
            bits_u(p, 56, 16) as i64 * 16_000,
            9,
        ),
        1044 => (
            Constellation::Qzss,
            4,
            WeekField::Mod1024(bits_u(p, 446, 10) as i64),
            bits_u(p, 16, 16) as i64 * 16_000,
            57,
        ),
        // BDT = GPST − 14 s; its week 0 began 1356 GPS weeks after GPS week 0.
        1042 => (
            Constellation::BeiDou,
            6,
            WeekField::Whole(BDT_WEEK0 + bits_u(p, 18, 13) as i64),
            bits_u(p, 54, 17) as i64 * 8_000 + 14_000,
            9,
        ),
        1045 | 1046 => (
            Constellation::Galileo,
            6,
            WeekField::Whole(1024 + bits_u(p, 18, 12) as i64),
            bits_u(p, 62, 14) as i64 * 60_000,
            10,
        ),
        _ => return None,
    };
    if p.len() < need {
        return None;
    }
    let prn = bits_u(p, 12, id_bits) as u8;
    Some(WeekVote {
        sv: Sv::new(sys, prn),
        week,
        toc_ms,
    })
}

/// What the votes settled.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Consensus {
    /// The GPS week of the observations.
    pub week: i64,
    /// Settled by whole-week (Galileo, BeiDou) votes.
    pub strong: bool,
    /// Votes for the week (whole and modulo 1024).
    pub agree: usize,
    /// Current votes for another week.
    pub disagree: usize,
    /// Ephemerides whose time of clock is not near the observations (did not vote).
    pub stale: usize,
}

impl std::fmt::Display for Consensus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} by the consensus of {} current ephemerides ({}){}",
            self.week,
            self.agree,
            if self.strong {
                "Galileo/BeiDou weeks among them"
            } else {
                "GPS/QZSS weeks modulo 1024 only"
            },
            if self.disagree > 0 {
                format!(", {} for another week", self.disagree)
            } else {
                String::new()
            }
        )?;
        if self.stale > 0 {
            write!(
                f,
                "; {} ephemerides far from the observations' time did not vote",
                self.stale
            )?;
        }
        Ok(())
    }
}

/// The offset (ms) from `tow` to `toc` within a week, wrapped into ±half a week.
fn wrapped(toc: i64, tow: i64) -> i64 {
    (toc - tow + WEEK_MS / 2).rem_euclid(WEEK_MS) - WEEK_MS / 2
}

/// The week whose 1024-cycle residue is `residue`, nearest `reference` (a GPS week); without
/// one, in the cycle that began on 2019-04-07 (week 2048).
pub fn in_cycle(residue: i64, reference: Option<i64>) -> i64 {
    match reference {
        Some(r) => residue + 1024 * ((r - residue) as f64 / 1024.0).round() as i64,
        None => 2048 + residue,
    }
}

/// The week of observations at time of week `tow_ms` by the `votes`; `reference` places
/// modulo-1024 weeks. None when no ephemeris is current.
pub fn consensus(votes: &[WeekVote], tow_ms: i64, reference: Option<i64>) -> Option<Consensus> {
    let mut strong: BTreeMap<i64, usize> = BTreeMap::new();
    let mut weak: BTreeMap<i64, usize> = BTreeMap::new();
    let mut stale = 0;
    for v in votes {
        let d = wrapped(v.toc_ms, tow_ms);
        if d.abs() > CURRENT {
            stale += 1;
            continue;
        }
        // The observations' instant: the ephemeris's minus the offset.
        match v.week {
            WeekField::Whole(w) => {
                *strong
                    .entry((w * WEEK_MS + v.toc_ms - d).div_euclid(WEEK_MS))
                    .or_default() += 1
            }
            WeekField::Mod1024(w) => {
                let wk = (w * WEEK_MS + v.toc_ms - d).div_euclid(WEEK_MS);
                *weak.entry(wk.rem_euclid(1024)).or_default() += 1
            }
        }
    }
    let best = |m: &BTreeMap<i64, usize>| {
        m.iter()
            .max_by_key(|(k, n)| (**n, -**k))
            .map(|(k, n)| (*k, *n))
    };
    let total_weak: usize = weak.values().sum();
    if let Some((week, n)) = best(&strong) {
        let weak_agree = weak.get(&week.rem_euclid(1024)).copied().unwrap_or(0);
        let total: usize = strong.values().sum::<usize>() + total_weak;
        return Some(Consensus {
            week,
            strong: true,
            agree: n + weak_agree,
            disagree: total - n - weak_agree,
            stale,
        });
    }
    let (residue, n) = best(&weak)?;
    Some(Consensus {
        week: in_cycle(residue, reference),
        strong: false,
        agree: n,
        disagree: total_weak - n,
        stale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gps(prn: u8, week: i64, toc_h: i64) -> WeekVote {
        WeekVote {
            sv: Sv::new(Constellation::Gps, prn),
            week: WeekField::Mod1024(week % 1024),
            toc_ms: toc_h * 3_600_000,
        }
    }

    /// The DJI case: stale GPS ephemerides of weeks 2018, 2019 and 2022 (some near the
    /// observations' time of week) beside current ones of week 2024 and Galileo ones: the
    /// Galileo weeks settle it, whatever the order.
    #[test]
    fn stale_ephemerides_do_not_date_the_log() {
        let tow = 3 * 86_400_000 + 14 * 3_600_000; // Wednesday 14:00
        let mut votes = vec![gps(5, 2018, 87), gps(9, 2019, 30), gps(12, 2022, 84)];
        votes.extend((1..=7).map(|p| gps(p + 10, 2024, 86)));
        let gal = |prn| WeekVote {
            sv: Sv::new(Constellation::Galileo, prn),
            week: WeekField::Whole(2024),
            toc_ms: 3 * 86_400_000 + 13 * 3_600_000 + 600_000,
        };
        votes.extend((1..=4).map(gal));
        let c = consensus(&votes, tow, None).unwrap();
        assert_eq!(c.week, 2024);
        assert!(c.strong);
        assert_eq!((c.agree, c.disagree, c.stale), (11, 2, 1), "{c}");
        // Without Galileo: the GPS majority, in the cycle of the reference (a year hint).
        let gps_only: Vec<WeekVote> = votes[..10].to_vec();
        let c = consensus(&gps_only, tow, Some(2000)).unwrap();
        assert_eq!((c.week, c.strong, c.agree, c.disagree), (2024, false, 7, 2));
        // …and without a reference, in the cycle of 2019–2038.
        assert_eq!(consensus(&gps_only, tow, None).unwrap().week, 2024 + 1024);
        // Nothing current: no consensus.
        assert_eq!(consensus(&votes[..1], 0, None), None);
    }

    /// An ephemeris whose toc lies in the next week (Saturday night observations) votes for
    /// the observations' week.
    #[test]
    fn votes_across_the_week_end() {
        let tow = WEEK_MS - 3_600_000; // Saturday 23:00
        let v = WeekVote {
            sv: Sv::new(Constellation::Galileo, 3),
            week: WeekField::Whole(2301),
            toc_ms: 3_600_000, // Sunday 01:00 of week 2301
        };
        let c = consensus(&[v], tow, None).unwrap();
        assert_eq!(c.week, 2300);
    }
}
