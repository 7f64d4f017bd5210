//! BeiDou B1I/B2I D1 and D2 navigation messages, independent of the receiver: the BCH(15,11,1)
//! check of each word, D1 subframes 1–3 (MEO/IGSO) and D2 subframe 1 pages 1–10 (GEO) into an
//! ephemeris record (BDS-SIS-ICD-B1I-3.0 §5.1.3, §5.2.4, §5.3.3).
//!
//! What enters: subframes as ten 30-bit words (D1…D30 of each word, the first transmitted in
//! bit 29). A word 2–10 holds, after de-interleaving, the 11 information bits of its first BCH
//! code word, the 11 of its second, then the 4 parity bits of the first and the 4 of the
//! second; word 1 holds 15 uncoded bits (preamble, reserved) and one BCH code word. What
//! leaves: the subframe as a 300-bit string whose bit positions are those the ICD numbers
//! (parity bits kept in place, so field positions read as in the ICD figures), and
//! ephemerides as [`NavRecord`]s laid out as the RINEX 3 BeiDou record (as
//! [`super::rtcm_eph`] and [`super::sbf_nav`] make them: AODE, BDT week, SatH1, TGD1, TGD2,
//! transmission time in BDT seconds of the week of toe, AODC; toc in GPST).
//!
//! Fields are described once, in [`D1`] and [`D2`] (which subframe or page, which bit parts,
//! signed or not); the decoder here and the encoder in [`super::ubx_nav_write`] read the same
//! tables.

use super::bits::{bits_u, set_bits};
use super::lnav::ura_metres;
use super::rtcm_eph::BDT_WEEK0;
use crate::rinex::nav::{Klobuchar, NavKind, NavRecord};
use crate::sv::Sv;
use crate::time::{from_week_tow, week_of, WEEK_SECONDS};
use hifitime::Duration;
use std::f64::consts::PI;

/// Bytes of one subframe (300 bits).
pub const SUBFRAME_BYTES: usize = 38;

/// The preamble (the first 11 bits of word 1).
pub const PREAMBLE: u32 = 0b111_0001_0010;

/// Whether satellite `prn` broadcasts D2 (the GEO satellites, PRN 1–5 and 59–63).
pub fn is_d2(prn: u8) -> bool {
    prn <= 5 || prn >= 59
}

/// The 4 parity bits of 11 information bits (generator x⁴ + x + 1, ICD §5.1.3).
pub fn bch_parity(info: u32) -> u32 {
    let mut r = (info & 0x7FF) << 4;
    for k in (4..15).rev() {
        if r >> k & 1 == 1 {
            r ^= 0b10011 << (k - 4);
        }
    }
    r
}

/// Whether a 15-bit code word (11 information bits, then 4 parity bits) is valid.
pub fn bch_ok(code: u32) -> bool {
    bch_parity(code >> 4) == code & 0xF
}

/// Whether word `index` (0–9) of a subframe passes its BCH checks (word 1: its last 15 bits
/// only; words 2–10: both code words).
pub fn check_word(index: usize, word: u32) -> bool {
    let w = word & 0x3FFF_FFFF;
    if index == 0 {
        return bch_ok(w & 0x7FFF);
    }
    let (i1, i2) = (w >> 19 & 0x7FF, w >> 8 & 0x7FF);
    bch_ok(i1 << 4 | (w >> 4 & 0xF)) && bch_ok(i2 << 4 | (w & 0xF))
}

/// The parity bits a word needs, from its information bits (the inverse of [`check_word`]):
/// word `index` with its parity bits replaced by valid ones.
pub fn with_parity(index: usize, word: u32) -> u32 {
    let w = word & 0x3FFF_FFF0;
    if index == 0 {
        return w | bch_parity(w >> 4 & 0x7FF);
    }
    let (i1, i2) = (w >> 19 & 0x7FF, w >> 8 & 0x7FF);
    (w & !0xFF) | bch_parity(i1) << 4 | bch_parity(i2)
}

/// A subframe's 300 bits from its ten 30-bit words.
pub fn subframe(words: &[u32; 10]) -> [u8; SUBFRAME_BYTES] {
    let mut b = [0u8; SUBFRAME_BYTES];
    for (i, w) in words.iter().enumerate() {
        set_bits(&mut b, 30 * i, 30, w & 0x3FFF_FFFF);
    }
    b
}

