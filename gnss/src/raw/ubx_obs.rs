//! RXM-RAWX measurements to RINEX observations, exactly as RTKLIB convbin (demo5 / EX 2.5)
//! makes them, so that files converted by ppkat and by convbin agree value for value.
//!
//! What enters: decoded [`Rawx`] messages in file order. What leaves: [`RawEpoch`]s whose
//! signals carry RINEX codes, values and loss-of-lock indicators. State kept across epochs:
//! per satellite and frequency slot, the last lock time, half-cycle-subtracted bit and a
//! pending-slip flag; and whether a multi-band (generation 9) receiver has been seen.
//!
//! The rules (from reading RTKLIB `src/rcv/ublox.c` and `src/convrnx.c`):
//! - signals map to RINEX codes with the tracking attribute combined (`X`) where RINEX has
//!   one: GPS L1C/A → 1C, L2CL/L2CM → 2X, L5 → 5X; Galileo E1 → 1X, E5a → 5X, E5b → 7X;
//!   BeiDou B1I → 2I, B2I → 7I, B2a → 5X; QZSS like GPS; SBAS L1 → 1C; GLONASS 1C/2C;
//!   NavIC L5 → 5A. Beyond convbin (which has no slot for them and drops them), BeiDou B3I →
//!   6I, B1C → 1P (pilot) / 1D (data) and Galileo E6 → 6B / 6C / 6A, as RINEX 3.04 names
//!   them. Each satellite has [`SLOTS`] slots by band; a signal of another band is dropped and
//!   counted, and a second signal in one slot replaces the first.
//! - the pseudorange is blank unless prValid; the phase is blank unless cpValid, not −0.5 and
//!   cpStdev ≤ 5 (14 once a signal with sigId > 1 has been seen, from the next message on);
//!   BeiDou GEO phases get +0.5 cycle.
//! - LLI bit 1 (half cycle unresolved) when the phase is there and halfCyc is not set (for
//!   SBAS: lock time ≤ 8 s); bit 0 (slip) when subHalfCyc changed, and on the first phase
//!   after a slip: lock time 0 or shorter than before, subHalfCyc changed, or cpStdev = 15.
//!   A slip flagged on a measurement without phase is carried to the next phase (convbin's
//!   save/restore of slips).
//! - One rule beyond convbin's: a lock time that grew by less than the time since the
//!   signal's previous epoch (less [`LOCK_TOLERANCE_S`], below the counter's 64.5 s ceiling)
//!   is a slip too: the loop lost lock and locked again inside a gap of the log. A base that
//!   logs one epoch in five loses such slips by the hundred to convbin's rule (the low-cost
//!   walk's simulated base: 2 m jumps of the backward pass where an aged base epoch met an
//!   arc that had restarted unseen). In a log without gaps both rules agree.

use super::slots::SlotTable;
use super::ubx::{Rawx, RawxMeas};
use super::RawStats;
use crate::sv::{Constellation, Sv};

/// One signal of one satellite, ready for RINEX.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawSignal {
    /// RINEX band and attribute, e.g. `*b"1C"`.
    pub code: [u8; 2],
    /// Pseudorange, m (0: none).
    pub pr: f64,
    /// Carrier phase, cycles (0: none).
    pub cp: f64,
    /// Doppler, Hz (0: none).
    pub doppler: f64,
    /// C/N0, dB-Hz (0: none).
    pub cno: f64,
    /// RINEX loss-of-lock indicator (bits 0 and 1).
    pub lli: u8,
}

/// Frequency slots of a satellite in a raw epoch: the system's first, second and third band
/// (0–2), then band 6 (BeiDou B3I, Galileo E6; 3) and BeiDou B1C (band 1 beside B1I; 4).
pub const SLOTS: usize = 5;

/// One satellite in one epoch: up to [`SLOTS`] frequency slots.
#[derive(Clone, Debug, PartialEq)]
pub struct RawSat {
    /// The satellite.
    pub sv: Sv,
    /// Slots by frequency index (see [`SLOTS`]).
    pub sig: [Option<RawSignal>; SLOTS],
}

