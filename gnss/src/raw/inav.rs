//! Galileo I/NAV (E1-B, E5b-I) navigation message, independent of the receiver: nominal page
//! checks (even/odd order, alert pages, CRC-24Q) and word types 1–5 into an ephemeris record
//! (Galileo OS SIS ICD §4.3).
//!
//! What enters: the even and odd half of a page, each as 120 bits left-aligned in 16 bytes.
//! What leaves: 128-bit data words (112 bits of the even half, 16 of the odd), and ephemerides
//! as [`NavRecord`]s laid out as a RINEX 3 Galileo record.

use super::bits::{bits_s, bits_u, crc24q, set_bits};
use crate::rinex::nav::{NavKind, NavRecord};
use crate::sv::{Constellation, Sv};
use crate::time::{from_week_tow, week_of};
use std::f64::consts::PI;

/// Bytes of one data word (128 bits: the word type, then its fields).
pub const WORD_BYTES: usize = 16;

/// Why a page gives no data word.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PageError {
    /// The halves are not an even then an odd part.
    EvenOdd,
    /// An alert page (no navigation data).
    Alert,
    /// The CRC-24Q over both halves fails.
    Crc,
}

/// The data word of a nominal page from its even and odd halves (120 bits each,
/// left-aligned), after checking the part order, the page type and the CRC.
pub fn page_word(even: &[u8; 16], odd: &[u8; 16]) -> Result<[u8; WORD_BYTES], PageError> {
    if bits_u(even, 0, 1) != 0 || bits_u(odd, 0, 1) != 1 {
        return Err(PageError::EvenOdd);
    }
    if bits_u(even, 1, 1) == 1 || bits_u(odd, 1, 1) == 1 {
        return Err(PageError::Alert);
    }
    // CRC over the even half's first 114 bits and the odd half's first 82, right-aligned in
    // 25 bytes (4 leading zero bits).
    let mut c = [0u8; 25];
    for k in 0..114 {
        set_bits(&mut c, 4 + k, 1, bits_u(even, k, 1));
    }
    for k in 0..82 {
        set_bits(&mut c, 118 + k, 1, bits_u(odd, k, 1));
    }
    if crc24q(&c) != bits_u(odd, 82, 24) {
        return Err(PageError::Crc);
    }
    let mut w = [0u8; WORD_BYTES];
    for k in 0..112 {
        set_bits(&mut w, k, 1, bits_u(even, 2 + k, 1));
    }
    set_bits(&mut w, 112, 16, bits_u(odd, 2, 16));
    Ok(w)
}

/// The word type (0–63) of a data word.
pub fn word_type(w: &[u8]) -> u32 {
    bits_u(w, 0, 6)
}

/// The issue of data (IODnav) of word types 1–4.
pub fn iod_nav(w: &[u8]) -> u32 {
    bits_u(w, 6, 10)
}

fn p2(e: i32) -> f64 {
    2f64.powi(e)
}

/// SISA in metres of its index (ICD §5.1.12); −1 for "no accuracy prediction" (NAPA).
pub(crate) fn sisa_metres(n: u32) -> f64 {
    match n {
        0..=49 => n as f64 * 0.01,
        50..=74 => 0.5 + (n - 50) as f64 * 0.02,
        75..=99 => 1.0 + (n - 75) as f64 * 0.04,
        100..=125 => 2.0 + (n - 100) as f64 * 0.16,
        _ => -1.0,
    }
}