/// The ten 30-bit words of a subframe's 300 bits (the inverse of [`subframe`]).
pub fn words(sf: &[u8; SUBFRAME_BYTES]) -> [u32; 10] {
    std::array::from_fn(|i| bits_u(sf, 30 * i, 30))
}

/// The subframe id (FraID, 1–5).
pub fn subframe_id(sf: &[u8]) -> u32 {
    bits_u(sf, 15, 3)
}

/// Seconds of the BDT week at the start of the subframe (SOW).
pub fn sow(sf: &[u8]) -> u32 {
    bits_u(sf, 18, 8) << 12 | bits_u(sf, 30, 12)
}

/// The page number (Pnum, 1–10) of a D2 subframe 1.
pub fn d2_page(sf: &[u8]) -> u32 {
    bits_u(sf, 42, 4)
}

/// The Klobuchar parameters of a D1 subframe 1 (α0–α3, β0–β3; ICD §5.2.4.7).
pub fn klobuchar(sf1: &[u8]) -> Klobuchar {
    let field = |parts: &[(usize, usize)]| parts_value(&[sf1], 0, true, parts) as f64;
    Klobuchar {
        alpha: [
            field(&[(126, 8)]) * p2(-30),
            field(&[(134, 8)]) * p2(-27),
            field(&[(150, 8)]) * p2(-24),
            field(&[(158, 8)]) * p2(-24),
        ],
        beta: [
            field(&[(166, 6), (180, 2)]) * p2(11),
            field(&[(182, 8)]) * p2(14),
            field(&[(190, 8)]) * p2(16),
            field(&[(198, 4), (210, 4)]) * p2(16),
        ],
    }
}

/// A quantity of the ephemeris, as the integer the message carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Q {
    /// Autonomous satellite health flag.
    SatH1,
    /// Age of data, clock.
    Aodc,
    /// User range accuracy index.
    Urai,
    /// BDT week number (of transmission).
    Week,
    /// Time of clock (8 s).
    Toc,
    /// Group delay B1I (0.1 ns).
    Tgd1,
    /// Group delay B2I (0.1 ns).
    Tgd2,
    /// Clock bias a0.
    A0,
    /// Clock drift a1.
    A1,
    /// Clock drift rate a2.
    A2,
    /// Age of data, ephemeris.
    Aode,
    /// Mean motion difference Δn.
    Dn,
    /// Argument-of-latitude cosine harmonic.
    Cuc,
    /// Mean anomaly at toe.
    M0,
    /// Eccentricity.
    E,
    /// Argument-of-latitude sine harmonic.
    Cus,
    /// Orbit-radius cosine harmonic.
    Crc,
    /// Orbit-radius sine harmonic.
    Crs,
    /// Square root of the semi-major axis.
    SqrtA,
    /// Time of ephemeris (8 s).
    Toe,
    /// Inclination at toe.
    I0,
    /// Inclination cosine harmonic.
    Cic,
    /// Rate of right ascension Ω̇.
    OmegaDot,
    /// Inclination sine harmonic.
    Cis,
    /// Rate of inclination.
    Idot,
    /// Longitude of the ascending node Ω0.
    Omega0,
    /// Argument of perigee ω.
    Omega,
}

/// How many quantities [`Q`] has.
pub const QUANTITIES: usize = Q::Omega as usize + 1;

