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
//! votes are weak. The week with the most strong votes wins (weak votes for another week are
//! outvoted, and the summary says so); without strong votes the residue with the most weak
//! votes, placed in a 1024-week cycle by, in turn: the caller's reference (a hint), the whole
//! weeks of the stale Galileo/BeiDou ephemerides (a receiver keeps them days or weeks, never
//! a cycle: they tell the cycle even when they cannot tell the week), or else the latest cycle
//! that does not put the log after today (a log is never from the future; a 2018 log read in
//! 2026 is dated 2018, not 2038).
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
    /// What placed a modulo-1024 week in its cycle.
    pub cycle: Cycle,
}

/// What chose the 1024-week cycle of a week settled by GPS/QZSS (modulo-1024) votes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cycle {
    /// No cycle to choose: whole-week (Galileo, BeiDou) ephemerides of the observations' time.
    Whole,
    /// The caller's reference (a `--year-hint` or `--date-hint`).
    Reference,
    /// The whole weeks of this many stale Galileo/BeiDou ephemerides.
    Stale(usize),
    /// The latest cycle that does not date the log after the given GPS week (today's).
    Latest(i64),
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
            match (self.disagree, self.strong) {
                (0, _) => String::new(),
                (n, true) => format!(
                    ", {n} for another week outvoted (Galileo and BeiDou weeks are whole, \
                     GPS and QZSS ones modulo 1024)"
                ),
                (n, false) => format!(", {n} for another week"),
            }
        )?;
        match self.cycle {
            Cycle::Whole | Cycle::Reference => {}
            Cycle::Stale(n) => write!(
                f,
                ", in the 1024-week cycle of the whole weeks of {n} stale Galileo/BeiDou \
                 ephemerides"
            )?,
            Cycle::Latest(today) => write!(
                f,
                ", in the latest 1024-week cycle that does not date the log after today ({} to \
                 {}); give --date-hint if the log is older",
                week_day(today - 1023),
                week_day(today + 1)
            )?,
        }
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

/// The first day (GPST, `YYYY-MM-DD`) of GPS week `week`.
fn week_day(week: i64) -> String {
    // Noon: the UTC date of GPST midnight would be the day before.
    let e = hifitime::Epoch::from_gpst_seconds((week * WEEK_MS / 1000 + 43_200) as f64);
    let (y, m, d, ..) = e.to_gregorian_utc();
    format!("{y:04}-{m:02}-{d:02}")
}

/// The offset (ms) from `tow` to `toc` within a week, wrapped into ±half a week.
fn wrapped(toc: i64, tow: i64) -> i64 {
    (toc - tow + WEEK_MS / 2).rem_euclid(WEEK_MS) - WEEK_MS / 2
}

/// The week whose 1024-cycle residue is `residue`, nearest `reference` (a GPS week).
pub fn in_cycle(residue: i64, reference: i64) -> i64 {
    residue + 1024 * ((reference - residue) as f64 / 1024.0).round() as i64
}

/// The latest week with 1024-cycle residue `residue` that is not after GPS week `today`.
pub fn latest_in_cycle(residue: i64, today: i64) -> i64 {
    today - (today - residue).rem_euclid(1024)
}

/// The GPS week of today by the system clock (the bound no log's date may pass).
pub fn today_week() -> i64 {
    let s = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64);
    // The GPS epoch (1980-01-06) is 315,964,800 s after the Unix one; leap seconds are
    // far below a week.
    (s - 315_964_800).div_euclid(WEEK_MS / 1000)
}

