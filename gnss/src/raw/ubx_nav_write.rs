//! RXM-SFRBX payloads from BeiDou and GLONASS navigation records (the inverse of the BeiDou
//! and GLONASS paths of [`super::ubx_nav`]), to build test data.
//!
//! What enters: a [`NavRecord`] laid out as RINEX 3 has it (BeiDou Keplerian, GLONASS). What
//! leaves: the SFRBX payloads of one frame — D1 subframes 1–3 (MEO/IGSO) or D2 subframe 1
//! pages 1–10 (GEO) with valid BCH parity, or GLONASS strings 1–4 with a valid Hamming code —
//! each value rounded to the field's resolution; the other fields are 0. Fields are placed by
//! the tables the decoders read ([`bds_nav::D1`], [`bds_nav::D2`], [`glo_nav::FIELDS`]).

use super::bds_nav::{self, Field, Q, QUANTITIES, SUBFRAME_BYTES};
use super::bits::set_bits;
use super::glo_nav::{self, G, STRING_BYTES};
use super::rtcm_eph_write::ura_index;
use super::rtcm_msm::leap_seconds;
use crate::rinex::nav::{NavKind, NavRecord};
use crate::sv::Constellation;
use crate::time::{week_tow, WEEK_SECONDS};
use hifitime::Duration;

/// An SFRBX payload: the header (GNSS id, SV id, signal id, freqId, word count, channel,
/// version 2) and the words, little-endian.
fn payload(gnss: u8, sv: u8, sig: u8, freq: u8, words: &[u32]) -> Vec<u8> {
    let mut p = vec![gnss, sv, sig, freq, words.len() as u8, 0, 2, 0];
    for w in words {
        p.extend_from_slice(&w.to_le_bytes());
    }
    p
}

/// The payloads of one record's frame; `None` for a record of another kind or system, or
/// incomplete.
pub fn sfrbx_payloads(r: &NavRecord) -> Option<Vec<Vec<u8>>> {
    match (r.kind, r.sv.sys) {
        (NavKind::Kepler, Constellation::BeiDou) if r.orbit.len() >= 26 => Some(beidou(r)),
        (NavKind::Glonass, Constellation::Glonass) if r.orbit.len() >= 12 => Some(glonass(r)),
        _ => None,
    }
}

/// The integers a BeiDou record's fields carry, and the transmission time (BDT week, SOW).
fn beidou_quantities(r: &NavRecord) -> ([i64; QUANTITIES], i64, i64) {
    let o = &r.orbit;
    let mut q = [0i64; QUANTITIES];
    let set = |q: &mut [i64; QUANTITIES], x: Q, v: f64| {
        q[x as usize] = (v / bds_nav::scale(x)).round() as i64;
    };
    let (_, toc) = week_tow(r.toc - Duration::from_seconds(14.0));
    let values = [
        (Q::Aode, o[0]),
        (Q::Crs, o[1]),
        (Q::Dn, o[2]),
        (Q::M0, o[3]),
        (Q::Cuc, o[4]),
        (Q::E, o[5]),
        (Q::Cus, o[6]),
        (Q::SqrtA, o[7]),
        (Q::Toe, o[8]),
        (Q::Cic, o[9]),
        (Q::Omega0, o[10]),
        (Q::Cis, o[11]),
        (Q::I0, o[12]),
        (Q::Crc, o[13]),
        (Q::Omega, o[14]),
        (Q::OmegaDot, o[15]),
        (Q::Idot, o[16]),
        (Q::SatH1, o[21]),
        (Q::Tgd1, o[22]),
        (Q::Tgd2, o[23]),
        (Q::Aodc, o[25]),
        (Q::Toc, toc),
        (Q::A0, r.clock[0]),
        (Q::A1, r.clock[1]),
        (Q::A2, r.clock[2]),
    ];
    for (x, v) in values {
        set(&mut q, x, v);
    }
    q[Q::Urai as usize] = ura_index(o[20]);
    // The week broadcast is that of transmission.
    let sent = o[24].round() as i64;
    let week = o[18] as i64 + sent.div_euclid(WEEK_SECONDS as i64);
    q[Q::Week as usize] = week;
    (q, week, sent.rem_euclid(WEEK_SECONDS as i64))
}

