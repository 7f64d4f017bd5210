//! SBF MeasEpoch measurements to observation epochs: SVIDs to satellites, signal numbers to
//! RINEX 3 codes, carrier phase in cycles, Type-2 Doppler from the master's, and the
//! loss-of-lock indicator from the lock time.
//!
//! What enters: decoded [`MeasEpoch`] blocks in file order. What leaves: [`RawEpoch`]s as the
//! UBX and RTCM 3 paths make them (the band slots `ubx_obs::SLOTS` per satellite) and, in [`RawStats`], every
//! measurement dropped with its reason. State kept across epochs: per satellite and signal,
//! the last lock time and a slip waiting for the next phase.
//!
//! Rules (SBF reference guide §4.1.9 and §4.1.10; checked against RTKLIB `septentrio.c`):
//! - SVIDs: 1–37 GPS, 38–61 GLONASS slots 1–24 (62 an unknown slot: dropped), 63–68 slots
//!   25–30, 71–106 Galileo, 120–140 SBAS, 141–180 BeiDou 1–40, 181–190 QZSS, 191–197 NavIC
//!   1–7, 198–215 SBAS 141–158, 216–222 NavIC 8–14, 223–245 BeiDou 41–63;
//! - signals take the codes RTKLIB and Septentrio's own converter give them: GPS L1 C/A 1C,
//!   L1P 1W, L2P 2W, L2C 2L, L5 5Q, L1C 1L; GLONASS 1C, 1P, 2P, 2C, L3 3Q; Galileo E1 1C, E6
//!   6C, E5a 5Q, E5b 7Q, AltBOC 8Q; BeiDou B1I 2I, B2I 7I, B3I 6I, B1C 1P, B2a 5P, B2b 7D;
//!   QZSS 1C, 2L, 5Q, 6L, 1L, 1Z, 1E, 5P; SBAS 1C, 5I; NavIC 5A, 9A. Each satellite has the
//!   slots by band of the UBX and RTCM 3 paths; a signal of another band is dropped and
//!   counted, and of two signals of one band the lower signal number is kept (L1 C/A before
//!   L1P, L2P before L2C, as RTKLIB keeps them first);
//! - carrier phase = pseudorange / λ + the carrier field, in cycles, and only with a
//!   pseudorange, a known wavelength (GLONASS FDMA: the frequency number of the Type-1
//!   sub-block) and a lock time that is not do-not-use (Type-1; RTKLIB's rule too);
//! - a Type-2 Doppler is the master's scaled by the frequency ratio plus its offset;
//! - LLI bit 0 when the lock time is 0 or shorter than the signal's last (a Type-2 lock time
//!   is clipped at 254 s, so it is compared with the last clipped the same way); a slip seen
//!   on a measurement without phase is carried to the signal's next phase; LLI bit 1 when
//!   ObsInfo bit 2 (half-cycle ambiguity) is set;
//! - only the main antenna's measurements are used; an epoch flagged scrambled (no
//!   measurement-availability permission) is dropped whole, as RTKLIB does.

use super::rtcm_msm::band_slot;
use super::sbf_meas::{MeasEpoch, SigMeas};
use super::ubx_obs::{RawEpoch, RawSat, RawSignal};
use super::RawStats;
use crate::signal::frequency;
use crate::sv::{Constellation, Sv};

/// Speed of light, m/s.
const C: f64 = 299_792_458.0;

/// The satellite of an SBF SVID; `None` for SVIDs that name none (0, unknown GLONASS slot,
/// L-band, reserved).
pub fn satellite(svid: u8) -> Option<Sv> {
    use Constellation::*;
    let (sys, prn) = match svid {
        1..=37 => (Gps, svid),
        38..=61 => (Glonass, svid - 37),
        63..=68 => (Glonass, svid - 38),
        71..=106 => (Galileo, svid - 70),
        120..=140 => (Sbas, svid - 100),
        141..=180 => (BeiDou, svid - 140),
        181..=190 => (Qzss, svid - 180),
        191..=197 => (Irnss, svid - 190),
        198..=215 => (Sbas, svid - 157),
        216..=222 => (Irnss, svid - 208),
        223..=245 => (BeiDou, svid - 182),
        _ => return None,
    };
    Some(Sv::new(sys, prn))
}

