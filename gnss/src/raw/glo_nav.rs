//! GLONASS L1OF/L2OF navigation strings, independent of the receiver: the Hamming code (KX)
//! of each string, and strings 1–4 into an ephemeris record (GLONASS ICD edition 5.1 §4.4,
//! §4.7).
//!
//! What enters: a string as 85 bits in 11 bytes, the first transmitted (ICD bit 85, the idle
//! bit) the most significant bit of byte 0, so that ICD bit `i` is bit `85 − i` here. What
//! leaves: ephemerides as [`NavRecord`]s laid out as the RINEX 3 GLONASS record, as
//! [`super::rtcm_eph`] (message 1020) makes them: toe (tb) in GPST, −τn, γn and the message
//! frame time (tk, UTC seconds of the week), positions, velocities and accelerations in km,
//! km/s and km/s², the health flag (the MSB of Bn), the frequency channel and the age En. The
//! string carries times of day only (Moscow time); the day is the one nearest the receiver's
//! time, as for RTCM 1020.
//!
//! Fields are described once, in [`FIELDS`]; the decoder here and the encoder in
//! [`super::ubx_nav_write`] read the same table.

use super::bits::{bits_u, set_bits};
use super::rtcm_eph::nearest_day;
use super::rtcm_msm::{leap_seconds, WEEK_MS};
use crate::rinex::nav::{NavKind, NavRecord};
use crate::sv::Sv;
use hifitime::Epoch;

/// Bytes of one string (85 bits, padded).
pub const STRING_BYTES: usize = 11;

/// ICD bit `i` (1–85) of a string.
fn bit(s: &[u8], i: usize) -> u32 {
    bits_u(s, 85 - i, 1)
}

/// The Hamming-code position of data bit `i` (9–85): the (i − 8)-th position, counting from
/// 3, that is not a power of two.
fn code_position(i: usize) -> usize {
    (3usize..)
        .filter(|p| !p.is_power_of_two())
        .nth(i - 9)
        .unwrap_or(0)
}

/// The check bits β1…β7 the data bits b9…b85 call for (bit k−1 of the result is βk).
fn check_bits(s: &[u8]) -> u32 {
    (9..=85)
        .filter(|&i| bit(s, i) == 1)
        .fold(0, |acc, i| acc ^ code_position(i) as u32)
        & 0x7F
}

/// Whether the string's Hamming code holds: no error, or an error in one check bit only (a
/// data bit in error is not corrected: the string is refused).
pub fn hamming_ok(s: &[u8; STRING_BYTES]) -> bool {
    let given = (1..=7).fold(0u32, |acc, k| acc | bit(s, k) << (k - 1));
    let syndrome = (given ^ check_bits(s)).count_ones();
    let overall = (1..=85).fold(0, |acc, i| acc ^ bit(s, i));
    (syndrome == 0 && overall == 0) || (syndrome == 1 && overall == 1)
}

/// Set the string's check bits b1…b8 from its data bits (the encoder's side).
pub fn set_hamming(s: &mut [u8; STRING_BYTES]) {
    let beta = check_bits(s);
    for k in 1..=7 {
        set_bits(s, 85 - k, 1, beta >> (k - 1) & 1);
    }
    set_bits(s, 85 - 8, 1, 0);
    let overall = (1..=85).fold(0, |acc, i| acc ^ bit(s, i));
    set_bits(s, 85 - 8, 1, overall);
}

/// The string number m (ICD bits 84–81).
pub fn string_number(s: &[u8]) -> u32 {
    bits_u(s, 1, 4)
}

/// A quantity of the ephemeris, as the integer the strings carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum G {
    /// tk hours.
    TkH,
    /// tk minutes.
    TkM,
    /// tk half-minute (30 s).
    TkS,
    /// Velocity x (2⁻²⁰ km/s).
    Vx,
    /// Acceleration x (2⁻³⁰ km/s²).
    Ax,
    /// Position x (2⁻¹¹ km).
    X,
    /// The MSB of Bn (health flag).
    Bn,
    /// tb, index of the 15-min interval of the day (Moscow time).
    Tb,
    /// Velocity y.
    Vy,
    /// Acceleration y.
    Ay,
    /// Position y.
    Y,
    /// Relative frequency offset γn (2⁻⁴⁰).
    Gamma,
    /// Velocity z.
    Vz,
    /// Acceleration z.
    Az,
    /// Position z.
    Z,
    /// Clock offset τn (2⁻³⁰ s).
    Tau,
    /// Age of the data En (days).
    En,
    /// Slot number n.
    Slot,
}