fn beidou(r: &NavRecord) -> Vec<Vec<u8>> {
    let d2 = bds_nav::is_d2(r.sv.prn);
    let (table, step, n): (&[Field], i64, usize) = if d2 {
        (&bds_nav::D2, 3, 10)
    } else {
        (&bds_nav::D1, 6, 3)
    };
    let (q, _, sow0) = beidou_quantities(r);
    let mut sf = vec![[0u8; SUBFRAME_BYTES]; n];
    for f in table {
        bds_nav::write(f, q[f.0 as usize], &mut sf);
    }
    sf.iter_mut()
        .enumerate()
        .map(|(k, s)| {
            let sow = (sow0 + step * k as i64) as u32;
            set_bits(s, 0, 11, bds_nav::PREAMBLE);
            set_bits(s, 15, 3, if d2 { 1 } else { k as u32 + 1 });
            set_bits(s, 18, 8, sow >> 12);
            set_bits(s, 30, 12, sow & 0xFFF);
            if d2 {
                set_bits(s, 42, 4, k as u32 + 1);
            }
            let mut w = bds_nav::words(s);
            for (i, x) in w.iter_mut().enumerate() {
                *x = bds_nav::with_parity(i, *x);
            }
            payload(3, r.sv.prn, u8::from(d2), 0, &w)
        })
        .collect()
}

/// Moscow time of day (s) of a UTC instant given in ms.
fn moscow(utc_ms: i64) -> i64 {
    (utc_ms + 10_800_000).rem_euclid(86_400_000) / 1000
}