/// One measurement epoch.
#[derive(Clone, Debug, PartialEq)]
pub struct RawEpoch {
    /// GPS week.
    pub week: u16,
    /// Receiver time of week, seconds.
    pub tow: f64,
    /// Satellites in message order.
    pub sats: Vec<RawSat>,
    /// GLONASS frequency channels seen (slot, channel).
    pub glonass: Vec<(u8, i8)>,
}

/// How much less than the time elapsed a lock time may have grown (its millisecond counter
/// against the epochs' tags) before the signal counts as having slipped, seconds.
pub const LOCK_TOLERANCE_S: f64 = 0.5;

/// The ceiling of RAWX's lock time counter, seconds.
const LOCK_MAX_S: f64 = 64.5;

#[derive(Clone, Copy, Default)]
struct Lock {
    lockt: f64,
    /// Time of the signal's previous epoch (s since the GPS epoch), once seen.
    last: Option<f64>,
    halfc: bool,
    pending: bool,
    slip_carry: bool,
}

/// The converter's state across epochs.
#[derive(Default)]
pub struct RawxConverter {
    gen9: bool,
    locks: SlotTable<Lock>,
}

/// System and RINEX PRN of a u-blox GNSS id and satellite id (RTKLIB's satellite ranges).
pub(crate) fn satellite(gnss_id: u8, sv_id: u8) -> Option<Sv> {
    let (sys, lo, hi, off) = match gnss_id {
        0 => (Constellation::Gps, 1, 32, 0),
        1 => (Constellation::Sbas, 120, 158, 100),
        2 => (Constellation::Galileo, 1, 36, 0),
        3 => (Constellation::BeiDou, 1, 50, 0),
        5 => (Constellation::Qzss, 1, 10, 0),
        6 => (Constellation::Glonass, 1, 27, 0),
        7 => (Constellation::Irnss, 1, 14, 0),
        _ => return None,
    };
    (lo..=hi)
        .contains(&sv_id)
        .then(|| Sv::new(sys, sv_id - off))
}

/// RINEX band+attribute and frequency slot of a signal; `None` when it has no slot.
pub fn signal_code(sys: Constellation, sig_id: u8, version: u8) -> Option<([u8; 2], usize)> {
    use Constellation::*;
    if version < 1 {
        return Some(match sys {
            BeiDou => (*b"2I", 0),
            Galileo => (*b"1X", 0),
            _ => (*b"1C", 0),
        });
    }
    let c = match (sys, sig_id) {
        (Gps, 0) | (Qzss, 0) | (Qzss, 1) | (Sbas, 0) | (Glonass, 0) => *b"1C",
        (Gps, 3 | 4) | (Qzss, 4 | 5) => *b"2X",
        (Gps, 6 | 7) | (Qzss, 8 | 9) | (Galileo, 3 | 4) | (BeiDou, 7 | 8) => *b"5X",
        (Glonass, 2) => *b"2C",
        (Galileo, 0 | 1) => *b"1X",
        (Galileo, 5 | 6) => *b"7X",
        (BeiDou, 0 | 1) => *b"2I",
        (BeiDou, 2 | 3) => *b"7I",
        // RINEX 3.04: B3I 6I, B1C pilot 1P and data 1D; Galileo E6-B 6B, E6-C 6C, E6-A 6A.
        (BeiDou, 4 | 10) => *b"6I",
        (BeiDou, 5) => *b"1P",
        (BeiDou, 6) => *b"1D",
        (Galileo, 8) => *b"6B",
        (Galileo, 9) => *b"6C",
        (Galileo, 10) => *b"6A",
        (Irnss, 0) => *b"5A",
        _ => return None,
    };
    let slot = match (sys, c[0]) {
        (BeiDou, b'1') => 4,
        (BeiDou | Galileo, b'6') => 3,
        (BeiDou, b'2') | (Irnss, b'5') | (_, b'1') => 0,
        (Galileo | BeiDou, b'7') | (Gps | Qzss | Glonass, b'2') => 1,
        (_, b'5') => 2,
        _ => return None,
    };
    Some((c, slot))
}

impl RawxConverter {
    /// A converter with no history.
    pub fn new() -> Self {
        Self::default()
    }