/// One field: its quantity, the subframe (D1: 0–2 for subframes 1–3) or page (D2: 0–9 for
/// pages 1–10) that carries it, whether it is two's complement, and its bit parts (position,
/// length), the most significant first.
pub type Field = (Q, usize, bool, &'static [(usize, usize)]);

/// The ephemeris fields of D1 subframes 1–3.
pub const D1: [Field; 27] = [
    (Q::SatH1, 0, false, &[(42, 1)]),
    (Q::Aodc, 0, false, &[(43, 5)]),
    (Q::Urai, 0, false, &[(48, 4)]),
    (Q::Week, 0, false, &[(60, 13)]),
    (Q::Toc, 0, false, &[(73, 9), (90, 8)]),
    (Q::Tgd1, 0, true, &[(98, 10)]),
    (Q::Tgd2, 0, true, &[(108, 4), (120, 6)]),
    (Q::A2, 0, true, &[(214, 11)]),
    (Q::A0, 0, true, &[(225, 7), (240, 17)]),
    (Q::A1, 0, true, &[(257, 5), (270, 17)]),
    (Q::Aode, 0, false, &[(287, 5)]),
    (Q::Dn, 1, true, &[(42, 10), (60, 6)]),
    (Q::Cuc, 1, true, &[(66, 16), (90, 2)]),
    (Q::M0, 1, true, &[(92, 20), (120, 12)]),
    (Q::E, 1, false, &[(132, 10), (150, 22)]),
    (Q::Cus, 1, true, &[(180, 18)]),
    (Q::Crc, 1, true, &[(198, 4), (210, 14)]),
    (Q::Crs, 1, true, &[(224, 8), (240, 10)]),
    (Q::SqrtA, 1, false, &[(250, 12), (270, 20)]),
    (Q::Toe, 1, false, &[(290, 2), (42 + 300, 10), (60 + 300, 5)]),
    (Q::I0, 2, true, &[(65, 17), (90, 15)]),
    (Q::Cic, 2, true, &[(105, 7), (120, 11)]),
    (Q::OmegaDot, 2, true, &[(131, 11), (150, 13)]),
    (Q::Cis, 2, true, &[(163, 9), (180, 9)]),
    (Q::Idot, 2, true, &[(189, 13), (210, 1)]),
    (Q::Omega0, 2, true, &[(211, 21), (240, 11)]),
    (Q::Omega, 2, true, &[(251, 11), (270, 21)]),
];

/// The ephemeris fields of D2 subframe 1 pages 1–10 (page 2 carries none).
pub const D2: [Field; 27] = [
    (Q::SatH1, 0, false, &[(46, 1)]),
    (Q::Aodc, 0, false, &[(47, 5)]),
    (Q::Urai, 0, false, &[(60, 4)]),
    (Q::Week, 0, false, &[(64, 13)]),
    (Q::Toc, 0, false, &[(77, 5), (90, 12)]),
    (Q::Tgd1, 0, true, &[(102, 10)]),
    (Q::Tgd2, 0, true, &[(120, 10)]),
    (Q::A0, 2, true, &[(100, 12), (120, 12)]),
    (Q::A1, 2, true, &[(132, 4), (46 + 300, 6), (60 + 300, 12)]),
    (Q::A2, 3, true, &[(72, 10), (90, 1)]),
    (Q::Aode, 3, false, &[(91, 5)]),
    (Q::Dn, 3, true, &[(96, 16)]),
    (Q::Cuc, 3, true, &[(120, 14), (46 + 300, 4)]),
    (Q::M0, 4, true, &[(50, 2), (60, 22), (90, 8)]),
    (Q::Cus, 4, true, &[(98, 14), (120, 4)]),
    (Q::E, 4, false, &[(124, 10), (46 + 300, 6), (60 + 300, 16)]),
    (Q::SqrtA, 5, false, &[(76, 6), (90, 22), (120, 4)]),
    (Q::Cic, 5, true, &[(124, 10), (46 + 300, 6), (60 + 300, 2)]),
    (Q::Cis, 6, true, &[(62, 18)]),
    (Q::Toe, 6, false, &[(80, 2), (90, 15)]),
    (
        Q::I0,
        6,
        true,
        &[(105, 7), (120, 14), (46 + 300, 6), (60 + 300, 5)],
    ),
    (Q::Crc, 7, true, &[(65, 17), (90, 1)]),
    (Q::Crs, 7, true, &[(91, 18)]),
    (Q::OmegaDot, 7, true, &[(109, 3), (120, 16), (46 + 300, 5)]),
    (Q::Omega0, 8, true, &[(51, 1), (60, 22), (90, 9)]),
    (Q::Omega, 8, true, &[(99, 13), (120, 14), (46 + 300, 5)]),
    (Q::Idot, 9, true, &[(51, 1), (60, 13)]),
];

/// The value of bit parts (position, length; a position ≥ 300·k lies in the k-th subframe
/// after `first`), the most significant first, two's complement when `signed`.
fn parts_value(sf: &[&[u8]], first: usize, signed: bool, parts: &[(usize, usize)]) -> i64 {
    let (mut v, mut n) = (0i64, 0usize);
    for &(pos, len) in parts {
        let s = sf.get(first + pos / 300).copied().unwrap_or(&[]);
        v = v << len | bits_u(s, pos % 300, len) as i64;
        n += len;
    }
    if signed && n > 0 && v >> (n - 1) & 1 == 1 {
        v - (1 << n)
    } else {
        v
    }
}

/// A field's value from the subframes.
fn read(f: &Field, sf: &[&[u8; SUBFRAME_BYTES]]) -> i64 {
    let s: Vec<&[u8]> = sf.iter().map(|x| &x[..]).collect();
    parts_value(&s, f.1, f.2, f.3)
}

/// Write a field's value (its low bits) into the subframes (the inverse of `read`).
pub fn write(f: &Field, v: i64, sf: &mut [[u8; SUBFRAME_BYTES]]) {
    let (_, first, _, parts) = *f;
    let mut left: usize = parts.iter().map(|p| p.1).sum();
    for &(pos, len) in parts {
        left -= len;
        let bits = (v >> left) as u32 & ((1u64 << len) - 1) as u32;
        if let Some(s) = sf.get_mut(first + pos / 300) {
            set_bits(s, pos % 300, len, bits);
        }
    }
}

/// The quantities of a set of subframes (D1: subframes 1–3; D2: pages 1–10).
pub fn quantities(table: &[Field], sf: &[&[u8; SUBFRAME_BYTES]]) -> [i64; QUANTITIES] {
    let mut q = [0i64; QUANTITIES];
    for f in table {
        q[f.0 as usize] = read(f, sf);
    }
    q
}

fn p2(e: i32) -> f64 {
    2f64.powi(e)
}

/// Scale of each quantity (semicircle quantities already in radians).
pub fn scale(q: Q) -> f64 {
    match q {
        Q::Toc | Q::Toe => 8.0,
        Q::Tgd1 | Q::Tgd2 => 1e-10,
        Q::A0 => p2(-33),
        Q::A1 => p2(-50),
        Q::A2 => p2(-66),
        Q::Dn | Q::OmegaDot | Q::Idot => p2(-43) * PI,
        Q::M0 | Q::I0 | Q::Omega0 | Q::Omega => p2(-31) * PI,
        Q::Cuc | Q::Cus | Q::Cic | Q::Cis => p2(-31),
        Q::Crc | Q::Crs => p2(-6),
        Q::E => p2(-33),
        Q::SqrtA => p2(-19),
        _ => 1.0,
    }
}

/// Why a set of subframes makes no ephemeris.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetError {
    /// The parts are not of one frame (their SOWs do not follow each other): a part was lost
    /// or a new frame began while collecting; the set completes with later parts.
    Inconsistent,
}