fn glonass(r: &NavRecord) -> Vec<Vec<u8>> {
    let (o, c) = (&r.orbit, r.clock);
    let t_ms = (r.toc.to_gpst_seconds() * 1000.0).round() as i64;
    let tb = moscow(t_ms - leap_seconds(t_ms) * 1000) / 900;
    let tk = moscow((c[2] * 1000.0).round() as i64);
    let mut q = [0i64; glo_nav::QUANTITIES];
    let scaled = [
        (G::X, o[0]),
        (G::Vx, o[1]),
        (G::Ax, o[2]),
        (G::Y, o[4]),
        (G::Vy, o[5]),
        (G::Ay, o[6]),
        (G::Z, o[8]),
        (G::Vz, o[9]),
        (G::Az, o[10]),
        (G::Gamma, c[1]),
        (G::Tau, -c[0]),
    ];
    for (g, v) in scaled {
        q[g as usize] = (v / glo_nav::scale(g)).round() as i64;
    }
    q[G::Bn as usize] = i64::from(o[3] != 0.0);
    q[G::En as usize] = o[11] as i64;
    q[G::Tb as usize] = tb;
    q[G::Slot as usize] = r.sv.prn as i64;
    (q[G::TkH as usize], q[G::TkM as usize]) = (tk / 3600, tk % 3600 / 60);
    q[G::TkS as usize] = i64::from(tk % 60 >= 30);
    let mut strings = [[0u8; STRING_BYTES]; 4];
    for f in &glo_nav::FIELDS {
        glo_nav::write(f, q[f.0 as usize], &mut strings[f.1]);
    }
    let freq = (o[7] as i64 + 7).clamp(0, 13) as u8;
    // The frame counters of the fourth word: superframe 1, frame 1.
    let frame = 1 << 16 | 1;
    strings
        .iter_mut()
        .enumerate()
        .map(|(k, s)| {
            set_bits(s, 1, 4, k as u32 + 1);
            glo_nav::set_hamming(s);
            let mut b = [0u8; 12];
            b[..STRING_BYTES].copy_from_slice(s);
            let w: Vec<u32> = b
                .chunks_exact(4)
                .map(|c| u32::from_be_bytes([c[0], c[1], c[2], c[3]]))
                .chain([frame])
                .collect();
            payload(6, r.sv.prn, 0, freq, &w)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::ubx_nav::{NavDecoder, NavOut};
    use crate::raw::RawStats;
    use crate::sv::Sv;
    use hifitime::Epoch;
    use std::f64::consts::PI;

    /// Decode the payloads in order; the ephemeris the last one completes.
    fn decode(payloads: &[Vec<u8>], now_ms: i64, st: &mut RawStats) -> Option<NavRecord> {
        let mut dec = NavDecoder::new();
        let mut got = None;
        for p in payloads {
            if let Some(NavOut::Ephemeris(r)) = dec.push(p, Some(now_ms), st) {
                got = Some(r);
            }
        }
        got
    }

    /// Every field back within half the resolution of the field that carries it.
    fn same(a: &NavRecord, b: &NavRecord, lsb: &[f64]) {
        assert_eq!((a.sv, a.kind, a.toc), (b.sv, b.kind, b.toc));
        assert_eq!(a.orbit.len(), b.orbit.len());
        let (x, y): (Vec<f64>, Vec<f64>) = (
            a.clock.iter().chain(&a.orbit).copied().collect(),
            b.clock.iter().chain(&b.orbit).copied().collect(),
        );
        for (k, ((u, v), l)) in x.iter().zip(&y).zip(lsb).enumerate() {
            assert!(
                (u - v).abs() <= l / 2.0 * (1.0 + 1e-9),
                "value {k}: {u} vs {v}"
            );
        }
    }

    fn beidou_record(prn: u8) -> NavRecord {
        // BDT week 944 (GPS week 2300), toc = toe = 3600 s BDT, sent at 3000 s BDT
        let toc = Epoch::from_gpst_seconds(2300.0 * 604_800.0 + 3600.0 + 14.0);
        let mut orbit = vec![
            17.0,
            331.890625,
            -4.659e-9,
            0.8665 * PI,
            1.1011e-5,
            9.5e-4,
            -1.409e-5,
            6493.38,
            3600.0,
            -2.6e-8,
            0.134 * PI,
            -2.3e-8,
            0.0135 * PI,
            424.171875,
            -0.433 * PI,
            -5.5e-9,
            -2.8e-10,
        ];
        orbit.extend([0.0, 944.0, 0.0, 2.0, 1.0, 2.1e-9, -9.5e-9, 3000.0, 5.0]);
        NavRecord {
            sv: Sv::new(Constellation::BeiDou, prn),
            kind: NavKind::Kepler,
            toc,
            clock: [3.94e-4, -2.5e-11, 1.3e-19],
            orbit,
            line: 0,
        }
    }

    #[test]
    fn beidou_d1_and_d2_round_trip() {
        let p2 = |e: i32| 2f64.powi(e);
        let sc = PI;
        let lsb = [
            p2(-33),
            p2(-50),
            p2(-66),
            0.0,
            p2(-6),
            p2(-43) * sc,
            p2(-31) * sc,
            p2(-31),
            p2(-33),
            p2(-31),
            p2(-19),
            0.0,
            p2(-31),
            p2(-31) * sc,
            p2(-31),
            p2(-31) * sc,
            p2(-6),
            p2(-31) * sc,
            p2(-43) * sc,
            p2(-43) * sc,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            1e-10,
            1e-10,
            0.0,
            0.0,
        ];
        let now = (2300 * 604_800 + 3020) * 1000;
        for (prn, d2) in [(23, false), (3, true), (60, true)] {
            let r = beidou_record(prn);
            let p = sfrbx_payloads(&r).unwrap();
            assert_eq!((p.len(), p[0][2]), (if d2 { 10 } else { 3 }, u8::from(d2)));
            let mut st = RawStats::default();
            let back = decode(&p, now, &mut st).unwrap();
            same(&back, &r, &lsb);
            assert_eq!(st.nav.parity_failures + st.nav.page_errors, 0);
            // One bit flipped in any coded word is caught by its BCH code.
            let mut bad = p.clone();
            bad[1][8 + 4 * 5] ^= 0x10;
            assert!(decode(&bad, now, &mut st).is_none());
            assert_eq!(st.nav.parity_failures, 1);
        }
    }

    #[test]
    fn glonass_round_trip() {
        // slot 3, channel −4, tb = 96 (Moscow 24:00 → 21:00 UTC), GPS week 2300
        let toe = Epoch::from_gpst_seconds(2300.0 * 604_800.0 + 3.0 * 86_400.0 + 75_600.0 + 18.0);
        let r = NavRecord {
            sv: Sv::new(Constellation::Glonass, 3),
            kind: NavKind::Glonass,
            toc: toe,
            clock: [
                1.259408891201e-4,
                9.094947017729e-13,
                3.0 * 86_400.0 + 75_570.0,
            ],
            orbit: vec![
                -7741.1689453125,
                -2.988474845886,
                0.0,
                1.0,
                10624.01220703125,
                0.1815881729126,
                1.862645149231e-9,
                -4.0,
                21866.857421875,
                -1.144448280334,
                -2.793967723846e-9,
                3.0,
            ],
            line: 0,
        };
        let p2 = |e: i32| 2f64.powi(e);
        let lsb = [
            p2(-30),
            p2(-40),
            0.0,
            p2(-11),
            p2(-20),
            p2(-30),
            0.0,
            p2(-11),
            p2(-20),
            p2(-30),
            0.0,
            p2(-11),
            p2(-20),
            p2(-30),
            0.0,
        ];
        let p = sfrbx_payloads(&r).unwrap();
        assert_eq!((p.len(), p[0][3]), (4, 3));
        let now = (2300 * 604_800 + 3 * 86_400 + 75_600) * 1000;
        let mut st = RawStats::default();
        same(&decode(&p, now, &mut st).unwrap(), &r, &lsb);
        // Without the receiver's time, the day of tb is unknown.
        let mut dec = NavDecoder::new();
        assert!(p.iter().all(|q| dec.push(q, None, &mut st).is_none()));
        assert_eq!(st.nav.before_week_known, 1);
        // Strings of one frame in any order make the set; a string of a later frame whose
        // string 2 was lost is not mixed with strings of another tb.
        let mut st = RawStats::default();
        let shuffled = [p[0].clone(), p[2].clone(), p[1].clone(), p[3].clone()];
        assert!(decode(&shuffled, now, &mut st).is_some());
        let mut next = r.clone();
        next.toc += hifitime::Duration::from_seconds(1800.0);
        next.orbit[0] += 10.0;
        let q: Vec<Vec<u8>> = sfrbx_payloads(&next)
            .unwrap()
            .into_iter()
            .map(|mut x| {
                x[20..24].copy_from_slice(&(1u32 << 16 | 2).to_le_bytes()); // frame 2
                x
            })
            .collect();
        let mut dec = NavDecoder::new();
        for x in [&p[0], &p[1], &p[2], &q[3]] {
            assert!(dec.push(x, Some(now), &mut st).is_none());
        }
        assert!(dec.push(&q[1], Some(now), &mut st).is_none());
        assert!(dec.push(&q[0], Some(now), &mut st).is_none());
        let Some(NavOut::Ephemeris(b)) = dec.push(&q[2], Some(now), &mut st) else {
            panic!("frame 2 complete");
        };
        assert_eq!((b.toc, b.orbit[0]), (next.toc, next.orbit[0]));
        let mut bad = p.clone();
        bad[2][9] ^= 0x01;
        assert!(decode(&bad, now, &mut st).is_none());
        assert_eq!(st.nav.parity_failures, 1);
    }
}
