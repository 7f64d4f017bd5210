//! Carrier frequencies and the choice of signals per system.

use crate::rinex::ObsCode;
use crate::sv::Constellation;

/// Carrier frequency (Hz) of a band of a system; GLONASS FDMA needs the channel number.
pub fn frequency(sys: Constellation, band: u8, glo_channel: Option<i8>) -> Option<f64> {
    const MHZ: f64 = 1e6;
    Some(match (sys, band) {
        (Constellation::Glonass, b'1') => (1602.0 + 0.5625 * glo_channel? as f64) * MHZ,
        (Constellation::Glonass, b'2') => (1246.0 + 0.4375 * glo_channel? as f64) * MHZ,
        (Constellation::Glonass, b'3') => 1202.025 * MHZ,
        (Constellation::BeiDou, b'2') => 1561.098 * MHZ,
        (Constellation::BeiDou, b'6') => 1268.52 * MHZ,
        (_, b'1') => 1575.42 * MHZ,
        (_, b'2') => 1227.60 * MHZ,
        (_, b'5') => 1176.45 * MHZ,
        (_, b'6') => 1278.75 * MHZ,
        (_, b'7') => 1207.14 * MHZ,
        (_, b'8') => 1191.795 * MHZ,
        (Constellation::Irnss, b'9') => 2492.028 * MHZ,
        _ => return None,
    })
}

/// Preferred first-frequency code observations per system, best first. The band of the
/// broadcast group delay (TGD/BGD) must match, so BeiDou uses B1I (band 2).
pub fn primary_codes(sys: Constellation) -> &'static [&'static [u8; 3]] {
    match sys {
        Constellation::Gps | Constellation::Qzss => &[b"C1C", b"C1W", b"C1P", b"C1X", b"C1L"],
        Constellation::Galileo => &[b"C1C", b"C1X", b"C1B"],
        Constellation::BeiDou => &[b"C2I", b"C2X", b"C1I"],
        Constellation::Glonass => &[b"C1C", b"C1P"],
        Constellation::Irnss => &[b"C5A", b"C5X"],
        Constellation::Sbas => &[b"C1C"],
    }
}

/// Index of the first of `wanted` present in `types`.
pub fn find_code(types: &[ObsCode], wanted: &[&[u8; 3]]) -> Option<usize> {
    wanted
        .iter()
        .find_map(|w| types.iter().position(|t| &t.0 == *w))
}
