//! The observation files of a run: RINEX or a raw receiver log, the format told from the
//! content unless the job says it (through [`gnss::obs`]).
//!
//! Enters: a path and the format the user may insist on. Leaves: the observations, the
//! ephemerides a raw log carries (for [`crate::orbits::load_orbits`] when no navigation file is
//! given), and what decoding the log counted as dropped, as a warning for the report.

use gnss::error::Result;
use gnss::obs::{read_obs, ObsFormat};
use gnss::raw::rtcm_station::Station;
use gnss::raw::{RawStats, TimeHint};
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use std::path::{Path, PathBuf};

/// The observations of one receiver.
#[derive(Clone, Debug)]
pub struct RunObs {
    /// Observations and events.
    pub obs: ObsFile,
    /// Ephemerides decoded from a raw log (`None` for RINEX or a log without any).
    pub nav: Option<NavFile>,
    /// What decoding a raw log read and dropped, for the report.
    pub warnings: Vec<String>,
    /// The reference station a raw log describes (RTCM 1005/1006, 1007/1008/1033), when it
    /// does; its marker is the header's approximate position.
    pub station: Option<Station>,
}

/// One line on what decoding a raw log counted.
fn raw_note(path: &Path, format: &str, s: &RawStats) -> String {
    let dropped: u64 = s.dropped.values().sum();
    // A log mixing protocols is named by what it holds (UBX + RTCM 3 + NMEA).
    let format = if s.protocols.len() > 1 {
        s.log_kind(gnss::raw::RawFormat::Ubx)
    } else {
        format.to_string()
    };
    let mut extra = String::new();
    if s.nav.stale > 0 {
        extra += &format!(", {} stale ephemerides not used", s.nav.stale);
    }
    if let Some(t) = &s.time_source {
        extra += &format!("; GPS week {t}");
    }
    for w in &s.warnings {
        extra += &format!("; {w}");
    }
    format!(
        "{}: read as a {format} log: {} epochs ({} before the receiver knew the time, \
         skipped), {} checksum failures, {} truncated frames, {} measurements dropped; \
         navigation messages: {} parity and {} CRC failures, {} ephemerides{extra}",
        path.display(),
        s.epochs,
        s.epochs_without_time,
        s.checksum_failures,
        s.truncated_frames,
        dropped,
        s.nav.parity_failures,
        s.nav.crc_failures,
        s.nav.ephemerides
    )
}

/// Read the observations at `path` (RINEX or raw log; `format` `None`: told from content;
/// `hint` for an RTCM 3 log's week).
pub fn read_observations(
    path: &Path,
    format: Option<ObsFormat>,
    hint: Option<TimeHint>,
) -> Result<RunObs> {
    let input = read_obs(path, format, hint)?;
    let name = match input.format {
        ObsFormat::Raw(f) => f.name(),
        ObsFormat::Rinex => "RINEX",
    };
    let mut warnings: Vec<String> = input.raw.iter().map(|s| raw_note(path, name, s)).collect();
    warnings.extend(
        input
            .raw
            .iter()
            .filter_map(|s| s.time_source.as_ref())
            .map(|t| format!("{}: GPS week of the observations: {t}", path.display())),
    );
    let station = input.raw.map(|s| s.station).filter(|s| s.is_known());
    Ok(RunObs {
        obs: input.obs,
        nav: input.nav,
        warnings,
        station,
    })
}

/// The navigation sources to name in messages: the files given, else the log whose
/// ephemerides are used.
pub fn nav_sources(nav: &[PathBuf], from_log: Option<&NavFile>) -> Vec<PathBuf> {
    match from_log {
        Some(n) if nav.is_empty() => vec![n.path.clone()],
        _ => nav.to_vec(),
    }
}