/// The SBF SVID of a satellite (the inverse of [`satellite`]); `None` when SBF has none.
pub fn svid(sv: Sv) -> Option<u8> {
    (1..=245u8).find(|&s| satellite(s) == Some(sv))
}

/// System and RINEX band+attribute of an SBF signal number; `None` for reserved numbers and
/// signals without a RINEX 3 code.
pub fn signal(sig: u8) -> Option<(Constellation, [u8; 2])> {
    use Constellation::*;
    let (sys, c): (Constellation, &[u8; 2]) = match sig {
        0 => (Gps, b"1C"),
        1 => (Gps, b"1W"),
        2 => (Gps, b"2W"),
        3 => (Gps, b"2L"),
        4 => (Gps, b"5Q"),
        5 => (Gps, b"1L"),
        6 => (Qzss, b"1C"),
        7 => (Qzss, b"2L"),
        8 => (Glonass, b"1C"),
        9 => (Glonass, b"1P"),
        10 => (Glonass, b"2P"),
        11 => (Glonass, b"2C"),
        12 => (Glonass, b"3Q"),
        13 => (BeiDou, b"1P"),
        14 => (BeiDou, b"5P"),
        15 => (Irnss, b"5A"),
        17 => (Galileo, b"1C"),
        19 => (Galileo, b"6C"),
        20 => (Galileo, b"5Q"),
        21 => (Galileo, b"7Q"),
        22 => (Galileo, b"8Q"),
        24 => (Sbas, b"1C"),
        25 => (Sbas, b"5I"),
        26 => (Qzss, b"5Q"),
        27 => (Qzss, b"6L"),
        28 => (BeiDou, b"2I"),
        29 => (BeiDou, b"7I"),
        30 => (BeiDou, b"6I"),
        32 => (Qzss, b"1L"),
        33 => (Qzss, b"1Z"),
        34 => (BeiDou, b"7D"),
        36 => (Irnss, b"9A"),
        38 => (Qzss, b"1E"),
        39 => (Qzss, b"5P"),
        _ => return None,
    };
    Some((sys, *c))
}

/// The band slot of a code: as [`band_slot`], with SBAS L1/L5 and NavIC L5 as the UBX path
/// places them.
pub fn slot(sys: Constellation, band: u8) -> Option<usize> {
    match (sys, band) {
        (Constellation::Sbas, b'1') | (Constellation::Irnss, b'5') => Some(0),
        (Constellation::Sbas, b'5') => Some(2),
        _ => band_slot(sys, band),
    }
}

/// Lock state of one signal.
#[derive(Clone, Copy, Default)]
struct Lock {
    last: Option<u16>,
    pending: bool,
}

/// The converter's state across epochs.
#[derive(Default)]
pub struct SbfConverter {
    /// Lock state per SVID and signal number (`svid << 6 | sig`: a flat table rather than a
    /// hash map, which cost a tenth of the conversion).
    locks: Vec<Lock>,
}

/// The lock-table index of an SVID and signal number (0..=63).
fn lock_key(svid: u8, sig: u8) -> usize {
    (svid as usize) << 6 | (sig as usize & 63)
}

/// A signal of one satellite placed in a slot, before the slots are filled.
struct Placed {
    sig: u8,
    slot: usize,
    signal: RawSignal,
}

impl SbfConverter {
    /// A converter with no history.
    pub fn new() -> Self {
        Self::default()
    }

