//! Raw items into RINEX records, the same whether they are written to a file or kept in
//! memory: the observation types of the header, each epoch's satellites aligned with them,
//! and camera events placed as convbin places them.
//!
//! What enters: [`RawItem`]s in file order. What leaves: [`RinexOut`]s in RINEX order, and
//! the header's types and span from a [`Scan`].

use super::items::{gpst, gpst_ns, EventMark, RawItem};
use super::ubx_obs::{RawEpoch, RawSignal};
use crate::error::{Error, Result};
use crate::rinex::{Obs, ObsCode, SatObs};
use crate::sv::Constellation;
use hifitime::Epoch;
use std::collections::BTreeMap;
use std::path::Path;

/// A signal's system (index), band slot and RINEX code.
type SlotCode = (usize, usize, [u8; 2]);

/// Observation types per system from the first pass: per slot, the code and which of C, L,
/// D, S ever had a value.
#[derive(Default)]
pub struct Scan {
    /// (system, slot, code) and its mask, in the order first seen (a few dozen at most: a
    /// search of this list is cheaper than a tree's for every signal of every epoch).
    codes: Vec<(SlotCode, u8)>,
    /// GLONASS slots and their frequency channels.
    pub glonass: BTreeMap<u8, i8>,
    /// Time of the first epoch.
    pub first: Option<Epoch>,
    /// Time of the last epoch.
    pub last: Option<Epoch>,
}

impl Scan {
    /// Take in one epoch.
    pub fn add(&mut self, e: &RawEpoch) {
        let t = gpst(e.week, e.tow);
        self.first.get_or_insert(t);
        self.last = Some(t);
        for &(s, c) in &e.glonass {
            self.glonass.entry(s).or_insert(c);
        }
        for s in &e.sats {
            for (idx, g) in s.sig.iter().enumerate() {
                let Some(g) = g else { continue };
                let key = (s.sv.sys.index(), idx, g.code);
                let k = match self.codes.iter().position(|(c, _)| *c == key) {
                    Some(k) => k,
                    None => {
                        self.codes.push((key, 0));
                        self.codes.len() - 1
                    }
                };
                self.codes[k].1 |= u8::from(g.pr != 0.0)
                    | u8::from(g.cp != 0.0) << 1
                    | u8::from(g.doppler != 0.0) << 2
                    | u8::from(g.cno != 0.0) << 3;
            }
        }
    }

    /// Observation types per system, in RTKLIB's order of systems.
    pub fn types(&self) -> Vec<(Constellation, Vec<ObsCode>)> {
        let mut out: Vec<(Constellation, Vec<ObsCode>)> = Vec::new();
        let mut codes = self.codes.clone();
        codes.sort_unstable();
        for sys in RINEX_ORDER {
            let mut v = Vec::new();
            for &((s, _, code), mask) in &codes {
                if s != sys.index() {
                    continue;
                }
                for (j, k) in b"CLDS".iter().enumerate() {
                    if mask & (1 << j) != 0 {
                        v.push(ObsCode([*k, code[0], code[1]]));
                    }
                }
            }
            if !v.is_empty() {
                out.push((sys, v));
            }
        }
        out
    }
}

/// Systems in the order RTKLIB writes them.
const RINEX_ORDER: [Constellation; 7] = [
    Constellation::Gps,
    Constellation::Glonass,
    Constellation::Galileo,
    Constellation::Qzss,
    Constellation::Sbas,
    Constellation::BeiDou,
    Constellation::Irnss,
];

/// A signal's observation of `kind` (C, L, D or S): blank (NaN) where the value is 0, the
/// LLI on phase only.
fn observation(g: &RawSignal, kind: u8) -> Obs {
    let (v, lli) = match kind {
        b'C' => (g.pr, 0),
        b'L' => (g.cp, g.lli & 3),
        b'D' => (g.doppler, 0),
        _ => (g.cno, 0),
    };
    Obs {
        value: if v == 0.0 { f64::NAN } else { v },
        lli,
        ssi: 0,
    }
}