/// The week of observations at time of week `tow_ms` by the `votes`; `reference` (a hint)
/// places modulo-1024 weeks, else the stale whole weeks, else the latest cycle not after
/// GPS week `today`. None when no ephemeris is current.
pub fn consensus(
    votes: &[WeekVote],
    tow_ms: i64,
    reference: Option<i64>,
    today: i64,
) -> Option<Consensus> {
    let mut strong: BTreeMap<i64, usize> = BTreeMap::new();
    let mut weak: BTreeMap<i64, usize> = BTreeMap::new();
    let mut stale_whole: Vec<i64> = Vec::new();
    let mut stale = 0;
    for v in votes {
        let d = wrapped(v.toc_ms, tow_ms);
        if d.abs() > CURRENT {
            stale += 1;
            if let WeekField::Whole(w) = v.week {
                stale_whole.push(w);
            }
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
            cycle: Cycle::Whole,
        });
    }
    let (residue, n) = best(&weak)?;
    stale_whole.sort_unstable();
    let (week, cycle) = match (reference, stale_whole.get(stale_whole.len() / 2)) {
        (Some(r), _) => (in_cycle(residue, r), Cycle::Reference),
        (None, Some(&w)) => (in_cycle(residue, w), Cycle::Stale(stale_whole.len())),
        (None, None) => (latest_in_cycle(residue, today), Cycle::Latest(today)),
    };
    Some(Consensus {
        week,
        strong: false,
        agree: n,
        disagree: total_weak - n,
        stale,
        cycle,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// GPS week 2448 (2026-12-06).
    const TODAY: i64 = 2448;

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
        let c = consensus(&votes, tow, None, TODAY).unwrap();
        assert_eq!(c.week, 2024);
        assert!(c.strong);
        assert_eq!((c.agree, c.disagree, c.stale), (11, 2, 1), "{c}");
        // Without Galileo: the GPS majority, in the cycle of the reference (a year hint).
        let gps_only: Vec<WeekVote> = votes[..10].to_vec();
        let c = consensus(&gps_only, tow, Some(2000), TODAY).unwrap();
        assert_eq!((c.week, c.strong, c.agree, c.disagree), (2024, false, 7, 2));
        assert_eq!(c.cycle, Cycle::Reference);
        // …and without a reference, in the latest cycle that is not after today: 2018, not
        // 2038 (the cycle 2019–2038 would put it in the future).
        let c = consensus(&gps_only, tow, None, TODAY).unwrap();
        assert_eq!((c.week, c.cycle), (2024, Cycle::Latest(TODAY)));
        assert!(c.to_string().contains("--date-hint"), "{c}");
        // Read in 2040, the same GPS-only log would be dated 2038: the message says so.
        assert_eq!(consensus(&gps_only, tow, None, 3200).unwrap().week, 3048);
        // Nothing current: no consensus.
        assert_eq!(consensus(&votes[..1], 0, None, TODAY), None);
    }

    /// The real DJI case: the Galileo ephemerides are days old (toc at the week's start), so
    /// they cannot date the observations' week, but their whole weeks settle the cycle in
    /// which the GPS votes choose: 2018, also when read in 2040, and a log of 2039 read then
    /// is dated 2039.
    #[test]
    fn stale_whole_weeks_choose_the_cycle() {
        let tow = 3 * 86_400_000 + 14 * 3_600_000;
        for (week, today) in [(2024, TODAY), (2024, 3200), (3100, 3200)] {
            let mut votes: Vec<WeekVote> = (1..=4).map(|p| gps(p, week, 86)).collect();
            votes.extend((1..=7).map(|prn| WeekVote {
                sv: Sv::new(Constellation::Galileo, prn),
                week: WeekField::Whole(week),
                toc_ms: 0,
            }));
            let c = consensus(&votes, tow, None, today).unwrap();
            assert_eq!((c.week, c.strong, c.stale), (week, false, 7), "{c}");
            assert_eq!(c.cycle, Cycle::Stale(7));
            // BeiDou's whole weeks alike, a week older.
            for v in votes.iter_mut().skip(4) {
                v.sv = Sv::new(Constellation::BeiDou, v.sv.prn);
                v.week = WeekField::Whole(week - 1);
            }
            assert_eq!(consensus(&votes, tow, None, today).unwrap().week, week);
        }
    }

    /// Current Galileo weeks outvote GPS ones that point at another week, and say so.
    #[test]
    fn whole_weeks_outvote_modulo_weeks() {
        let tow = 3 * 86_400_000 + 14 * 3_600_000;
        let mut votes: Vec<WeekVote> = (1..=5).map(|p| gps(p, 2025, 86)).collect();
        votes.extend((1..=2).map(|prn| WeekVote {
            sv: Sv::new(Constellation::Galileo, prn),
            week: WeekField::Whole(2024),
            toc_ms: tow - 600_000,
        }));
        let c = consensus(&votes, tow, None, TODAY).unwrap();
        assert_eq!((c.week, c.strong, c.agree, c.disagree), (2024, true, 2, 5));
        assert!(c.to_string().contains("outvoted"), "{c}");
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
        let c = consensus(&[v], tow, None, TODAY).unwrap();
        assert_eq!(c.week, 2300);
    }
}
