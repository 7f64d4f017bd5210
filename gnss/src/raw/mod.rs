//! Raw receiver logs: format detection from content and conversion to RINEX 3.04.
//!
//! What enters: the bytes of a receiver log. What leaves: observation epochs in the records of
//! [`crate::rinex`] ([`ObsEpoch`](crate::rinex::ObsEpoch), [`SatObs`](crate::rinex::SatObs)) (so that the RINEX writer and every engine take them as they take a
//! RINEX file), camera events, and [`RawStats`] counting everything that was dropped.
//! Uses [`crate::rinex::write`] to write RINEX. Formats: u-blox UBX ([`ubx`]), RTCM 3
//! MSM observations ([`rtcm`], [`rtcm_msm`], [`log_items`]) and Septentrio SBF ([`sbf`],
//! [`sbf_obs`], [`sbf_nav`], [`sbf_items`]).
//!
//! The UBX decoder is our own rather than the `ublox` crate: the conversion must reproduce
//! RTKLIB convbin bit for bit (its loss-of-lock rules need the raw `trkStat`, `locktime` and
//! `cpStdev` fields), bad frames must be counted rather than skipped inside a crate, and the
//! frame format (sync, class, id, length, payload, Fletcher checksum) is a few dozen lines.
//! The RTCM 3 decoder is our own for the same reasons (CRC failures counted, lock-time
//! indicators kept raw for the loss-of-lock rule) and because the frame and MSM layouts are
//! short; it reuses [`bits`] (bit fields, CRC-24Q) already written for navigation messages.
//! The SBF decoder is our own for the same reasons again: the crates that read SBF
//! (`libsbf`, `sbf-tools`) are parse-only, giving raw fields (no pseudorange, phase in
//! cycles or Type-2 values from their offsets), they stop at the first bad block where CRC
//! failures must be counted and the search resumed, the lock time and half-cycle flag must be
//! kept raw for the loss-of-lock rule, and the writer `simulate --raw sbf` needs is ours
//! anyway; the block format is a sync, a CRC-16 and little-endian fields.

pub mod bds_nav;
pub mod bits;
pub mod convert;
pub mod frames;
pub mod glo_nav;
pub mod inav;
pub mod items;
pub mod lnav;
pub mod log_items;
pub mod mixed;
pub mod nmea;
pub mod read_items;
pub mod records;
pub mod rtcm;
pub mod rtcm_eph;
pub mod rtcm_eph_write;
pub mod rtcm_msm;
pub mod rtcm_station;
pub mod rtcm_week;
pub mod rtcm_write;
pub mod sbf;
pub mod sbf_eph_write;
pub mod sbf_items;
pub mod sbf_meas;
pub mod sbf_nav;
pub mod sbf_obs;
pub mod sbf_write;
pub mod slots;
pub mod source;
pub mod spill;
pub mod ubx;
pub mod ubx_nav;
pub mod ubx_nav_write;
pub mod ubx_obs;
pub mod ubx_write;

use std::collections::BTreeMap;
use std::fmt;

/// A raw log format that `convert` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawFormat {
    /// u-blox UBX binary protocol.
    Ubx,
    /// RTCM 3 (MSM observations), e.g. DJI `PPKRAW.bin`.
    Rtcm3,
    /// Septentrio SBF (MeasEpoch, decoded navigation blocks, ExtEvent).
    Sbf,
}

impl RawFormat {
    /// The format's name for reports.
    pub fn name(self) -> &'static str {
        match self {
            RawFormat::Ubx => "u-blox UBX",
            RawFormat::Rtcm3 => "RTCM 3",
            RawFormat::Sbf => "Septentrio SBF",
        }
    }
}

/// The format of a log from its first bytes: the format of the first whole frame with a
/// valid checksum (UBX Fletcher, RTCM 3 CRC-24Q, SBF CRC-16-CCITT) within them. `None` when no known format is
/// recognised.
pub fn detect(head: &[u8]) -> Option<RawFormat> {
    let mut i = 0;
    while i + 8 <= head.len() {
        if head[i] == ubx::SYNC1 && head[i + 1] == ubx::SYNC2 {
            let len = u16::from_le_bytes([head[i + 4], head[i + 5]]) as usize;
            let end = i + 8 + len;
            if end <= head.len() && ubx::checksum_ok(&head[i..end]) {
                return Some(RawFormat::Ubx);
            }
        }
        if rtcm::frame_at(head, i) {
            return Some(RawFormat::Rtcm3);
        }
        if sbf::block_at(head, i) {
            return Some(RawFormat::Sbf);
        }
        i += 1;
    }
    None
}

/// When a log was recorded, as far as the user knows. RTCM 3 observations carry the time of
/// week only (of day for GLONASS) and the GPS ephemeris its week modulo 1024; a hint settles
/// what the log cannot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeHint {
    /// The year: the 1024-week cycle of the GPS and QZSS ephemerides' weeks (not enough to
    /// place observations when no ephemeris gives the week).
    Year(i32),
    /// The day (GPST) the log begins, within a few days: places the observations whatever
    /// the log carries.
    Date(i32, u8, u8),
}