/// One epoch's satellites aligned with the header's types; satellites with none are left out
/// (an epoch left with none is not a RINEX record).
pub fn sat_records(e: &RawEpoch, types: &[(Constellation, Vec<ObsCode>)]) -> Vec<SatObs> {
    let mut out = Vec::new();
    for s in &e.sats {
        let Some((_, ts)) = types.iter().find(|(sys, _)| *sys == s.sv.sys) else {
            continue;
        };
        let mut any = false;
        let obs = ts
            .iter()
            .map(|t| {
                let g = s
                    .sig
                    .iter()
                    .flatten()
                    .find(|g| g.code == [t.band(), t.attribute()]);
                let Some(g) = g else { return Obs::MISSING };
                any = true;
                observation(g, t.kind())
            })
            .collect();
        if any {
            out.push(SatObs { sv: s.sv, obs });
        }
    }
    out
}

/// One epoch as the RINEX text [`crate::rinex::write::write_epoch`] writes of its
/// [`sat_records`], formatted straight from the raw epoch (nothing allocated per satellite);
/// nothing when no satellite has an observation of the header's types.
pub fn write_raw_epoch(
    text: &mut Vec<u8>,
    t: Epoch,
    e: &RawEpoch,
    types: &[(Constellation, Vec<ObsCode>)],
) {
    use crate::rinex::write::{count3, epoch_line, put_obs_field, sv_field, write_epoch};
    let start = text.len();
    epoch_line(text, t, 0);
    let body = text.len();
    let (mut n, mut wide) = (0usize, false);
    for s in &e.sats {
        let Some((_, ts)) = types.iter().find(|(sys, _)| *sys == s.sv.sys) else {
            continue;
        };
        let line = text.len();
        sv_field(text, s.sv);
        let cols = text.len();
        text.resize(cols + 16 * ts.len(), b' ');
        let mut any = false;
        // the last slot first, so that the first signal of a code is the one left (as
        // `sat_records` finds it)
        for g in s.sig.iter().rev().flatten() {
            for (j, ty) in ts.iter().enumerate() {
                if [ty.band(), ty.attribute()] != g.code {
                    continue;
                }
                any = true;
                let o = observation(g, ty.kind());
                let f = &mut text[cols + 16 * j..cols + 16 * (j + 1)];
                if let Ok(f) = <&mut [u8; 16]>::try_from(f) {
                    wide |= !put_obs_field(f, o.value, o.lli, o.ssi);
                }
            }
        }
        if any {
            text.push(b'\n');
            n += 1;
        } else {
            text.truncate(line);
        }
    }
    if wide {
        // a value wider than its field: the epoch as the general writer lays it out
        text.truncate(start);
        let _ = write_epoch(text, t, &sat_records(e, types));
        return;
    }
    match n {
        0 => text.truncate(start),
        1..=999 => {
            // the count field of the opening line, 3 wide after `> date  0`
            text[start + 32..start + 35].copy_from_slice(&count3(n));
        }
        _ => {
            let sats = text.split_off(body);
            text.truncate(start);
            epoch_line(text, t, n);
            text.extend_from_slice(&sats);
        }
    }
}

/// The first and last epoch of a scan, or the error saying the log has no usable epoch.
pub fn span(scan: &Scan, input: &Path) -> Result<(Epoch, Epoch)> {
    match (scan.first, scan.last) {
        (Some(a), Some(b)) => Ok((a, b)),
        _ => Err(Error::input(
            input,
            "no measurement epoch with a known GPS week: for UBX enable RXM-RAWX output on \
             the receiver and log after it has acquired time; for RTCM 3 log MSM4/5/6/7 \
             together with an ephemeris message (1019, 1042, 1045 or 1046) that gives the week; \
             for SBF log the MeasEpoch block (Meas3 blocks are not read)",
        )),
    }
}