/// An ephemeris of satellite `sv` from D1 subframes 1–3 (`d2` false) or D2 subframe 1 pages
/// 1–10 (`d2` true), given in order; the parts must be of one frame.
pub fn ephemeris(sv: Sv, sf: &[&[u8; SUBFRAME_BYTES]], d2: bool) -> Result<NavRecord, SetError> {
    let (table, step, count): (&[Field], u32, usize) = if d2 { (&D2, 3, 10) } else { (&D1, 6, 3) };
    let sow0 = sow(*sf.first().ok_or(SetError::Inconsistent)?);
    let in_frame = sf.len() == count
        && sf.iter().enumerate().all(|(k, s)| {
            // D2 page 2 is the ionosphere page, sent between pages 1 and 3 all the same.
            sow(*s) == sow0 + step * k as u32
        });
    if !in_frame {
        return Err(SetError::Inconsistent);
    }
    let q = quantities(table, sf);
    Ok(record(sv, &q, sow0))
}

/// The record of the quantities of one ephemeris; `sow0` is the transmission time (BDT
/// seconds of the week of `Week`) of its first part.
pub fn record(sv: Sv, q: &[i64; QUANTITIES], sow0: u32) -> NavRecord {
    let v = |x: Q| q[x as usize] as f64 * scale(x);
    let toe = v(Q::Toe);
    let sent = sow0 as f64;
    // The week broadcast is that of transmission; toe may lie in the week before or after.
    let week = week_of(q[Q::Week as usize], toe, sent);
    let sent_in_toe_week = sent + (q[Q::Week as usize] - week) as f64 * WEEK_SECONDS;
    let orbit = vec![
        v(Q::Aode),
        v(Q::Crs),
        v(Q::Dn),
        v(Q::M0),
        v(Q::Cuc),
        v(Q::E),
        v(Q::Cus),
        v(Q::SqrtA),
        toe,
        v(Q::Cic),
        v(Q::Omega0),
        v(Q::Cis),
        v(Q::I0),
        v(Q::Crc),
        v(Q::Omega),
        v(Q::OmegaDot),
        v(Q::Idot),
        0.0,
        week as f64,
        0.0,
        ura_metres(q[Q::Urai as usize] as u32),
        v(Q::SatH1),
        v(Q::Tgd1),
        v(Q::Tgd2),
        sent_in_toe_week,
        v(Q::Aodc),
    ];
    let toc =
        from_week_tow((week + BDT_WEEK0).max(0) as u32, v(Q::Toc)) + Duration::from_seconds(14.0);
    NavRecord {
        sv,
        kind: NavKind::Kepler,
        toc,
        clock: [v(Q::A0), v(Q::A1), v(Q::A2)],
        orbit,
        line: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bch_parity_by_hand() {
        // x¹⁰ · x⁴ = x¹⁴ ≡ x³ + 1 (mod x⁴ + x + 1): parity 1001.
        assert_eq!(bch_parity(0b100_0000_0000), 0b1001);
        // x⁰ · x⁴ ≡ x + 1: parity 0011; x¹ · x⁴ = x⁵ ≡ x² + x: 0110.
        assert_eq!(bch_parity(1), 0b0011);
        assert_eq!(bch_parity(2), 0b0110);
        // Linear: the parity of a sum is the sum of the parities.
        assert_eq!(bch_parity(0b100_0000_0011), 0b1001 ^ 0b0011 ^ 0b0110);
    }

    #[test]
    fn bch_detects_every_single_bit_error() {
        for index in [0, 4] {
            let w = with_parity(index, 0x2B5_A5F0 ^ (index as u32) << 20);
            assert!(check_word(index, w));
            let coded = if index == 0 { 15 } else { 30 };
            for bit in 0..coded {
                assert!(!check_word(index, w ^ 1 << bit), "word {index} bit {bit}");
            }
        }
    }

    #[test]
    fn klobuchar_fields_across_words() {
        let mut sf = [0u8; SUBFRAME_BYTES];
        set_bits(&mut sf, 126, 8, 0xFD); // α0 = −3
        set_bits(&mut sf, 158, 8, 0x07); // α3 = 7
                                         // β0 = −74 = 1011 0110: its 6 MSBs in word 7, its 2 LSBs past word 7's parity.
        set_bits(&mut sf, 166, 6, 0b101101);
        set_bits(&mut sf, 180, 2, 0b10);
        set_bits(&mut sf, 198, 4, 0b0001); // β3 = 0001 0011 = 19
        set_bits(&mut sf, 210, 4, 0b0011);
        let k = klobuchar(&sf);
        assert_eq!(k.alpha, [-3.0 * p2(-30), 0.0, 0.0, 7.0 * p2(-24)]);
        assert_eq!(k.beta, [-74.0 * p2(11), 0.0, 0.0, 19.0 * p2(16)]);
    }

    #[test]
    fn tables_cover_each_quantity_once_without_overlap() {
        for (table, parts) in [(&D1, 3), (&D2, 10)] {
            let mut used = vec![[false; 300]; parts];
            for q in 0..QUANTITIES {
                assert_eq!(table.iter().filter(|f| f.0 as usize == q).count(), 1);
            }
            for &(_, first, _, bits) in table.iter() {
                for &(pos, len) in bits {
                    for b in pos..pos + len {
                        let (s, k) = (first + b / 300, b % 300);
                        assert!(!used[s][k], "bit {k} of part {s} twice");
                        // Past the header, never a parity bit (words 2–10's last 8).
                        assert!(k >= 42 && (k - 30) % 30 < 22, "bit {k} of part {s}");
                        used[s][k] = true;
                    }
                }
            }
        }
    }
}