    /// Convert one MeasEpoch; `None` for epochs without a time and epochs left empty.
    pub fn epoch(&mut self, m: &MeasEpoch, stats: &mut RawStats) -> Option<RawEpoch> {
        let (Some(tow), Some(week)) = (m.tow_ms, m.wnc) else {
            stats.epochs_without_time += 1;
            return None;
        };
        if m.flags & 0x80 != 0 {
            stats.drop("MeasEpoch scrambled (no measurement-availability permission): epoch");
            return None;
        }
        let mut e = RawEpoch {
            week,
            tow: tow as f64 * 1e-3,
            sats: Vec::new(),
            glonass: Vec::new(),
        };
        for s in &m.sats {
            let Some(sv) = satellite(s.svid) else {
                stats.drop("unknown SVID (no satellite)");
                continue;
            };
            if let (Constellation::Glonass, Some(ch)) = (sv.sys, s.fcn) {
                if !e.glonass.iter().any(|g| g.0 == sv.prn) {
                    e.glonass.push((sv.prn, ch));
                }
            }
            let mut placed = self.satellite_signals(sv, s.svid, s.fcn, &s.sigs, stats);
            placed.sort_by_key(|p| p.sig);
            let mut sat = RawSat {
                sv,
                sig: [None; crate::raw::ubx_obs::SLOTS],
            };
            for p in placed {
                if sat.sig[p.slot].is_some() {
                    stats.drop("second signal of a band (the lower signal number kept)");
                    continue;
                }
                sat.sig[p.slot] = Some(p.signal);
            }
            if sat.sig.iter().any(Option::is_some) {
                e.sats.push(sat);
            }
        }
        (!e.sats.is_empty()).then_some(e)
    }

    /// The signals of one satellite with their slots; the dropped ones counted.
    fn satellite_signals(
        &mut self,
        sv: Sv,
        svid: u8,
        fcn: Option<i8>,
        sigs: &[SigMeas],
        stats: &mut RawStats,
    ) -> Vec<Placed> {
        let master = sigs.first().and_then(|g| {
            let (_, code) = signal(g.sig)?;
            Some((frequency(sv.sys, code[0], fcn)?, g.doppler?))
        });
        let mut out = Vec::with_capacity(sigs.len());
        for g in sigs {
            if g.antenna != 0 {
                stats.drop("auxiliary antenna");
                continue;
            }
            let code = match signal(g.sig) {
                Some((sys, code)) if sys == sv.sys => code,
                _ => {
                    stats.drop(&format!("{} signal number {}", sv.sys.letter(), g.sig));
                    continue;
                }
            };
            let Some(slot) = slot(sv.sys, code[0]) else {
                stats.drop(&format!(
                    "{} {} (no RINEX slot)",
                    sv.sys.letter(),
                    String::from_utf8_lossy(&code)
                ));
                continue;
            };
            let f = frequency(sv.sys, code[0], fcn);
            let doppler = if g.type2 {
                match (master, f, g.doppler) {
                    (Some((f1, d1)), Some(f2), Some(off)) => Some(d1 * f2 / f1 + off),
                    _ => None,
                }
            } else {
                g.doppler
            };
            let cp = match (g.pr, g.carrier, f) {
                (Some(pr), Some(c), Some(f)) if g.type2 || g.lock.is_some() => pr * f / C + c,
                _ => 0.0,
            };
            let lli = self.lli(lock_key(svid, g.sig), g, cp != 0.0);
            out.push(Placed {
                sig: g.sig,
                slot,
                signal: RawSignal {
                    code,
                    pr: g.pr.unwrap_or(0.0),
                    cp,
                    doppler: doppler.unwrap_or(0.0),
                    cno: g.cn0.unwrap_or(0.0),
                    lli,
                },
            });
        }
        out
    }