/// One RINEX record of a log.
pub enum RinexOut {
    /// An observation epoch (flag 0) and its satellites, not yet aligned with the header's
    /// types ([`sat_records`] does that; an epoch it leaves empty is no record).
    Epoch(Epoch, RawEpoch),
    /// A flag-5 event with its comment lines.
    Event(Epoch, Vec<String>),
}

/// Puts a log's items in RINEX order: a time mark that is a record (UBX: its falling edge, as
/// convbin; SBF: every event) goes before the first epoch not earlier than it; every edge is kept in `marks` for the CSV.
#[derive(Default)]
pub struct RinexOrder {
    /// Events not yet written, by time (GPST ns) and arrival: released in O(log n) each, so a
    /// log of many future-dated marks does not cost marks × epochs.
    pending: BTreeMap<(u64, u64), EventMark>,
    /// Events received so far (the arrival part of `pending`'s key).
    arrivals: u64,
    /// Every time-mark edge, in file order.
    pub marks: Vec<EventMark>,
}

impl RinexOrder {
    /// Take one item; hand the records it completes to `out`.
    pub fn item<E>(
        &mut self,
        it: RawItem,
        out: &mut impl FnMut(RinexOut) -> std::result::Result<(), E>,
    ) -> std::result::Result<(), E> {
        match it {
            RawItem::Event(ev) => {
                self.marks.push(ev);
                if ev.record {
                    self.arrivals += 1;
                    let key = (gpst_ns(ev.week, ev.tow), self.arrivals);
                    self.pending.insert(key, ev);
                }
            }
            RawItem::Ephemeris(_)
            | RawItem::GpsIono(..)
            | RawItem::BdsIono(_)
            | RawItem::Fix(_) => {}
            RawItem::Epoch(e) => {
                let t = gpst(e.week, e.tow);
                let t_ns = gpst_ns(e.week, e.tow);
                while let Some(due) = self.pending.first_entry() {
                    if due.key().0 > t_ns {
                        break;
                    }
                    out(mark(&due.remove()))?;
                }
                out(RinexOut::Epoch(t, e))?;
            }
        }
        Ok(())
    }

    /// The events after the last epoch.
    pub fn finish<E>(
        &mut self,
        out: &mut impl FnMut(RinexOut) -> std::result::Result<(), E>,
    ) -> std::result::Result<(), E> {
        for m in std::mem::take(&mut self.pending).into_values() {
            out(mark(&m))?;
        }
        Ok(())
    }
}

