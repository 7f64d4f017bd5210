//! GPS and QZSS LNAV (L1 C/A) navigation message, independent of the receiver: word parity,
//! subframes 1–3 into an ephemeris record, subframe 4 page 18 into the Klobuchar parameters
//! and leap seconds (IS-GPS-200 §20.3).
//!
//! What enters: subframes as ten 24-bit data words (parity already checked with
//! [`check_word`]) and the full GPS week the receiver knows. What leaves: ephemerides as
//! [`NavRecord`]s laid out as a RINEX 3 navigation record, so that the RINEX writer and
//! [`crate::orbit::Ephemerides`] take them as they take a navigation file.

use super::bits::{bits_s, bits_u, set_bits};
use crate::rinex::nav::{Klobuchar, NavKind, NavRecord};
use crate::sv::{Constellation, Sv};
use crate::time::{from_week_tow, week_of};
use std::f64::consts::PI;

/// The TLM word's preamble (its first 8 data bits).
pub const PREAMBLE: u32 = 0x8B;

/// Bytes of one subframe's data bits (ten words of 24 bits).
pub const SUBFRAME_BYTES: usize = 30;

/// Data bits (1-based, d1 the first transmitted) in each of the six parity equations
/// D25…D30, and whether D29* (true) or D30* (false) of the previous word enters it.
const PARITY: [(&[u8], bool); 6] = [
    (&[1, 2, 3, 5, 6, 10, 11, 12, 13, 14, 17, 18, 20, 23], true),
    (&[2, 3, 4, 6, 7, 11, 12, 13, 14, 15, 18, 19, 21, 24], false),
    (&[1, 3, 4, 5, 7, 8, 12, 13, 14, 15, 16, 19, 20, 22], true),
    (&[2, 4, 5, 6, 8, 9, 13, 14, 15, 16, 17, 20, 21, 23], false),
    (
        &[1, 3, 5, 6, 7, 9, 10, 14, 15, 16, 17, 18, 21, 22, 24],
        false,
    ),
    (&[3, 5, 6, 8, 9, 10, 11, 13, 15, 19, 22, 23, 24], true),
];

/// The 24 source data bits of a 30-bit word as transmitted (D1…D30, D1 the most significant),
/// given the last two parity bits D29*, D30* of the word before; `None` when the parity fails.
/// When D30* is set the transmitted data bits are complemented, as the ICD specifies.
pub fn check_word(word: u32, d29: bool, d30: bool) -> Option<u32> {
    let mut data = (word >> 6) & 0xFF_FFFF;
    if d30 {
        data ^= 0xFF_FFFF;
    }
    let mut parity = 0u32;
    for (bits, uses_d29) in PARITY {
        let mut p = u32::from(if uses_d29 { d29 } else { d30 });
        for &b in bits {
            p ^= (data >> (24 - b)) & 1;
        }
        parity = (parity << 1) | p;
    }
    (parity == word & 0x3F).then_some(data)
}

/// A subframe's data bits from its ten 24-bit data words.
pub fn subframe(words: &[u32; 10]) -> [u8; SUBFRAME_BYTES] {
    let mut b = [0u8; SUBFRAME_BYTES];
    for (i, w) in words.iter().enumerate() {
        set_bits(&mut b, 24 * i, 24, *w);
    }
    b
}

/// The subframe id (1–5) of the handover word.
pub fn subframe_id(sf: &[u8]) -> u32 {
    bits_u(sf, 43, 3)
}

/// Why subframes 1–3 do not make an ephemeris.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetError {
    /// Their issues of data differ (a new upload arrived while collecting): wait for the rest.
    Inconsistent,
    /// The receiver does not know the GPS week yet, so the 10-bit week is ambiguous.
    NoWeek,
}

const SC: f64 = PI; // semicircles to radians

fn p2(e: i32) -> f64 {
    2f64.powi(e)
}

/// Nominal URA in metres of a URA index (IS-GPS-200 §20.3.3.3.1.1; 15: no prediction).
pub(crate) fn ura_metres(n: u32) -> f64 {
    match n {
        0..=6 => [2.0, 2.8, 4.0, 5.7, 8.0, 11.3, 16.0][n as usize],
        7..=14 => p2(n as i32 - 2),
        _ => 8192.0,
    }
}

