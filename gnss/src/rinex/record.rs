//! The observation records shared by the readers of this module: observation codes, values,
//! satellite records, epochs, events, warnings and ingest counts.
//!
//! What enters: nothing (plain data). What leaves: the types that [`super::header`],
//! [`super::crx`] and [`super::body`] fill and that [`super::ObsReader`] hands out; this module
//! uses none of them.

use crate::sv::Sv;
use hifitime::Epoch;
use std::fmt;

/// A RINEX 3 observation code such as `C1C` (kind, band, attribute).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObsCode(pub [u8; 3]);

impl ObsCode {
    /// `C` code, `L` phase, `D` Doppler, `S` signal strength.
    pub fn kind(&self) -> u8 {
        self.0[0]
    }
    /// Frequency band digit.
    pub fn band(&self) -> u8 {
        self.0[1]
    }
    /// Tracking attribute (signal component).
    pub fn attribute(&self) -> u8 {
        self.0[2]
    }
}

impl fmt::Display for ObsCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", String::from_utf8_lossy(&self.0))
    }
}
impl fmt::Debug for ObsCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

/// One observation value with its loss-of-lock indicator and signal strength digit.
/// A missing observation has a NaN value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obs {
    /// Value (cycles, metres, Hz or dB-Hz); NaN when missing.
    pub value: f64,
    /// Loss-of-lock indicator (0 when blank).
    pub lli: u8,
    /// Signal strength indicator (0 when blank).
    pub ssi: u8,
}

impl Obs {
    /// A missing observation.
    pub const MISSING: Obs = Obs {
        value: f64::NAN,
        lli: 0,
        ssi: 0,
    };
    /// Whether the observation has a value.
    pub fn is_present(&self) -> bool {
        !self.value.is_nan()
    }
    /// Whether the field is blank: no value, no loss-of-lock indicator, no strength.
    pub fn is_blank(&self) -> bool {
        self.value.is_nan() && self.lli == 0 && self.ssi == 0
    }
}

/// All observations of one satellite in one epoch, aligned with [`ObsHeader::types_of`](super::ObsHeader::types_of).
#[derive(Clone, Debug)]
pub struct SatObs {
    /// The satellite.
    pub sv: Sv,
    /// Observations in the header's order for its system. Read from a file, the blank
    /// fields that end a record are left out: read them with [`SatObs::get`].
    pub obs: Vec<Obs>,
}

impl SatObs {
    /// The observation of the `k`-th type of the satellite's system ([`Obs::MISSING`] when
    /// the record ends before it).
    #[inline]
    pub fn get(&self, k: usize) -> Obs {
        self.obs.get(k).copied().unwrap_or(Obs::MISSING)
    }
}

/// One observation epoch (flag 0 or 1).
#[derive(Clone, Debug)]
pub struct ObsEpoch {
    /// Receiver time tag in GPST.
    pub time: Epoch,
    /// 0 = OK, 1 = power failure since the previous epoch.
    pub flag: u8,
    /// Receiver clock offset from the file, seconds, when given.
    pub clock_offset: Option<f64>,
    /// Satellites observed.
    pub sats: Vec<SatObs>,
    /// 1-based line where the epoch starts (in the compressed file for CRINEX).
    pub line: usize,
}

/// A special record (epoch flag 2–5). Flag 5 is an external event: a camera exposure.
#[derive(Clone, Debug)]
pub struct Event {
    /// The exact event time in GPST (may be absent for flags 2–4).
    pub time: Option<Epoch>,
    /// Epoch flag (2–5).
    pub flag: u8,
    /// 1-based line of the event record.
    pub line: usize,
    /// The special records (header or comment lines) that follow it.
    pub records: Vec<String>,
}

/// Something wrong in the file that did not stop the reading; the data around it were kept.
#[derive(Clone, Debug)]
pub struct Warning {
    /// 1-based line.
    pub line: usize,
    /// What was wrong.
    pub what: String,
}

/// Counts gathered while reading.
#[derive(Clone, Debug, Default)]
pub struct IngestStats {
    /// Text bytes parsed (after decompression).
    pub bytes: u64,
    /// Lines read.
    pub lines: usize,
    /// Epochs with flag 1 (power failure).
    pub power_failures: usize,
    /// Cycle-slip records (flag 6) read and not used.
    pub cycle_slip_records: usize,
    /// Lines skipped because they could not be read.
    pub skipped_lines: usize,
    /// Satellite records dropped (unknown system letter, unreadable).
    pub dropped_sat_records: usize,
    /// Epochs whose time is not after the previous epoch.
    pub non_increasing: usize,
}

/// One item of the observation stream.
#[derive(Clone, Debug)]
pub enum Record {
    /// An observation epoch.
    Epoch(ObsEpoch),
    /// A special record (flags 2–5).
    Event(Event),
}
