//! `convert`: a raw log to a RINEX 3.04 observation file (and its camera events to CSV).
//!
//! What enters: the path of a log and its format (detected from content when not given).
//! What leaves: the RINEX file and the optional CSV, each written atomically, and the
//! [`RawStats`] of the conversion. The log is read twice (first for the header's observation
//! types and time span, then to write), so memory stays bounded whatever the log's size.

use super::ubx::{self, FrameReader, Tm2};
use super::ubx_obs::{RawEpoch, RawxConverter};
use super::{detect, RawFormat, RawStats};
use crate::error::{Error, Result};
use crate::rinex::write::{self, HeaderOut};
use crate::rinex::{Obs, ObsCode, SatObs};
use crate::solution::write_atomic;
use crate::sv::Constellation;
use hifitime::Epoch;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read, Write};
use std::path::Path;

/// Which edge of a time-mark pulse.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    /// Rising edge.
    Rising,
    /// Falling edge.
    Falling,
}

/// One time-mark edge of TIM-TM2: a camera event.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventMark {
    /// GPS week.
    pub week: u16,
    /// GPS time of week, seconds (converted from UTC when the receiver reported UTC).
    pub tow: f64,
    /// The edge.
    pub edge: Edge,
    /// The receiver's edge counter.
    pub count: u16,
    /// The receiver marked the time valid.
    pub valid: bool,
}

/// One item of a raw log, in file order.
#[derive(Clone, Debug)]
pub enum RawItem {
    /// A measurement epoch.
    Epoch(RawEpoch),
    /// A time-mark edge.
    Event(EventMark),
}

/// GPST epoch of a week and time of week.
pub fn gpst(week: u16, tow: f64) -> Epoch {
    let ticks = (tow * 1e7).round() as i64; // 100 ns, as RINEX prints
    let ns = week as i64 * 604_800_000_000_000 + ticks * 100;
    Epoch::from_gpst_nanoseconds(ns.max(0) as u64)
}

/// Read every item of a log, calling `f` on each; returns what was read and dropped.
pub fn for_each_item(
    path: &Path,
    format: Option<RawFormat>,
    mut f: impl FnMut(RawItem),
) -> Result<RawStats> {
    let io = Error::io(path);
    let mut file = BufReader::new(File::open(path).map_err(io)?);
    let format = match format {
        Some(fm) => fm,
        None => {
            let mut head = Vec::new();
            (&mut file)
                .take(1 << 16)
                .read_to_end(&mut head)
                .map_err(io)?;
            let fm = detect(&head).ok_or_else(|| {
                Error::input(
                    path,
                    "no UBX frame (B5 62 with a valid checksum) in the first 64 KiB: not a \
                     u-blox log; give a UBX log, or --format ubx to read it anyway",
                )
            })?;
            file = BufReader::new(File::open(path).map_err(io)?);
            fm
        }
    };
    let RawFormat::Ubx = format;
    let mut r = FrameReader::new(file);
    let mut st = RawStats::default();
    let mut conv = RawxConverter::new();
    let mut leap = 18i8;
    let mut last: Option<(u16, f64)> = None;
    while let Some(fr) = r.next_frame(&mut st).map_err(io)? {
        match (fr.class, fr.id) {
            (0x02, 0x15) => {
                let Some(x) = ubx::decode_rawx(fr.payload) else {
                    *st.malformed.entry("RXM-RAWX".into()).or_default() += 1;
                    continue;
                };
                if x.leap_valid {
                    leap = x.leap_s;
                }
                if let Some(e) = conv.epoch(&x, &mut st) {
                    let t = (e.week, e.tow);
                    if last.is_some_and(|l| (l.0, l.1) >= t) {
                        st.time_jumps += 1;
                    }
                    last = Some(t);
                    st.epochs += 1;
                    f(RawItem::Epoch(e));
                }
            }
            (0x0d, 0x03) => {
                let Some(t) = ubx::decode_tm2(fr.payload) else {
                    *st.malformed.entry("TIM-TM2".into()).or_default() += 1;
                    continue;
                };
                for ev in marks(&t, leap) {
                    st.events += 1;
                    f(RawItem::Event(ev));
                }
            }
            (c, i) => *st.unused.entry(ubx::type_name(c, i)).or_default() += 1,
        }
    }
    Ok(st)
}

/// The new edges of a TIM-TM2 message as events in GPST.
fn marks(t: &Tm2, leap: i8) -> Vec<EventMark> {
    let mut v = Vec::new();
    for (new, edge, (week, tow)) in [
        (t.new_rising, Edge::Rising, t.rising),
        (t.new_falling, Edge::Falling, t.falling),
    ] {
        if !new {
            continue;
        }
        let mut tow = tow;
        let mut week = week;
        if t.time_base == 2 {
            tow += leap as f64;
            if tow >= 604_800.0 {
                tow -= 604_800.0;
                week += 1;
            }
        }
        v.push(EventMark {
            week,
            tow,
            edge,
            count: t.count,
            valid: t.time_valid,
        });
    }
    v
}

/// Observation types per system from the first pass: per slot, the code and which of C, L,
/// D, S ever had a value.
#[derive(Default)]
struct Scan {
    codes: BTreeMap<(usize, usize, [u8; 2]), u8>,
    glonass: BTreeMap<u8, i8>,
    first: Option<Epoch>,
    last: Option<Epoch>,
}