/// How many quantities [`G`] has.
pub const QUANTITIES: usize = G::Slot as usize + 1;

/// One field: its quantity, the string (0–3 for strings 1–4), whether it is sign-magnitude,
/// and its position (bits from the idle bit) and length.
pub type Field = (G, usize, bool, usize, usize);

/// The ephemeris fields of strings 1–4.
pub const FIELDS: [Field; QUANTITIES] = [
    (G::TkH, 0, false, 9, 5),
    (G::TkM, 0, false, 14, 6),
    (G::TkS, 0, false, 20, 1),
    (G::Vx, 0, true, 21, 24),
    (G::Ax, 0, true, 45, 5),
    (G::X, 0, true, 50, 27),
    // The MSB of Bn, the health flag RINEX and RTCM 1020 keep.
    (G::Bn, 1, false, 5, 1),
    (G::Tb, 1, false, 9, 7),
    (G::Vy, 1, true, 21, 24),
    (G::Ay, 1, true, 45, 5),
    (G::Y, 1, true, 50, 27),
    (G::Gamma, 2, true, 6, 11),
    (G::Vz, 2, true, 21, 24),
    (G::Az, 2, true, 45, 5),
    (G::Z, 2, true, 50, 27),
    (G::Tau, 3, true, 5, 22),
    (G::En, 3, false, 32, 5),
    (G::Slot, 3, false, 70, 5),
];

/// The quantities of strings 1–4.
pub fn quantities(s: [&[u8; STRING_BYTES]; 4]) -> [i64; QUANTITIES] {
    let mut q = [0i64; QUANTITIES];
    for &(g, k, sm, pos, len) in &FIELDS {
        q[g as usize] = if sm {
            let mag = bits_u(s[k], pos + 1, len - 1) as i64;
            if bits_u(s[k], pos, 1) == 1 {
                -mag
            } else {
                mag
            }
        } else {
            bits_u(s[k], pos, len) as i64
        };
    }
    q
}

/// Write a field's value into its string (sign-magnitude fields saturate at their largest
/// magnitude).
pub fn write(f: &Field, v: i64, s: &mut [u8; STRING_BYTES]) {
    let &(_, _, sm, pos, len) = f;
    if sm {
        let mag = v.unsigned_abs().min((1 << (len - 1)) - 1) as u32;
        set_bits(s, pos, 1, u32::from(v < 0));
        set_bits(s, pos + 1, len - 1, mag);
    } else {
        set_bits(s, pos, len, (v as u64 & ((1u64 << len) - 1)) as u32);
    }
}

fn p2(e: i32) -> f64 {
    2f64.powi(e)
}

/// Scale of each quantity (positions in km, velocities km/s, accelerations km/s²).
pub fn scale(g: G) -> f64 {
    match g {
        G::Vx | G::Vy | G::Vz => p2(-20),
        G::Ax | G::Ay | G::Az | G::Tau => p2(-30),
        G::X | G::Y | G::Z => p2(-11),
        G::Gamma => p2(-40),
        G::Tb => 900.0,
        _ => 1.0,
    }
}

/// Why strings 1–4 make no ephemeris.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetError {
    /// String 4 names another slot than the satellite's.
    Slot,
    /// The receiver's time is not known yet, so the day of tb cannot be placed.
    NoTime,
}

/// An ephemeris of satellite `sv` on frequency `channel` from strings 1–4 of one frame;
/// `now_ms` is the receiver's time (GPST ms since the GPS epoch).
pub fn ephemeris(
    sv: Sv,
    channel: i8,
    s: [&[u8; STRING_BYTES]; 4],
    now_ms: Option<i64>,
) -> Result<NavRecord, SetError> {
    let q = quantities(s);
    if q[G::Slot as usize] != sv.prn as i64 {
        return Err(SetError::Slot);
    }
    let now = now_ms.ok_or(SetError::NoTime)?;
    Ok(record(sv, channel, &q, now))
}