fn mark(m: &EventMark) -> RinexOut {
    let c = if m.valid {
        vec![]
    } else {
        vec![" Time mark is not valid".to_string()]
    };
    RinexOut::Event(gpst(m.week, m.tow), c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::ubx_obs::{RawSat, RawSignal};
    use crate::sv::Sv;

    /// Marks go before the first epoch not earlier than them, by time; 50,000 marks dated
    /// after every epoch wait without being looked at per epoch (they cost marks × epochs).
    #[test]
    fn marks_are_released_in_time_before_their_epoch() {
        let mark = |tow: f64| {
            RawItem::Event(EventMark {
                week: 2300,
                tow,
                edge: crate::raw::items::Edge::Falling,
                count: 0,
                valid: true,
                record: true,
            })
        };
        let epoch = |tow: f64| {
            RawItem::Epoch(RawEpoch {
                week: 2300,
                tow,
                sats: Vec::new(),
                glonass: Vec::new(),
            })
        };
        let mut order = RinexOrder::default();
        let mut got: Vec<(char, f64)> = Vec::new();
        let mut out = |o: RinexOut| -> std::result::Result<(), ()> {
            let (c, t) = match o {
                RinexOut::Epoch(t, _) => ('E', t),
                RinexOut::Event(t, _) => ('M', t),
            };
            got.push((c, crate::time::week_tow(t).1));
            Ok(())
        };
        for it in [mark(10.5), mark(9.5), mark(30.0), epoch(10.0), epoch(11.0)] {
            order.item(it, &mut out).unwrap();
        }
        for k in 0..50_000 {
            order.item(mark(500_000.0 + k as f64), &mut out).unwrap();
        }
        for k in 0..50_000 {
            order
                .item(epoch(12.0 + k as f64 * 0.001), &mut out)
                .unwrap();
        }
        order.finish(&mut out).unwrap();
        assert_eq!(
            &got[..4],
            &[('M', 9.5), ('E', 10.0), ('M', 10.5), ('E', 11.0)],
            "released by time before the first epoch not earlier"
        );
        assert_eq!(got.len(), 4 + 50_000 + 1 + 50_000);
        assert_eq!(got[4], ('E', 12.0));
        let i = got.iter().position(|g| *g == ('M', 30.0)).unwrap();
        assert!(got[i - 1].1 < 30.0 && got[i + 1].0 == 'E' && got[i + 1].1 >= 30.0);
        let tail = &got[got.len() - 50_000..];
        assert!(
            tail[0] == ('M', 500_000.0),
            "the future marks at the end, by time"
        );
        assert!(tail.windows(2).all(|w| w[0].1 < w[1].1 && w[1].0 == 'M'));
    }

    /// `write_raw_epoch` gives the bytes of `sat_records` + `write_epoch`, on random epochs
    /// with hostile values (zeros, ties, ±10⁹ and beyond, NaN, infinities, PRN ≥ 100).
    #[test]
    fn raw_epochs_print_as_their_records() {
        let mut x: u64 = 0x853C_49E6_748F_EA9B;
        let mut rnd = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let special = [
            0.0,
            -0.0,
            0.0625,
            -999_999_999.999_6,
            999_999_999.999_6,
            -1_999_999_999.999_7,
            1e15,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let codes = [*b"1C", *b"2W", *b"5Q", *b"1X", *b"7Q"];
        let types: Vec<(Constellation, Vec<ObsCode>)> =
            [Constellation::Gps, Constellation::Galileo]
                .into_iter()
                .map(|sys| {
                    let v = [*b"1C", *b"2W", *b"5Q", *b"7Q"]
                        .iter()
                        .flat_map(|c| b"CLDS".iter().map(move |k| ObsCode([*k, c[0], c[1]])))
                        .collect();
                    (sys, v)
                })
                .collect();
        for k in 0..3000 {
            let value = |r: u64| match r % 5 {
                0 => special[(r >> 8) as usize % special.len()],
                1 => (r >> 11) as f64 / (1u64 << 53) as f64 * 4e9 - 2e9,
                _ => ((r >> 11) % 4_000_000_000) as f64 / 16.0,
            };
            let sats = (0..rnd() % 30)
                .map(|_| {
                    let sys = [
                        Constellation::Gps,
                        Constellation::Galileo,
                        Constellation::BeiDou,
                    ][rnd() as usize % 3];
                    let mut sig = [None; crate::raw::ubx_obs::SLOTS];
                    for g in sig.iter_mut() {
                        if rnd() % 3 > 0 {
                            *g = Some(RawSignal {
                                code: codes[rnd() as usize % codes.len()],
                                pr: value(rnd()),
                                cp: value(rnd()),
                                doppler: value(rnd()),
                                cno: value(rnd()),
                                lli: (rnd() % 4) as u8,
                            });
                        }
                    }
                    RawSat {
                        sv: Sv::new(sys, (rnd() % 120) as u8),
                        sig,
                    }
                })
                .collect();
            let e = RawEpoch {
                week: 2300,
                tow: k as f64 * 0.1,
                sats,
                glonass: Vec::new(),
            };
            let t = super::super::items::gpst(e.week, e.tow);
            let mut fast = Vec::new();
            write_raw_epoch(&mut fast, t, &e, &types);
            let mut slow = Vec::new();
            let recs = sat_records(&e, &types);
            if !recs.is_empty() {
                crate::rinex::write::write_epoch(&mut slow, t, &recs).unwrap();
            }
            assert_eq!(
                String::from_utf8_lossy(&fast),
                String::from_utf8_lossy(&slow),
                "epoch {k}"
            );
        }
    }
}