impl TimeHint {
    /// The hint as GPST ms since the GPS epoch: the date's noon, or the year's 2 July.
    pub fn gpst_ms(self) -> i64 {
        let (y, m, d) = match self {
            TimeHint::Year(y) => (y, 7, 2),
            TimeHint::Date(y, m, d) => (y, m, d),
        };
        let e = crate::time::gpst(y.clamp(1980, 2200), m, d, 12, 0, 0, 0);
        (e.to_gpst_seconds() * 1000.0).round() as i64
    }

    /// The full GPS week the hint points at.
    pub fn week(self) -> i64 {
        self.gpst_ms().div_euclid(rtcm_msm::WEEK_MS)
    }

    /// Parse `YYYY` or `YYYY-MM-DD` (years 1980–2200, a real calendar date).
    pub fn parse(s: &str) -> std::result::Result<TimeHint, String> {
        let bad = || format!("'{s}' is not a year (YYYY) or a date (YYYY-MM-DD) from 1980 to 2200");
        let parts: Vec<&str> = s.trim().split('-').collect();
        let num = |t: &str| t.parse::<i32>().map_err(|_| bad());
        let y = num(parts[0])?;
        if !crate::time::file_year(y.into()) {
            return Err(bad());
        }
        match parts.len() {
            1 => Ok(TimeHint::Year(y)),
            3 => {
                let (m, d) = (num(parts[1])?, num(parts[2])?);
                let leap = y % 4 == 0 && (y % 100 != 0 || y % 400 == 0);
                let days = [
                    31,
                    if leap { 29 } else { 28 },
                    31,
                    30,
                    31,
                    30,
                    31,
                    31,
                    30,
                    31,
                    30,
                    31,
                ];
                if !(1..=12).contains(&m) || d < 1 || d > days[(m - 1) as usize] {
                    return Err(bad());
                }
                Ok(TimeHint::Date(y, m as u8, d as u8))
            }
            _ => Err(bad()),
        }
    }
}

impl fmt::Display for TimeHint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TimeHint::Year(y) => write!(f, "{y}"),
            TimeHint::Date(y, m, d) => write!(f, "{y:04}-{m:02}-{d:02}"),
        }
    }
}

/// What a conversion read and what it dropped (nothing is dropped silently).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawStats {
    /// Bytes read.
    pub bytes: u64,
    /// Frames with a valid checksum.
    pub frames: u64,
    /// Frames whose checksum failed (skipped; the search for the next frame went on).
    pub checksum_failures: u64,
    /// A frame cut off by the end of the file.
    pub truncated_frames: u64,
    /// Bytes outside any valid frame (noise, other protocols).
    pub skipped_bytes: u64,
    /// Frames per protocol (`UBX`, `RTCM 3`, `NMEA`) of a log that may mix them.
    pub protocols: BTreeMap<String, u64>,
    /// Frames of types the converter does not use, counted by type name.
    pub unused: BTreeMap<String, u64>,
    /// Frames of a used type whose payload is too short for what it announces.
    pub malformed: BTreeMap<String, u64>,
    /// Measurement epochs stamped before the receiver knew the GPS week (week 0): skipped.
    pub epochs_without_time: u64,
    /// Observation epochs written.
    pub epochs: u64,
    /// Epochs whose time is not after the previous one (kept, as convbin does).
    pub time_jumps: u64,
    /// Measurements dropped, counted by reason (unknown system or satellite, signal
    /// without a RINEX slot).
    pub dropped: BTreeMap<String, u64>,
    /// Camera events (time-mark edges) read.
    pub events: u64,
    /// Navigation messages (subframes, pages) and what became of them.
    pub nav: NavStats,
    /// The reference station the log describes (RTCM 1005/1006, 1007/1008/1033).
    pub station: rtcm_station::Station,
    /// Where the GPS week of the observations came from (RTCM 3: a message or a hint).
    pub time_source: Option<String>,
    /// Receiver fixes read from NMEA GGA.
    pub nmea_fixes: u64,
    /// What the user should know of the decoding (a hint taken over the log's evidence).
    pub warnings: Vec<String>,
}

/// What became of the navigation messages of a log: every subframe or page that failed a
/// check is counted here and dropped; none of it is fatal.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NavStats {
    /// Navigation messages read (u-blox RXM-SFRBX).
    pub messages: u64,
    /// Subframes or strings whose parity fails: a GPS/QZSS word's parity, a BeiDou word's
    /// BCH(15,11) code, a GLONASS string's Hamming code.
    pub parity_failures: u64,
    /// Galileo pages whose CRC-24Q fails.
    pub crc_failures: u64,
    /// Subframes or pages out of structure: a GPS or BeiDou preamble, subframe id or page
    /// number that is wrong, a Galileo page whose halves are not even then odd, a GLONASS
    /// string number 0.
    pub page_errors: u64,
    /// Galileo alert pages (no navigation data).
    pub alert_pages: u64,
    /// Sets whose parts carried different issues of data when the last part arrived (a new
    /// upload being broadcast), BeiDou sets whose parts are not of one frame, GLONASS strings
    /// 1–4 naming another slot; the set completes with later parts.
    pub inconsistent: u64,
    /// GPS/QZSS sets complete before the receiver knew the GPS week (the broadcast week is
    /// modulo 1024), GLONASS sets before it knew its time (the strings carry times of day);
    /// the set completes again when it is rebroadcast.
    pub before_week_known: u64,
    /// Distinct ephemerides decoded.
    pub ephemerides: u64,
    /// Satellites whose last parts never formed an ephemeris by the end of the log.
    pub incomplete: u64,
    /// Ephemerides whose time of clock lies far from the log's time (kept by the receiver
    /// from an earlier day): not used.
    pub stale: u64,
    /// The first of them, named (satellite, message, time of clock, days from the log).
    pub stale_named: Vec<String>,
}