    /// The loss-of-lock indicator of one measurement, updating the signal's lock state.
    fn lli(&mut self, key: usize, g: &SigMeas, phase: bool) -> u8 {
        if self.locks.is_empty() {
            self.locks = vec![Lock::default(); 1 << 14];
        }
        let st = &mut self.locks[key & 0x3fff];
        if let Some(lock) = g.lock {
            let cap = if g.type2 { 254 } else { u16::MAX };
            if lock == 0 || st.last.is_some_and(|l| lock < l.min(cap)) {
                st.pending = true;
            }
            st.last = Some(lock);
        }
        if !phase {
            return 0;
        }
        let slip = std::mem::take(&mut st.pending);
        u8::from(slip) | u8::from(g.half) << 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::sbf_meas::SatMeas;

    fn sig(sig: u8, lock: Option<u16>, type2: bool) -> SigMeas {
        SigMeas {
            sig,
            antenna: 0,
            pr: Some(20_000_000.0),
            carrier: Some(-1.5),
            doppler: Some(if type2 { 0.25 } else { -1000.0 }),
            cn0: Some(45.0),
            lock,
            half: false,
            type2,
        }
    }

    fn epoch(sigs: Vec<SigMeas>) -> MeasEpoch {
        MeasEpoch {
            tow_ms: Some(1000),
            wnc: Some(2300),
            flags: 0,
            sats: vec![SatMeas {
                svid: 12,
                fcn: None,
                sigs,
            }],
        }
    }

    #[test]
    fn svids_and_signals() {
        assert_eq!(satellite(40), Some(Sv::new(Constellation::Glonass, 3)));
        assert_eq!(satellite(62), None);
        assert_eq!(satellite(64), Some(Sv::new(Constellation::Glonass, 26)));
        assert_eq!(satellite(71), Some(Sv::new(Constellation::Galileo, 1)));
        assert_eq!(satellite(181), Some(Sv::new(Constellation::Qzss, 1)));
        assert_eq!(satellite(230), Some(Sv::new(Constellation::BeiDou, 48)));
        assert_eq!(satellite(200), Some(Sv::new(Constellation::Sbas, 43)));
        assert_eq!(svid(Sv::new(Constellation::Galileo, 36)), Some(106));
        assert_eq!(signal(2), Some((Constellation::Gps, *b"2W")));
        assert_eq!(signal(21), Some((Constellation::Galileo, *b"7Q")));
        assert_eq!(signal(16), None);
    }

    #[test]
    fn phase_doppler_and_slots() {
        let mut c = SbfConverter::new();
        let mut st = RawStats::default();
        // L1 C/A (Type-1), L2P and L2C (Type-2): L2C dropped, the lower number kept
        let e = c
            .epoch(
                &epoch(vec![
                    sig(0, Some(30), false),
                    sig(3, Some(30), true),
                    sig(2, Some(30), true),
                ]),
                &mut st,
            )
            .unwrap();
        let s = &e.sats[0];
        assert_eq!(s.sv, Sv::new(Constellation::Gps, 12));
        let (l1, l2) = (s.sig[0].unwrap(), s.sig[1].unwrap());
        assert_eq!(l2.code, *b"2W");
        // 20000 km over λ(L1) = 299792458 / 1575.42e6 m, minus 1.5 cycles
        let want = 20_000_000.0 * 1575.42e6 / C - 1.5;
        assert!((l1.cp - want).abs() < 1e-6, "{}", l1.cp);
        // Type-2 Doppler: −1000 Hz × 1227.6/1575.42 + 0.25
        assert!((l2.doppler - (-1000.0 * 1227.6 / 1575.42 + 0.25)).abs() < 1e-9);
        assert_eq!(st.dropped.values().sum::<u64>(), 1);
    }

    #[test]
    fn lli_follows_lock_time_and_half_cycle() {
        let mut c = SbfConverter::new();
        let mut st = RawStats::default();
        let mut lli = |g: SigMeas| {
            c.epoch(&epoch(vec![g]), &mut st).unwrap().sats[0].sig[0]
                .unwrap()
                .lli
        };
        assert_eq!(lli(sig(0, Some(0), false)), 1); // lock time 0: new lock
        assert_eq!(lli(sig(0, Some(1), false)), 0);
        assert_eq!(lli(sig(0, Some(5), false)), 0);
        assert_eq!(lli(sig(0, Some(3), false)), 1); // went back
        let mut h = sig(0, Some(4), false);
        h.half = true;
        assert_eq!(lli(h), 2);
        // a slip without phase waits for the next phase
        let mut np = sig(0, Some(0), false);
        np.carrier = None;
        assert_eq!(lli(np), 0);
        assert_eq!(lli(sig(0, Some(1), false)), 1);
        assert_eq!(lli(sig(0, Some(2), false)), 0);
    }

    #[test]
    fn type2_lock_time_clipped_at_254_is_no_slip() {
        let mut c = SbfConverter::new();
        let mut st = RawStats::default();
        let k = lock_key(1, 2);
        let t1 = sig(0, Some(400), false);
        assert_eq!(c.lli(k, &t1, true), 0);
        let t2 = sig(2, Some(254), true);
        assert_eq!(c.lli(k, &t2, true), 0);
        let t2 = sig(2, Some(12), true);
        assert_eq!(c.lli(k, &t2, true), 1);
        let mut m = epoch(vec![sig(0, Some(1), false)]);
        m.flags = 0x80;
        assert!(c.epoch(&m, &mut st).is_none());
    }
}
