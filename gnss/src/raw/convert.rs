//! `convert`: a raw log to a RINEX 3.04 observation file (and its camera events to CSV).
//!
//! What enters: the path of a log and its format (detected from content when not given).
//! What leaves: the RINEX observation file, the optional RINEX navigation file (ephemerides
//! decoded from the log's navigation subframes) and event CSV, each written atomically, and
//! the [`RawStats`] of the conversion. The log is decoded once; its epochs and time marks go
//! to a temporary file ([`super::spill`]) while the header's observation types, time span and
//! the ephemerides are gathered, and are written as RINEX from there, formatted on all
//! threads in batches (the same bytes for any thread count). Memory stays bounded whatever
//! the log's size.

use super::items::{Edge, LogNav, RawItem};
use super::nmea::NmeaFix;
use super::read_items::for_each_item;
use super::records::{span, write_raw_epoch, RinexOrder, RinexOut, Scan};
use super::spill::{self, Spill};
use super::{RawFormat, RawStats, TimeHint};
use crate::error::{Error, Result};
use crate::rinex::write::{self, HeaderOut};
use crate::rinex::write_nav::{write_nav, NavHeaderOut};
use crate::rinex::ObsCode;
use crate::solution::{write_atomic, write_pos, PosFormat, PosRecord};
use crate::sv::Constellation;
use std::path::Path;

/// The files `convert` writes.
#[derive(Clone, Copy, Debug)]
pub struct Outputs<'a> {
    /// RINEX 3.04 observation file.
    pub obs: &'a Path,
    /// RINEX 3.04 mixed navigation file of the ephemerides decoded from the log.
    pub nav: Option<&'a Path>,
    /// CSV of every time-mark edge.
    pub events: Option<&'a Path>,
    /// RTKLIB `.pos` of the receiver's own fixes (NMEA GGA).
    pub nmea: Option<&'a Path>,
}

/// Convert `input` to the RINEX 3.04 files and the event CSV of `outs`; `hint` settles RTCM 3
/// weeks (see [`TimeHint`]).
pub fn convert(
    input: &Path,
    format: Option<RawFormat>,
    hint: Option<TimeHint>,
    outs: Outputs,
) -> Result<RawStats> {
    convert_with_progress(input, format, hint, outs, &crate::progress::NoProgress)
}

