//! A raw log as an observation file in memory, for the engines (`spp`, `ppk`, `info`).
//!
//! What enters: the path of a log and its format (detected from content when not given).
//! What leaves: a [`RawLog`]: an [`ObsFile`] holding exactly what `convert` would write and
//! [`ObsFile::read`] would read back (the same records through [`super::records`], values
//! rounded to the 0.001 RINEX prints), the ephemerides decoded from the log, and its
//! [`RawStats`]. So an engine gives the same answer on a log as on its conversion.

use super::items::{LogNav, RawItem};
use super::read_items::for_each_item;
use super::records::{sat_records, span, RinexOrder, RinexOut, Scan};
use super::{RawFormat, RawStats, TimeHint};
use crate::error::Result;
use crate::frame::Ecef;
use crate::rinex::lines::parse_real;
use crate::rinex::write::f14_3;
use crate::rinex::{AntennaDelta, Event, IngestStats, ObsEpoch, ObsFile, ObsHeader, SatObs};
use std::path::Path;

/// A raw log read into memory.
#[derive(Clone, Debug)]
pub struct RawLog {
    /// Its observations and events, as from the RINEX file `convert` writes.
    pub obs: ObsFile,
    /// Ephemerides and ionosphere parameters decoded from its navigation messages.
    pub nav: LogNav,
    /// What was read and dropped.
    pub stats: RawStats,
}

/// Values as RINEX carries them: F14.3 of the value modulo 10⁹ as the writer prints it, read
/// back by the RINEX reader's own number parser (printing rounds ties to even, so no
/// arithmetic shortcut gives the same digits).
fn printed(mut sats: Vec<SatObs>) -> Vec<SatObs> {
    let mut buf = [0u8; 32];
    for s in &mut sats {
        for o in s.obs.iter_mut().filter(|o| !o.value.is_nan()) {
            let n = f14_3(o.value % 1e9, &mut buf);
            o.value = parse_real(&buf[..n]).ok().flatten().unwrap_or(f64::NAN);
        }
    }
    sats
}

/// Read a whole log (format detected from content when `format` is `None`; `hint` for RTCM 3
/// weeks).
pub fn read_log(path: &Path, format: Option<RawFormat>, hint: Option<TimeHint>) -> Result<RawLog> {
    let mut scan = Scan::default();
    let mut nav = LogNav::default();
    let mut items = Vec::new();
    let stats = for_each_item(path, format, hint, |it| {
        nav.add(&it);
        match it {
            RawItem::Epoch(e) => {
                scan.add(&e);
                items.push(RawItem::Epoch(e));
            }
            RawItem::Event(_) => items.push(it),
            RawItem::Ephemeris(_)
            | RawItem::GpsIono(..)
            | RawItem::BdsIono(_)
            | RawItem::Fix(_) => {}
        }
    })?;
    span(&scan, path)?;
    let types = scan.types();
    let mut order = RinexOrder::default();
    let (mut epochs, mut events) = (Vec::new(), Vec::new());
    let mut put = |o: RinexOut| -> std::result::Result<(), ()> {
        match o {
            RinexOut::Epoch(time, e) => {
                let sats = sat_records(&e, &types);
                if !sats.is_empty() {
                    epochs.push(ObsEpoch {
                        time,
                        flag: 0,
                        clock_offset: None,
                        sats: printed(sats),
                        line: 0,
                    });
                }
            }
            RinexOut::Event(t, records) => events.push(Event {
                time: Some(t),
                flag: 5,
                line: 0,
                records,
            }),
        }
        Ok(())
    };
    for it in items {
        let _ = order.item(it, &mut put);
    }
    let _ = order.finish(&mut put);
    // the station fields as the RINEX header `convert` writes has them, read back
    let station = stats.station.rinex();
    let [_, rec_type, rec_version] = &station.receiver;
    let header = ObsHeader {
        obs_types: types.into_iter().collect(),
        glonass_channels: scan.glonass.clone(),
        approx_position: station.approx.map(|[x, y, z]| Ecef::new(x, y, z)),
        antenna_delta: AntennaDelta {
            up: station.height,
            ..AntennaDelta::default()
        },
        antenna: station.antenna[1].clone(),
        receiver: format!("{rec_type} {rec_version}").trim().to_string(),
        ..ObsHeader::new(3.04)
    };
    let obs = ObsFile {
        path: path.to_path_buf(),
        header,
        epochs,
        events,
        warnings: Vec::new(),
        stats: IngestStats {
            bytes: stats.bytes,
            ..IngestStats::default()
        },
    };
    Ok(RawLog { obs, nav, stats })
}
