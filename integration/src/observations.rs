//! The observation files of a run: RINEX or a raw receiver log, the format told from the
//! content unless the job says it (through [`gnss::obs`]).
//!
//! Enters: a path and the format the user may insist on. Leaves: the observations, the
//! ephemerides a raw log carries (for [`crate::orbits::load_orbits`] when no navigation file is
//! given), and what decoding the log counted as dropped, as a warning for the report.

use gnss::error::Result;
use gnss::obs::{read_obs, ObsFormat};
use gnss::raw::RawStats;
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
}

/// One line on what decoding a raw log counted.
fn raw_note(path: &Path, s: &RawStats) -> String {
    let dropped: u64 = s.dropped.values().sum();
    format!(
        "{}: read as a u-blox UBX log: {} epochs ({} before the receiver knew the time, \
         skipped), {} checksum failures, {} truncated frames, {} measurements dropped; \
         navigation messages: {} parity and {} CRC failures, {} ephemerides",
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

/// Read the observations at `path` (RINEX or raw log; `format` `None`: told from content).
pub fn read_observations(path: &Path, format: Option<ObsFormat>) -> Result<RunObs> {
    let input = read_obs(path, format)?;
    let warnings = input.raw.iter().map(|s| raw_note(path, s)).collect();
    Ok(RunObs {
        obs: input.obs,
        nav: input.nav,
        warnings,
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
