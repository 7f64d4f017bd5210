//! The text of a simulated RINEX 3.04 observation file: the header (observation types of
//! each system simulated, `GLONASS SLOT / FRQ #` when GLONASS is), epoch records with their
//! satellites, and flag-5 event records.
//!
//! Enters: what [`super::gnss_obs`] simulated ([`SatObs`] per satellite and epoch, receiver
//! time tags in GPST) and the header's facts ([`HeaderInfo`]). Leaves: text appended to a
//! `String` (code m, phase cycles, Doppler Hz, SNR dB-Hz, F14.3 as RINEX has them).

use gnss::frame::Ecef;
use gnss::rinex::write::epoch_fields;
use gnss::sv::{Constellation, Sv};
use hifitime::{Epoch, TimeScale};
use std::fmt::Write as _;

/// One satellite as observed (before formatting).
#[derive(Clone, Copy, Debug)]
pub struct SatObs {
    /// The satellite.
    pub sv: Sv,
    /// C1 (m), L1 (cycles), D1 (Hz), S1 (dB-Hz), C2, L2, D2, S2.
    pub v: [f64; 8],
    /// Loss-of-lock indicator of L1 and L2 (1: a slip before this epoch).
    pub lli: [u8; 2],
}

/// A flag-5 (external event) record at receiver time `t`.
pub(super) fn write_event(body: &mut String, t: Epoch) {
    let _ = writeln!(body, "> {}  5  0", epoch_fields(t));
}

/// An observation epoch: the epoch line, then one line per satellite (SSI from the SNR on
/// code and phase, LLI on the phases), both bands.
pub(super) fn write_epoch(body: &mut String, tag: Epoch, recs: &[SatObs]) {
    write_epoch_bands(body, tag, recs, 2);
}

/// An observation epoch of a receiver of `bands` bands (1: the first four values of each
/// record, L1's; 2: all eight); missing values (NaN) are blank.
pub(super) fn write_epoch_bands(body: &mut String, tag: Epoch, recs: &[SatObs], bands: usize) {
    let _ = writeln!(body, "> {}  0{:3}", epoch_fields(tag), recs.len());
    for r in recs {
        let _ = write!(body, "{}", r.sv);
        let ssi = char::from(b'0' + ((r.v[3].min(54.0) / 6.0) as u8).clamp(1, 9));
        for (j, val) in r.v.iter().enumerate().take(4 * bands.clamp(1, 2)) {
            if !val.is_finite() {
                body.push_str("                ");
                continue;
            }
            let lli = match j {
                1 if r.lli[0] > 0 => char::from(b'0' + r.lli[0]),
                5 if r.lli[1] > 0 => char::from(b'0' + r.lli[1]),
                _ => ' ',
            };
            let ssi = if j % 4 < 2 { ssi } else { ' ' };
            let _ = write!(body, "{val:14.3}{lli}{ssi}");
        }
        body.push('\n');
    }
}

/// What the observation header says besides the observations: the receiver's marker name,
/// interval and first epoch, its position, the systems present (in `gnss`'s order) and the
/// GLONASS slots with their frequency channels.
pub(super) struct HeaderInfo<'a> {
    /// Marker name.
    pub name: &'a str,
    /// Observation interval, seconds.
    pub interval: f64,
    /// First epoch, receiver time (GPST).
    pub start: Epoch,
    /// Approximate position, ECEF.
    pub pos: Ecef,
    /// Systems with observations.
    pub systems: &'a [Constellation],
    /// GLONASS slots and their frequency channels, by slot.
    pub glonass: &'a [(u8, i8)],
    /// Bands observed: 1 (the first signal's four types) or 2.
    pub bands: usize,
    /// The RINEX attribute of the GPS L1 code (`C`: C/A, `W`: P(Y)); the phase is `L1C`
    /// either way, as RINEX 2 files write `L1` beside `C1` or `P1`.
    pub gps_l1: u8,
}