impl Scan {
    fn add(&mut self, e: &RawEpoch) {
        let t = gpst(e.week, e.tow);
        self.first.get_or_insert(t);
        self.last = Some(t);
        for &(s, c) in &e.glonass {
            self.glonass.entry(s).or_insert(c);
        }
        for s in &e.sats {
            for (idx, g) in s.sig.iter().enumerate() {
                let Some(g) = g else { continue };
                let m = self
                    .codes
                    .entry((s.sv.sys.index(), idx, g.code))
                    .or_default();
                *m |= u8::from(g.pr != 0.0)
                    | u8::from(g.cp != 0.0) << 1
                    | u8::from(g.doppler != 0.0) << 2
                    | u8::from(g.cno != 0.0) << 3;
            }
        }
    }

    fn types(&self) -> Vec<(Constellation, Vec<ObsCode>)> {
        let mut out: Vec<(Constellation, Vec<ObsCode>)> = Vec::new();
        for sys in RINEX_ORDER {
            let mut v = Vec::new();
            for (&(s, _, code), &mask) in &self.codes {
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

/// One epoch's satellites aligned with the header's types; satellites with none are left out.
fn sat_records(e: &RawEpoch, types: &[(Constellation, Vec<ObsCode>)]) -> Vec<SatObs> {
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
                let (v, lli) = match t.kind() {
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
            })
            .collect();
        if any {
            out.push(SatObs { sv: s.sv, obs });
        }
    }
    out
}

/// Convert `input` to RINEX 3.04 at `out` (and the events to CSV at `events`).
pub fn convert(
    input: &Path,
    format: Option<RawFormat>,
    out: &Path,
    events: Option<&Path>,
) -> Result<RawStats> {
    let mut scan = Scan::default();
    for_each_item(input, format, |it| {
        if let RawItem::Epoch(e) = it {
            scan.add(&e)
        }
    })?;
    let (Some(first), Some(last)) = (scan.first, scan.last) else {
        return Err(Error::input(
            input,
            "no RXM-RAWX measurement epoch with a known GPS week: enable UBX-RXM-RAWX output \
             on the receiver, and log after it has acquired time",
        ));
    };
    let h = HeaderOut {
        program: "ppkat convert".into(),
        comments: vec![
            "format: u-blox UBX".into(),
            format!(
                "log: {}",
                input.file_name().unwrap_or_default().to_string_lossy()
            ),
        ],
        marker: String::new(),
        approx: [0.0; 3],
        types: scan.types(),
        first,
        last,
        glonass: scan.glonass.iter().map(|(&s, &c)| (s, c)).collect(),
    };
    let mut marks = Vec::new();
    // The second pass's own error (the log changed or became unreadable) is kept here and
    // the atomic write abandoned, so no partial file replaces OUT.
    let mut pass2: Option<Result<RawStats>> = None;
    let written = write_atomic(out, |w| {
        write::write_header(w, &h)?;
        let mut pending: Vec<EventMark> = Vec::new();
        let mut res = Ok(());
        let st = for_each_item(input, format, |it| {
            if res.is_ok() {
                res = write_item(w, it, &h.types, &mut pending, &mut marks);
            }
        });
        res?;
        let failed = st.is_err();
        pass2 = Some(st);
        if failed {
            return Err(std::io::Error::other(
                "reading the log a second time failed",
            ));
        }
        for ev in pending {
            write_mark(w, &ev)?;
        }
        Ok(())
    });
    if let Some(Err(e)) = pass2 {
        return Err(e);
    }
    written?;
    let st = match pass2 {
        Some(Ok(st)) => st,
        _ => return Err(Error::input(input, "internal: the second pass did not run")),
    };
    if let Some(p) = events {
        write_atomic(p, |w| {
            writeln!(w, "week,tow,edge,count,valid")?;
            for m in &marks {
                let edge = if m.edge == Edge::Rising {
                    "rising"
                } else {
                    "falling"
                };
                writeln!(w, "{},{:.9},{edge},{},{}", m.week, m.tow, m.count, m.valid)?;
            }
            Ok(())
        })?;
    }
    Ok(st)
}

/// Write one item: events (falling edges, as convbin) before the first epoch not earlier.
fn write_item(
    w: &mut dyn Write,
    it: RawItem,
    types: &[(Constellation, Vec<ObsCode>)],
    pending: &mut Vec<EventMark>,
    marks: &mut Vec<EventMark>,
) -> std::io::Result<()> {
    match it {
        RawItem::Event(ev) => {
            marks.push(ev);
            if ev.edge == Edge::Falling {
                pending.push(ev);
            }
        }
        RawItem::Epoch(e) => {
            let t = gpst(e.week, e.tow);
            let (now, later): (Vec<_>, Vec<_>) =
                pending.drain(..).partition(|m| gpst(m.week, m.tow) <= t);
            for m in &now {
                write_mark(w, m)?;
            }
            *pending = later;
            let sats = sat_records(&e, types);
            if !sats.is_empty() {
                write::write_epoch(w, t, &sats)?;
            }
        }
    }
    Ok(())
}

fn write_mark(w: &mut dyn Write, m: &EventMark) -> std::io::Result<()> {
    let c = if m.valid {
        vec![]
    } else {
        vec![" Time mark is not valid".to_string()]
    };
    write::write_event(w, gpst(m.week, m.tow), &c)
}