impl RawStats {
    /// What a log read as `format` holds, for a user: `u-blox UBX`, or `UBX + RTCM 3 + NMEA`
    /// (the protocols found) when it mixes them.
    pub fn log_kind(&self, format: RawFormat) -> String {
        if self.protocols.len() > 1 {
            let names: Vec<&str> = ["UBX", "RTCM 3", "NMEA"]
                .into_iter()
                .filter(|p| self.protocols.contains_key(*p))
                .collect();
            names.join(" + ")
        } else {
            format.name().to_string()
        }
    }

    /// Count one dropped measurement for `reason`.
    pub fn drop(&mut self, reason: &str) {
        *self.dropped.entry(reason.to_string()).or_default() += 1;
    }
}

impl fmt::Display for RawStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let by_protocol = if self.protocols.len() > 1 {
            let parts: Vec<String> = self
                .protocols
                .iter()
                .map(|(k, v)| format!("{v} {k}"))
                .collect();
            format!(" ({})", parts.join(", "))
        } else {
            String::new()
        };
        writeln!(
            f,
            "read {} bytes: {} frames{by_protocol}, {} checksum failures, {} truncated, {} bytes outside frames",
            self.bytes,
            self.frames,
            self.checksum_failures,
            self.truncated_frames,
            self.skipped_bytes
        )?;
        writeln!(
            f,
            "{} observation epochs, {} events, {} epochs before the receiver knew the time, {} time jumps",
            self.epochs, self.events, self.epochs_without_time, self.time_jumps
        )?;
        let list = |m: &BTreeMap<String, u64>| {
            m.iter()
                .map(|(k, v)| format!("{k} ×{v}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let n = &self.nav;
        if n.messages > 0 {
            writeln!(
                f,
                "{} navigation messages: {} ephemerides; dropped {} parity failures, {} CRC \
                 failures, {} out of structure, {} alert pages; {} sets of mixed issue of data, \
                 {} before the week was known, {} satellites left incomplete",
                n.messages,
                n.ephemerides,
                n.parity_failures,
                n.crc_failures,
                n.page_errors,
                n.alert_pages,
                n.inconsistent,
                n.before_week_known,
                n.incomplete
            )?;
        }
        if n.stale > 0 {
            writeln!(
                f,
                "{} stale ephemerides not used (time of clock far from the log's): {}{}",
                n.stale,
                n.stale_named.join(", "),
                if n.stale as usize > n.stale_named.len() {
                    ", …"
                } else {
                    ""
                }
            )?;
        }
        write!(f, "{}", self.station)?;
        if let Some(t) = &self.time_source {
            writeln!(f, "GPS week: {t}")?;
        }
        if self.nmea_fixes > 0 {
            writeln!(f, "{} receiver fixes (NMEA GGA)", self.nmea_fixes)?;
        }
        for w in &self.warnings {
            writeln!(f, "warning: {w}")?;
        }
        if !self.unused.is_empty() {
            writeln!(f, "not used: {}", list(&self.unused))?;
        }
        if !self.malformed.is_empty() {
            writeln!(f, "malformed (skipped): {}", list(&self.malformed))?;
        }
        if !self.dropped.is_empty() {
            writeln!(f, "measurements dropped: {}", list(&self.dropped))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn detects_ubx_from_content() {
        let f = ubx::frame(0x0d, 0x03, &[1, 2, 3, 4]);
        let mut head = b"$GPGGA,junk\r\n".to_vec();
        head.extend_from_slice(&f);
        assert_eq!(detect(&head), Some(RawFormat::Ubx));
        let n = head.len();
        head[n - 1] ^= 0xff;
        assert_eq!(detect(&head), None);
        assert_eq!(detect(b"     3.04           OBSERVATION DATA"), None);
    }

    #[test]
    fn time_hints_parse() {
        assert_eq!(TimeHint::parse("2024"), Ok(TimeHint::Year(2024)));
        assert_eq!(
            TimeHint::parse("2024-02-29"),
            Ok(TimeHint::Date(2024, 2, 29))
        );
        for bad in ["2023-02-29", "1979", "2024-13-01", "24-1-1-1", "x", ""] {
            assert!(TimeHint::parse(bad).is_err(), "{bad}");
        }
        // 2024-02-29 is in GPS week 2303
        assert_eq!(TimeHint::Date(2024, 2, 29).week(), 2303);
    }
}