/// The observation types of a system's records: the first and second signal's code, phase,
/// Doppler and SNR (GPS L1 C/A and L2 P(Y), GLONASS L1 and L2 C/A, Galileo E1 and E5a, QZSS
/// L1 C/A and L2C, as ppkat's PPK signal plan prefers them).
fn obs_types(sys: Constellation) -> Option<&'static str> {
    Some(match sys {
        Constellation::Gps => "G    8 C1C L1C D1C S1C C2W L2W D2W S2W",
        Constellation::Glonass => "R    8 C1C L1C D1C S1C C2C L2C D2C S2C",
        Constellation::Galileo => "E    8 C1C L1C D1C S1C C5Q L5Q D5Q S5Q",
        Constellation::Qzss => "J    8 C1C L1C D1C S1C C2L L2L D2L S2L",
        _ => return None,
    })
}

/// The `GLONASS SLOT / FRQ #` lines: the count, then eight `Rnn ±k` a line.
fn glonass_slot_lines(glonass: &[(u8, i8)]) -> Vec<String> {
    glonass
        .chunks(8)
        .enumerate()
        .map(|(i, chunk)| {
            let mut l = if i == 0 {
                format!("{:3} ", glonass.len())
            } else {
                "    ".to_string()
            };
            for (slot, ch) in chunk {
                let _ = write!(l, "R{slot:02} {ch:2} ");
            }
            l
        })
        .collect()
}

/// The RINEX 3.04 observation header.
pub(super) fn header(h: &HeaderInfo) -> String {
    let mut s = String::new();
    let mut line = |a: String, b: &str| {
        let _ = writeln!(s, "{a:<60}{b}");
    };
    line(
        "     3.04           OBSERVATION DATA    M".into(),
        "RINEX VERSION / TYPE",
    );
    line("ppkat simulate      ppkat".into(), "PGM / RUN BY / DATE");
    line(
        "Simulated by ppkat: synthetic constellation, exact truth".into(),
        "COMMENT",
    );
    line(h.name.to_string(), "MARKER NAME");
    line(format!("{:<20}{:<20}", "SIM", "PPKAT"), "OBSERVER / AGENCY");
    line(
        format!("{:<20}{:<20}{:<20}", "1", "PPKAT SIMULATOR", "1.0"),
        "REC # / TYPE / VERS",
    );
    line(
        format!("{:<20}{:<20}", "1", "PPKATSIM        NONE"),
        "ANT # / TYPE",
    );
    let p = h.pos;
    line(
        format!("{:14.4}{:14.4}{:14.4}", p.0.x, p.0.y, p.0.z),
        "APPROX POSITION XYZ",
    );
    line(
        format!("{:14.4}{:14.4}{:14.4}", 0.0, 0.0, 0.0),
        "ANTENNA: DELTA H/E/N",
    );
    for (sys, types) in h
        .systems
        .iter()
        .filter_map(|&sys| Some((sys, obs_types(sys)?)))
    {
        let types = match sys {
            Constellation::Gps => types.replacen("C1C", &format!("C1{}", h.gps_l1 as char), 1),
            _ => types.to_string(),
        };
        if h.bands == 1 {
            // "G    8 C1C L1C D1C S1C …" → "G    4 C1C L1C D1C S1C"
            line(
                format!("{}4{}", &types[..5], &types[6..22]),
                "SYS / # / OBS TYPES",
            );
        } else {
            line(types, "SYS / # / OBS TYPES");
        }
    }
    line(format!("{:10.3}", h.interval), "INTERVAL");
    let (y, mo, d, hh, mi, sec, ns) = h.start.to_gregorian(TimeScale::GPST);
    line(
        format!(
            "{y:6}{mo:6}{d:6}{hh:6}{mi:6}{:13.7}     GPS",
            sec as f64 + ns as f64 * 1e-9
        ),
        "TIME OF FIRST OBS",
    );
    if h.systems.contains(&Constellation::Glonass) {
        for l in glonass_slot_lines(h.glonass) {
            line(l, "GLONASS SLOT / FRQ #");
        }
        line(
            " C1C    0.000 C1P    0.000 C2C    0.000 C2P    0.000".into(),
            "GLONASS COD/PHS/BIS",
        );
    }
    line(String::new(), "END OF HEADER");
    s
}
