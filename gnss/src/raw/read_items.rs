//! Reading a raw log item by item. What enters: the path of a log and its format (detected
//! from content when not given). What leaves: each [`RawItem`] handed to a callback as it is
//! decoded (so memory stays bounded), and the [`RawStats`] of everything read and dropped.
//! Used by [`super::convert`] (RINEX files) and [`super::source`] (observations in memory).

use super::items::RawItem;
use super::{detect, RawFormat, RawStats, TimeHint};
use crate::error::{Error, Result};
use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Read every item of a log, calling `f` on each; returns what was read and dropped. `hint`
/// settles the week where the format leaves it open (RTCM 3; see [`TimeHint`]).
pub fn for_each_item(
    path: &Path,
    format: Option<RawFormat>,
    hint: Option<TimeHint>,
    f: impl FnMut(RawItem),
) -> Result<RawStats> {
    let io = Error::io(path);
    let format = match format {
        Some(fm) => fm,
        None => {
            let mut head = Vec::new();
            File::open(path)
                .and_then(|file| file.take(1 << 16).read_to_end(&mut head))
                .map_err(io)?;
            detect(&head).ok_or_else(|| {
                Error::input(
                    path,
                    "no UBX frame (B5 62 with a valid checksum), RTCM 3 frame (D3 with a valid \
                     CRC) nor SBF block ($@ with a valid CRC) in the first 64 KiB: not a raw \
                     log ppkat reads; give a UBX, RTCM 3 or SBF log, or --format \
                     ubx|rtcm3|sbf to read it anyway",
                )
            })?
        }
    };
    match format {
        RawFormat::Sbf => super::sbf_items::for_each_sbf(path, f),
        RawFormat::Ubx | RawFormat::Rtcm3 => super::log_items::for_each_log_item(path, hint, f),
    }
}