/// The record of the quantities of strings 1–4 received at `now` (GPST ms).
pub fn record(sv: Sv, channel: i8, q: &[i64; QUANTITIES], now: i64) -> NavRecord {
    let v = |g: G| q[g as usize] as f64 * scale(g);
    let tk_s = q[G::TkH as usize] * 3600 + q[G::TkM as usize] * 60 + q[G::TkS as usize] * 30;
    let leap = leap_seconds(now) * 1000;
    // Moscow time (UTC + 3 h) of day → UTC on the day nearest the receiver's time → GPST
    let toe_utc = nearest_day((v(G::Tb) as i64 - 10_800) * 1000, now - leap);
    let tof_utc = nearest_day((tk_s - 10_800) * 1000, toe_utc);
    NavRecord {
        sv,
        kind: NavKind::Glonass,
        toc: Epoch::from_gpst_seconds((toe_utc + leap) as f64 * 1e-3),
        clock: [
            -v(G::Tau),
            v(G::Gamma),
            tof_utc.rem_euclid(WEEK_MS) as f64 * 1e-3,
        ],
        orbit: vec![
            v(G::X),
            v(G::Vx),
            v(G::Ax),
            v(G::Bn),
            v(G::Y),
            v(G::Vy),
            v(G::Ay),
            channel as f64,
            v(G::Z),
            v(G::Vz),
            v(G::Az),
            v(G::En),
        ],
        line: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The data bits of each check bit βk as the ICD lists them (§4.7), typed from the text.
    fn icd_lists() -> [Vec<usize>; 7] {
        let r = |a: usize, b: usize| (a..=b).collect::<Vec<_>>();
        let cat = |v: &[Vec<usize>]| v.concat();
        [
            vec![
                9, 10, 12, 13, 15, 17, 19, 20, 22, 24, 26, 28, 30, 32, 34, 35, 37, 39, 41, 43, 45,
                47, 49, 51, 53, 55, 57, 59, 61, 63, 65, 66, 68, 70, 72, 74, 76, 78, 80, 82, 84,
            ],
            vec![
                9, 11, 12, 14, 15, 18, 19, 21, 22, 25, 26, 29, 30, 33, 34, 36, 37, 40, 41, 44, 45,
                48, 49, 52, 53, 56, 57, 60, 61, 64, 65, 67, 68, 71, 72, 75, 76, 79, 80, 83, 84,
            ],
            vec![
                10, 11, 12, 16, 17, 18, 19, 23, 24, 25, 26, 31, 32, 33, 34, 38, 39, 40, 41, 46, 47,
                48, 49, 54, 55, 56, 57, 62, 63, 64, 65, 69, 70, 71, 72, 77, 78, 79, 80, 85,
            ],
            cat(&[r(13, 19), r(27, 34), r(42, 49), r(58, 65), r(73, 80)]),
            cat(&[r(20, 34), r(50, 65), r(81, 85)]),
            r(35, 65),
            r(66, 85),
        ]
    }

    #[test]
    fn check_bits_are_the_icd_equations() {
        let lists = icd_lists();
        for i in 9..=85 {
            let mut s = [0u8; STRING_BYTES];
            set_bits(&mut s, 85 - i, 1, 1);
            for (k, list) in lists.iter().enumerate() {
                assert_eq!(
                    check_bits(&s) >> k & 1 == 1,
                    list.contains(&i),
                    "b{i} in β{}",
                    k + 1
                );
            }
        }
    }

    #[test]
    fn hamming_by_hand() {
        // Only b9 set: β1 = β2 = 1 (b9 is in both lists), β3…β7 = 0, and β8 makes the sum of
        // all 85 bits even: b1 + b2 + b9 = 3, so β8 = 1. KX (b8…b1) = 1000 0011.
        let mut s = [0u8; STRING_BYTES];
        set_bits(&mut s, 85 - 9, 1, 1);
        set_hamming(&mut s);
        assert_eq!(bits_u(&s, 77, 8), 0b1000_0011);
        assert!(hamming_ok(&s));
        // An error in one check bit only is accepted; in a data bit, or two bits, refused.
        for i in 1..=85 {
            let mut e = s;
            set_bits(&mut e, 85 - i, 1, bit(&s, i) ^ 1);
            assert_eq!(hamming_ok(&e), i <= 7, "b{i}");
        }
        let mut e = s;
        set_bits(&mut e, 85 - 20, 2, 0b11);
        assert!(!hamming_ok(&e));
    }
}