/// [`convert`], counting the log's epochs as they are decoded, then the RINEX records as they
/// are written, on `progress` (the first count's length is not known beforehand).
pub fn convert_with_progress(
    input: &Path,
    format: Option<RawFormat>,
    hint: Option<TimeHint>,
    outs: Outputs,
    progress: &dyn crate::progress::Progress,
) -> Result<RawStats> {
    let (out, events) = (outs.obs, outs.events);
    let mut scan = Scan::default();
    let mut lognav = LogNav::default();
    let mut records = 0u64;
    let spill_err = |cause| Error::Write {
        path: out.to_path_buf(),
        cause,
    };
    let mut spill = Spill::create(out).map_err(spill_err)?;
    let mut kept: std::io::Result<()> = Ok(());
    let mut order = RinexOrder::default();
    let mut fixes = Vec::new();
    progress.set_len("reading the log, epoch", 0);
    let st = for_each_item(input, format, hint, |it| {
        lognav.add(&it);
        if let RawItem::Fix(fix) = &it {
            fixes.push(*fix);
        }
        if let RawItem::Epoch(e) = &it {
            scan.add(e);
            progress.inc(1);
        }
        if kept.is_ok() {
            kept = order.item(it, &mut |o| {
                records += 1;
                spill.push(&o)
            });
        }
    })?;
    kept.and_then(|_| {
        order.finish(&mut |o| {
            records += 1;
            spill.push(&o)
        })
    })
    .map_err(spill_err)?;
    progress.set_len("writing RINEX records", records);
    if let Some(p) = outs.nav {
        write_nav_file(input, p, &lognav, &st)?;
    }
    if let Some(p) = outs.nmea {
        write_nmea_pos(input, p, &fixes)?;
    }
    let (first, last) = span(&scan, input)?;
    let station = st.station.rinex();
    let h = HeaderOut {
        program: "ppkat convert".into(),
        comments: vec![
            format!(
                "format: {}",
                format.map_or("raw log (detected)", RawFormat::name)
            ),
            format!(
                "log: {}",
                input.file_name().unwrap_or_default().to_string_lossy()
            ),
        ],
        marker: String::new(),
        approx: station.approx.unwrap_or([0.0; 3]),
        delta_h: station.height,
        receiver: station.receiver.clone(),
        antenna: station.antenna.clone(),
        types: scan.types(),
        first,
        last,
        glonass: scan.glonass.iter().map(|(&s, &c)| (s, c)).collect(),
    };
    let mut kept = spill.into_reader().map_err(spill_err)?;
    write_atomic(out, |w| {
        write::write_header(w, &h)?;
        let mut texts = Vec::new();
        while let Some(block) = kept.next_block(BLOCK)? {
            let recs = block.records();
            // the block before is written while this one is formatted
            let mut formatted = Ok(Vec::new());
            let written = rayon::in_place_scope(|s| {
                s.spawn(|_| formatted = format_block(&recs, &h.types));
                texts.iter().try_for_each(|t: &Vec<u8>| w.write_all(t))
            });
            written?;
            texts = formatted?;
            progress.inc(recs.len() as u64);
        }
        texts.iter().try_for_each(|t| w.write_all(t))
    })?;
    progress.finish();
    if let Some(p) = events {
        write_atomic(p, |w| {
            writeln!(w, "week,tow,edge,count,valid")?;
            for m in &order.marks {
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

/// Bytes of records formatted together, on all threads: enough to keep them busy, little
/// enough that a block and its text (about 2.5 times as much) stay a few megabytes.
const BLOCK: usize = 1 << 21;

/// The RINEX text of a block's records, formatted on all threads: one text per run of
/// records (few large writes rather than one per epoch), in order.
fn format_block(
    recs: &[&[u8]],
    types: &[(Constellation, Vec<ObsCode>)],
) -> std::io::Result<Vec<Vec<u8>>> {
    use rayon::prelude::*;
    recs.par_chunks(64)
        .map(|run| {
            let mut text = Vec::with_capacity(run.iter().map(|r| r.len() * 2).sum());
            for r in run {
                write_record(&mut text, &spill::decode(r)?, types)?;
            }
            Ok(text)
        })
        .collect()
}

/// The navigation file of a log's ephemerides; an error when the log has none.
fn write_nav_file(input: &Path, path: &Path, nav: &LogNav, st: &RawStats) -> Result<()> {
    if nav.records.is_empty() {
        return Err(Error::input(
            input,
            format!(
                "no complete ephemeris in the log's navigation messages ({} read): enable \
                 UBX-RXM-SFRBX (u-blox), RTCM 1019/1020/1042/1044/1045/1046 or SBF \
                 GPSNav/GALNav/BDSNav/GLONav on the receiver, or leave out --nav",
                st.nav.messages
            ),
        ));
    }
    let h = NavHeaderOut {
        program: "ppkat convert".into(),
        comments: vec![format!(
            "log: {}",
            input.file_name().unwrap_or_default().to_string_lossy()
        )],
        gps_iono: nav.gps_iono,
        bds_iono: nav.bds_iono,
        leap_seconds: nav.leap_seconds,
    };
    write_atomic(path, |w| write_nav(w, &h, &nav.records))?;
    Ok(())
}

/// The receiver's own fixes as an RTKLIB `.pos` (llh); an error when the log has none.
fn write_nmea_pos(input: &Path, path: &Path, fixes: &[NmeaFix]) -> Result<()> {
    if fixes.is_empty() {
        return Err(Error::input(
            input,
            "no NMEA GGA sentence with a fix in the log: enable GGA output on the receiver \
             (u-blox CFG-MSGOUT-NMEA_ID_GGA) or leave out --nmea",
        ));
    }
    let records: Vec<PosRecord> = fixes
        .iter()
        .map(|f| PosRecord {
            time: f.time,
            pos: f.pos,
            quality: f.quality,
            nsat: f.nsat,
            cov: nalgebra::Matrix3::zeros(),
            age: 0.0,
            ratio: 0.0,
        })
        .collect();
    let header = vec![
        format!(
            "program   : ppkat convert --nmea: the receiver's own solution (NMEA GGA) of {}",
            input.file_name().unwrap_or_default().to_string_lossy()
        ),
        "GGA in UTC is written in GPST (+ the leap seconds); height = altitude + geoid \
         separation; Q 1 from GGA quality 4 (RTK fixed), 2 from 5 (RTK float), 5 from any \
         other fix; GGA has no sigmas (written as 0)"
            .to_string(),
    ];
    write_pos(path, &header, &records, PosFormat::Llh)
}

/// One record as RINEX text; an epoch without a satellite of the header's types is none.
fn write_record(
    text: &mut Vec<u8>,
    o: &RinexOut,
    types: &[(Constellation, Vec<ObsCode>)],
) -> std::io::Result<()> {
    match o {
        RinexOut::Epoch(t, e) => {
            write_raw_epoch(text, *t, e, types);
            Ok(())
        }
        RinexOut::Event(t, c) => write::write_event(text, *t, c),
    }
}
