//! `convert`: a raw log to a RINEX 3.04 observation file (and its camera events to CSV).
//!
//! What enters: the path of a log and its format (detected from content when not given).
//! What leaves: the RINEX observation file, the optional RINEX navigation file (ephemerides
//! decoded from the log's navigation subframes) and event CSV, each written atomically, and
//! the [`RawStats`] of the conversion. The log is read twice (first for the header's
//! observation types, time span and the ephemerides, then to write the observations), so
//! memory stays bounded whatever the log's size.

use super::items::{for_each_item, Edge, LogNav, RawItem};
use super::records::{span, RinexOrder, RinexOut, Scan};
use super::{RawFormat, RawStats, TimeHint};
use crate::error::{Error, Result};
use crate::rinex::write::{self, HeaderOut};
use crate::rinex::write_nav::{write_nav, NavHeaderOut};
use crate::solution::write_atomic;
use std::io::Write;
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

/// [`convert`], counting the epochs of each pass on `progress` (the first pass's length is
/// not known beforehand; the second's is the first's count).
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
    let mut epochs = 0u64;
    progress.set_len("reading the log, epoch", 0);
    let st1 = for_each_item(input, format, hint, |it| {
        lognav.add(&it);
        if let RawItem::Epoch(e) = it {
            scan.add(&e);
            epochs += 1;
            progress.inc(1);
        }
    })?;
    progress.set_len("writing RINEX", epochs);
    if let Some(p) = outs.nav {
        write_nav_file(input, p, &lognav, &st1)?;
    }
    let (first, last) = span(&scan, input)?;
    let station = st1.station.rinex();
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
    let mut order = RinexOrder::new(&h.types);
    // The second pass's own error (the log changed or became unreadable) is kept here and
    // the atomic write abandoned, so no partial file replaces OUT.
    let mut pass2: Option<Result<RawStats>> = None;
    let written = write_atomic(out, |w| {
        write::write_header(w, &h)?;
        let mut res = Ok(());
        let mut put = |o: RinexOut| write_record(w, o);
        let st = for_each_item(input, format, hint, |it| {
            if matches!(it, RawItem::Epoch(_)) {
                progress.inc(1);
            }
            if res.is_ok() {
                res = order.item(it, &mut put);
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
        order.finish(&mut put)
    });
    progress.finish();
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

fn write_record(w: &mut dyn Write, o: RinexOut) -> std::io::Result<()> {
    match o {
        RinexOut::Epoch(t, sats) => write::write_epoch(w, t, &sats),
        RinexOut::Event(t, c) => write::write_event(w, t, &c),
    }
}