/// An ephemeris from word types 1–5 of satellite `sv` received on E1-B (`e5b` false) or
/// E5b-I; `None` when the words' types or issues of data do not match, or word 4 names
/// another satellite.
pub fn ephemeris(sv: Sv, w: [&[u8; WORD_BYTES]; 5], e5b: bool) -> Option<NavRecord> {
    let [w1, w2, w3, w4, w5] = w;
    if (0..5).any(|k| word_type(w[k]) != k as u32 + 1) {
        return None;
    }
    let iod = iod_nav(w1);
    if [w2, w3, w4].iter().any(|x| iod_nav(*x) != iod) || bits_u(w4, 16, 6) != sv.prn as u32 {
        return None;
    }
    let sc = PI;
    let toe_s = bits_u(w1, 16, 14) as f64 * 60.0;
    let toc_s = bits_u(w4, 54, 14) as f64 * 60.0;
    let tow = bits_u(w5, 85, 20) as f64;
    // GST week of toe: the broadcast week is that of word 5's transmission.
    let week = week_of(bits_u(w5, 73, 12) as i64 + 1024, toe_s, tow);
    let health = bits_u(w5, 67, 2) << 7
        | bits_u(w5, 71, 1) << 6
        | bits_u(w5, 69, 2) << 1
        | bits_u(w5, 72, 1);
    // Data sources: I/NAV on E1-B (bit 0) or E5b-I (bit 2); clock for E5b,E1 (bit 9).
    let source = if e5b { 1 << 2 } else { 1 } | 1 << 9;
    let orbit = vec![
        iod as f64,
        bits_s(w3, 104, 16) as f64 * p2(-5),
        bits_s(w3, 40, 16) as f64 * p2(-43) * sc,
        bits_s(w1, 30, 32) as f64 * p2(-31) * sc,
        bits_s(w3, 56, 16) as f64 * p2(-29),
        bits_u(w1, 62, 32) as f64 * p2(-33),
        bits_s(w3, 72, 16) as f64 * p2(-29),
        bits_u(w1, 94, 32) as f64 * p2(-19),
        toe_s,
        bits_s(w4, 22, 16) as f64 * p2(-29),
        bits_s(w2, 16, 32) as f64 * p2(-31) * sc,
        bits_s(w4, 38, 16) as f64 * p2(-29),
        bits_s(w2, 48, 32) as f64 * p2(-31) * sc,
        bits_s(w3, 88, 16) as f64 * p2(-5),
        bits_s(w2, 80, 32) as f64 * p2(-31) * sc,
        bits_s(w3, 16, 24) as f64 * p2(-43) * sc,
        bits_s(w2, 112, 14) as f64 * p2(-43) * sc,
        source as f64,
        week as f64,
        0.0,
        sisa_metres(bits_u(w3, 120, 8)),
        health as f64,
        bits_s(w5, 47, 10) as f64 * p2(-32),
        bits_s(w5, 57, 10) as f64 * p2(-32),
        tow,
    ];
    Some(NavRecord {
        sv: Sv::new(Constellation::Galileo, sv.prn),
        kind: NavKind::Kepler,
        toc: from_week_tow(week as u32, toc_s),
        clock: [
            bits_s(w4, 68, 31) as f64 * p2(-34),
            bits_s(w4, 99, 21) as f64 * p2(-46),
            bits_s(w4, 120, 6) as f64 * p2(-59),
        ],
        orbit,
        line: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A nominal page carrying `word`, with a valid CRC.
    fn page(word: &[u8; 16]) -> ([u8; 16], [u8; 16]) {
        let (mut e, mut o) = ([0u8; 16], [0u8; 16]);
        set_bits(&mut o, 0, 1, 1);
        for k in 0..112 {
            set_bits(&mut e, 2 + k, 1, bits_u(word, k, 1));
        }
        set_bits(&mut o, 2, 16, bits_u(word, 112, 16));
        let mut c = [0u8; 25];
        for k in 0..114 {
            set_bits(&mut c, 4 + k, 1, bits_u(&e, k, 1));
        }
        for k in 0..82 {
            set_bits(&mut c, 118 + k, 1, bits_u(&o, k, 1));
        }
        set_bits(&mut o, 82, 24, crc24q(&c));
        (e, o)
    }

    #[test]
    fn pages_are_checked() {
        let mut word = [0u8; 16];
        set_bits(&mut word, 0, 6, 4);
        set_bits(&mut word, 6, 10, 77);
        set_bits(&mut word, 112, 16, 0xBEEF);
        let (e, o) = page(&word);
        assert_eq!(page_word(&e, &o), Ok(word));
        let mut bad = o;
        bad[1] ^= 4;
        assert_eq!(page_word(&e, &bad), Err(PageError::Crc));
        assert_eq!(page_word(&o, &e), Err(PageError::EvenOdd));
        let mut alert = e;
        alert[0] |= 0x40;
        assert_eq!(page_word(&alert, &o), Err(PageError::Alert));
    }

    #[test]
    fn sisa_table() {
        assert_eq!(sisa_metres(107), 2.0 + 7.0 * 0.16);
        assert_eq!(sisa_metres(255), -1.0);
    }
}