    /// Convert one RAWX message; `None` for week-0 messages and epochs left empty.
    pub fn epoch(&mut self, r: &Rawx, stats: &mut RawStats) -> Option<RawEpoch> {
        if r.week == 0 {
            stats.epochs_without_time += 1;
            return None;
        }
        let cp_max = if self.gen9 { 14 } else { 5 };
        let mut e = RawEpoch {
            week: r.week,
            tow: r.rcv_tow,
            sats: Vec::new(),
            glonass: Vec::new(),
        };
        for m in &r.meas {
            if m.sig_id > 1 {
                self.gen9 = true;
            }
            let Some(sv) = satellite(m.gnss_id, m.sv_id) else {
                stats.drop("unknown system or satellite number");
                continue;
            };
            if sv.sys == Constellation::Glonass && !e.glonass.iter().any(|g| g.0 == sv.prn) {
                e.glonass.push((sv.prn, m.freq_id as i8 - 7));
            }
            let Some((code, idx)) = signal_code(sv.sys, m.sig_id, r.version) else {
                stats.drop(&format!(
                    "{} sigId {} (no RINEX 3 slot)",
                    sv.sys.letter(),
                    m.sig_id
                ));
                continue;
            };
            let t = f64::from(r.week) * crate::time::WEEK_SECONDS + r.rcv_tow;
            let s = self.signal(sv, idx, code, m, (cp_max, t));
            let k = match e.sats.iter().position(|x| x.sv == sv) {
                Some(k) => k,
                None => {
                    e.sats.push(RawSat {
                        sv,
                        sig: [None; SLOTS],
                    });
                    e.sats.len() - 1
                }
            };
            e.sats[k].sig[idx] = Some(s);
        }
        self.carry_slips(&mut e);
        (!e.sats.is_empty()).then_some(e)
    }

    /// Values and LLI of one measurement, updating the lock state of its slot.
    fn signal(
        &mut self,
        sv: Sv,
        idx: usize,
        code: [u8; 2],
        m: &RawxMeas,
        (cp_max, t): (u8, f64),
    ) -> RawSignal {
        let pr = if m.pr_valid() { m.pr } else { 0.0 };
        let mut cp = m.cp;
        if !m.cp_valid() || cp == -0.5 || m.cp_stdev > cp_max {
            cp = 0.0;
        }
        let geo = sv.sys == Constellation::BeiDou && (sv.prn <= 5 || sv.prn >= 59);
        if geo && cp != 0.0 {
            cp += 0.5;
        }
        let half_valid = if sv.sys == Constellation::Sbas {
            m.locktime > 8000
        } else {
            m.half_cyc()
        };
        let halfc = m.sub_half_cyc();
        let st = self.locks.get_mut(sv, idx);
        let lockt = m.locktime as f64 * 1e-3;
        // The lock time should have grown by the time since the signal's previous epoch.
        let grown = st.last.map(|l| (st.lockt + (t - l)).min(LOCK_MAX_S));
        let short = grown.is_some_and(|g| lockt < g - LOCK_TOLERANCE_S);
        let slip =
            m.locktime == 0 || lockt < st.lockt || short || halfc != st.halfc || m.cp_stdev >= 15;
        if slip {
            st.pending = true;
        }
        st.lockt = lockt;
        st.last = Some(t);
        let mut lli = if !half_valid && cp != 0.0 { 2 } else { 0 };
        if halfc != st.halfc {
            lli |= 1;
        }
        st.halfc = halfc;
        if cp != 0.0 {
            if st.pending {
                lli |= 1;
            }
            st.pending = false;
        }
        RawSignal {
            code,
            pr,
            cp,
            doppler: m.doppler as f64,
            cno: m.cno as f64,
            lli,
        }
    }