/// An ephemeris from subframes 1, 2 and 3 of satellite `sv` (GPS or QZSS); `week` is the full
/// GPS week the receiver knows (it resolves the broadcast week modulo 1024).
pub fn ephemeris(
    sv: Sv,
    sf: [&[u8; SUBFRAME_BYTES]; 3],
    week: Option<u16>,
) -> Result<NavRecord, SetError> {
    let [s1, s2, s3] = sf;
    let iodc = bits_u(s1, 70, 2) << 8 | bits_u(s1, 168, 8);
    let (iode2, iode3) = (bits_u(s2, 48, 8), bits_u(s3, 216, 8));
    if iode2 != iode3 || iode2 != iodc & 0xFF {
        return Err(SetError::Inconsistent);
    }
    let week = week.ok_or(SetError::NoWeek)?;
    let wn10 = bits_u(s1, 48, 10) as i64;
    let sent_week = wn10 + 1024 * ((week as i64 - wn10) as f64 / 1024.0).round() as i64;
    let tow1 = bits_u(s1, 24, 17) as f64 * 6.0;
    let toe_s = bits_u(s2, 216, 16) as f64 * 16.0;
    // The week of toe: toe may lie in the next (or previous) week of transmission.
    let full = week_of(sent_week, toe_s, tow1);
    let toc_s = bits_u(s1, 176, 16) as f64 * 16.0;
    let tgd = bits_s(s1, 160, 8);
    let fit_flag = bits_u(s2, 232, 1) == 1;
    let fit_hours = match (sv.sys, fit_flag) {
        (Constellation::Qzss, false) => 2.0,
        (Constellation::Qzss, true) => 4.0,
        (_, false) => 4.0,
        (_, true) => 6.0,
    };
    let orbit = vec![
        iode2 as f64,
        bits_s(s2, 56, 16) as f64 * p2(-5),
        bits_s(s2, 72, 16) as f64 * p2(-43) * SC,
        bits_s(s2, 88, 32) as f64 * p2(-31) * SC,
        bits_s(s2, 120, 16) as f64 * p2(-29),
        bits_u(s2, 136, 32) as f64 * p2(-33),
        bits_s(s2, 168, 16) as f64 * p2(-29),
        bits_u(s2, 184, 32) as f64 * p2(-19),
        toe_s,
        bits_s(s3, 48, 16) as f64 * p2(-29),
        bits_s(s3, 64, 32) as f64 * p2(-31) * SC,
        bits_s(s3, 96, 16) as f64 * p2(-29),
        bits_s(s3, 112, 32) as f64 * p2(-31) * SC,
        bits_s(s3, 144, 16) as f64 * p2(-5),
        bits_s(s3, 160, 32) as f64 * p2(-31) * SC,
        bits_s(s3, 192, 24) as f64 * p2(-43) * SC,
        bits_s(s3, 224, 14) as f64 * p2(-43) * SC,
        bits_u(s1, 58, 2) as f64,
        full as f64,
        bits_u(s1, 72, 1) as f64,
        ura_metres(bits_u(s1, 60, 4)),
        bits_u(s1, 64, 6) as f64,
        // −128 means "no TGD" (IS-GPS-200 §20.3.3.3.1.2 note).
        if tgd == -128 {
            0.0
        } else {
            tgd as f64 * p2(-31)
        },
        iodc as f64,
        tow1,
        fit_hours,
    ];
    Ok(NavRecord {
        sv,
        kind: NavKind::Kepler,
        toc: from_week_tow(full as u32, toc_s),
        clock: [
            bits_s(s1, 216, 22) as f64 * p2(-31),
            bits_s(s1, 200, 16) as f64 * p2(-43),
            bits_s(s1, 192, 8) as f64 * p2(-55),
        ],
        orbit,
        line: 0,
    })
}

/// Klobuchar parameters and the current leap seconds (GPS − UTC) of subframe 4 page 18
/// (SV id 56); `None` for any other subframe or page.
pub fn iono_utc(sf: &[u8; SUBFRAME_BYTES]) -> Option<(Klobuchar, i32)> {
    if subframe_id(sf) != 4 || bits_u(sf, 50, 6) != 56 {
        return None;
    }
    let a = |k: usize, e: i32| bits_s(sf, 56 + 8 * k, 8) as f64 * p2(e);
    let k = Klobuchar {
        alpha: [a(0, -30), a(1, -27), a(2, -24), a(3, -24)],
        beta: [a(4, 11), a(5, 14), a(6, 16), a(7, 16)],
    };
    Some((k, bits_s(sf, 192, 8)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Encode 24 data bits with parity for given D29*, D30* (the inverse of `check_word`).
    fn encode(data: u32, d29: bool, d30: bool) -> u32 {
        (0..64)
            .map(|p| (if d30 { data ^ 0xFF_FFFF } else { data }) << 6 | p)
            .find(|&w| check_word(w, d29, d30) == Some(data))
            .unwrap()
    }

    #[test]
    fn parity_detects_every_single_bit_error() {
        for (d29, d30) in [(false, false), (true, false), (false, true), (true, true)] {
            let w = encode(0x8B_1234, d29, d30);
            assert_eq!(check_word(w, d29, d30), Some(0x8B_1234));
            for bit in 0..30 {
                assert_eq!(check_word(w ^ (1 << bit), d29, d30), None, "bit {bit}");
            }
        }
    }

    #[test]
    fn page_18_gives_klobuchar_and_leap_seconds() {
        let mut sf = [0u8; SUBFRAME_BYTES];
        set_bits(&mut sf, 43, 3, 4);
        set_bits(&mut sf, 48, 2, 1);
        set_bits(&mut sf, 50, 6, 56);
        for (k, v) in [15i32, 16, -12, -4, 32, 4, -4, 4].iter().enumerate() {
            set_bits(&mut sf, 56 + 8 * k, 8, *v as u32 & 0xFF);
        }
        set_bits(&mut sf, 192, 8, 18);
        let (k, leap) = iono_utc(&sf).unwrap();
        assert_eq!(
            k.alpha,
            [
                15.0 * p2(-30),
                16.0 * p2(-27),
                -12.0 * p2(-24),
                -4.0 * p2(-24)
            ]
        );
        assert_eq!(
            k.beta,
            [32.0 * p2(11), 4.0 * p2(14), -4.0 * p2(16), 4.0 * p2(16)]
        );
        assert_eq!(leap, 18);
        set_bits(&mut sf, 50, 6, 55);
        assert!(iono_utc(&sf).is_none());
    }

    #[test]
    fn ura_table() {
        assert_eq!(ura_metres(0), 2.0);
        assert_eq!(ura_metres(7), 32.0);
        assert_eq!(ura_metres(14), 4096.0);
        assert_eq!(ura_metres(15), 8192.0);
    }
}
