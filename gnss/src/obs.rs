//! Observation sources: a RINEX observation file or a raw receiver log, told apart by
//! content (never by the file name), read into the same [`ObsFile`].
//!
//! What enters: a path and, optionally, the format the user insists on. What leaves: an
//! [`ObsInput`]: the observations, and for a raw log the ephemerides decoded from its
//! navigation messages and what its decoding dropped. `spp`, `ppk` and `info` read their
//! observations through [`read_obs`] only.

use crate::error::{Error, Result};
use crate::raw::source::read_log;
use crate::raw::{self, RawFormat, RawStats, TimeHint};
use crate::rinex::nav::NavFile;
use crate::rinex::ObsFile;
use std::io::Read;
use std::path::Path;

/// The format of an observation source.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObsFormat {
    /// RINEX 2/3/4 observations (plain, gzip or Hatanaka-compressed).
    Rinex,
    /// A raw receiver log.
    Raw(RawFormat),
}

/// An observation source read into memory.
#[derive(Clone, Debug)]
pub struct ObsInput {
    /// The observations (and events).
    pub obs: ObsFile,
    /// The format they were read from.
    pub format: ObsFormat,
    /// Ephemerides decoded from a raw log's navigation messages (`None` for RINEX, or a log
    /// without a complete ephemeris).
    pub nav: Option<NavFile>,
    /// What the decoding of a raw log read and dropped (`None` for RINEX).
    pub raw: Option<RawStats>,
}

/// Whether the first bytes of a file are RINEX: gzip (RINEX is the only compressed input),
/// or a first line labelled `RINEX VERSION / TYPE` or `CRINEX VERS   / TYPE`.
fn looks_like_rinex(head: &[u8]) -> bool {
    if head.starts_with(&[0x1f, 0x8b]) {
        return true;
    }
    let first = head.split(|&c| c == b'\n').next().unwrap_or(&[]);
    let label = first.get(60..).unwrap_or(&[]);
    label.starts_with(b"RINEX VERSION / TYPE") || label.starts_with(b"CRINEX VERS")
}

/// The format of a file from its content.
pub fn detect_format(path: &Path) -> Result<ObsFormat> {
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(1 << 16).read_to_end(&mut head))
        .map_err(Error::io(path))?;
    if looks_like_rinex(&head) {
        return Ok(ObsFormat::Rinex);
    }
    raw::detect(&head).map(ObsFormat::Raw).ok_or_else(|| {
        Error::input(
            path,
            "neither a RINEX observation file (no 'RINEX VERSION / TYPE' first line) nor a \
             raw log (no UBX, RTCM 3 or SBF frame with a valid checksum in the first 64 KiB); give \
             --obs-format to read it as one of them anyway",
        )
    })
}

/// Read an observation source; its format is detected from content unless `format` says it.
/// `hint` settles the week of an RTCM 3 log (see [`TimeHint`]; ignored for other formats).
pub fn read_obs(
    path: &Path,
    format: Option<ObsFormat>,
    hint: Option<TimeHint>,
) -> Result<ObsInput> {
    let format = match format {
        Some(f) => f,
        None => detect_format(path)?,
    };
    match format {
        ObsFormat::Rinex => Ok(ObsInput {
            obs: ObsFile::read(path)?,
            format,
            nav: None,
            raw: None,
        }),
        ObsFormat::Raw(rf) => {
            let log = read_log(path, Some(rf), hint)?;
            let nav = (!log.nav.records.is_empty()).then(|| log.nav.to_nav_file(path));
            Ok(ObsInput {
                obs: log.obs,
                format,
                nav,
                raw: Some(log.stats),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rinex_is_told_from_its_first_line() {
        let mut l = format!(
            "{:<60}RINEX VERSION / TYPE\n",
            "     3.04           OBSERVATION DATA"
        );
        assert!(looks_like_rinex(l.as_bytes()));
        l = format!(
            "{:<60}CRINEX VERS   / TYPE\n",
            "3.0                 COMPACT RINEX FORMAT"
        );
        assert!(looks_like_rinex(l.as_bytes()));
        assert!(looks_like_rinex(&[0x1f, 0x8b, 8, 0]));
        assert!(!looks_like_rinex(&crate::raw::ubx::frame(
            2, 0x15, &[0; 16]
        )));
    }
}