    /// convbin's save/restore of slips: a slip on a slot without phase goes to its next phase.
    fn carry_slips(&mut self, e: &mut RawEpoch) {
        for s in &mut e.sats {
            for (idx, g) in s.sig.iter_mut().enumerate() {
                let Some(g) = g else { continue };
                let st = self.locks.get_mut(s.sv, idx);
                if g.lli & 1 != 0 {
                    st.slip_carry = true;
                }
                if g.cp != 0.0 && st.slip_carry {
                    g.lli |= 1;
                    st.slip_carry = false;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meas(lock: u16, trk: u8) -> RawxMeas {
        RawxMeas {
            pr: 2.1e7,
            cp: 1.1e8,
            doppler: -100.5,
            gnss_id: 0,
            sv_id: 5,
            sig_id: 0,
            freq_id: 0,
            locktime: lock,
            cno: 40,
            pr_stdev: 3,
            cp_stdev: 2,
            do_stdev: 3,
            trk_stat: trk,
        }
    }
    fn rawx(m: RawxMeas) -> Rawx {
        Rawx {
            rcv_tow: 100.0,
            week: 2300,
            leap_s: 18,
            leap_valid: true,
            clk_reset: false,
            version: 1,
            meas: vec![m],
        }
    }

    /// Across a gap of the log, a lock time that grew by less than the gap is a slip (the
    /// loop locked again inside it), where convbin's rule (only a lock time that went back)
    /// sees none; one that grew by the gap, or sits at the counter's ceiling, is not.
    #[test]
    fn a_lock_time_short_of_the_gap_is_a_slip() {
        let mut c = RawxConverter::new();
        let mut st = RawStats::default();
        let mut at = |tow: f64, lock: u16| {
            let mut r = rawx(meas(lock, 7));
            r.rcv_tow = tow;
            c.epoch(&r, &mut st).unwrap().sats[0].sig[0].unwrap().lli
        };
        assert_eq!(at(100.0, 1000), 0);
        assert_eq!(at(110.0, 5000), 1); // 10 s on, locked for 5 s only
        assert_eq!(at(120.0, 15_000), 0);
        assert_eq!(at(121.0, 15_800), 0); // within the tolerance
        assert_eq!(at(200.0, 64_500), 0); // the ceiling
        assert_eq!(at(260.0, 64_500), 0);
    }

    #[test]
    fn lli_follows_lock_time_and_half_cycle() {
        let mut c = RawxConverter::new();
        let mut st = RawStats::default();
        let lli = |c: &mut RawxConverter, st: &mut RawStats, m| {
            c.epoch(&rawx(m), st).unwrap().sats[0].sig[0].unwrap().lli
        };
        assert_eq!(lli(&mut c, &mut st, meas(0, 7)), 1); // lock time 0: slip
        assert_eq!(lli(&mut c, &mut st, meas(1000, 7)), 0);
        assert_eq!(lli(&mut c, &mut st, meas(2000, 3)), 2); // half cycle unresolved
        assert_eq!(lli(&mut c, &mut st, meas(500, 7)), 1); // lock time went back
        assert_eq!(lli(&mut c, &mut st, meas(1500, 15)), 1); // subHalfCyc changed
                                                             // A slip without phase is carried to the next phase.
        let e = c.epoch(&rawx(meas(0, 1)), &mut st).unwrap();
        assert_eq!(e.sats[0].sig[0].unwrap().cp, 0.0);
        assert_eq!(lli(&mut c, &mut st, meas(3000, 15)), 1);
        assert_eq!(lli(&mut c, &mut st, meas(4000, 15)), 0);
        let mut w0 = rawx(meas(1, 7));
        w0.week = 0;
        assert!(c.epoch(&w0, &mut st).is_none());
        assert_eq!(st.epochs_without_time, 1);
    }

    #[test]
    fn signal_codes() {
        use Constellation::*;
        assert_eq!(signal_code(Gps, 3, 1), Some((*b"2X", 1)));
        assert_eq!(signal_code(Galileo, 0, 1), Some((*b"1X", 0)));
        assert_eq!(signal_code(Galileo, 6, 1), Some((*b"7X", 1)));
        assert_eq!(signal_code(BeiDou, 0, 1), Some((*b"2I", 0)));
        // X20: B3I, B1C (pilot, data) and E6 in the RINEX 3.04 slots convbin leaves out.
        assert_eq!(signal_code(BeiDou, 4, 1), Some((*b"6I", 3)));
        assert_eq!(signal_code(BeiDou, 5, 1), Some((*b"1P", 4)));
        assert_eq!(signal_code(BeiDou, 6, 1), Some((*b"1D", 4)));
        assert_eq!(signal_code(Galileo, 8, 1), Some((*b"6B", 3)));
        assert_eq!(signal_code(BeiDou, 9, 1), None);
        assert_eq!(signal_code(Sbas, 0, 1), Some((*b"1C", 0)));
    }
}
