//! RTCM 3 ephemeris messages: fields at their documented bit positions and scales
//! (hand-built payloads, GLONASS sign-magnitude included), every system through
//! encode → decode, week resolution, and refused messages.

use gnss::orbit::{Eph, Ephemerides};
use gnss::raw::bits::set_bits;
use gnss::raw::rtcm_eph::{decode_ephemeris, gps_week, EphError};
use gnss::raw::rtcm_eph_write::ephemeris_frame;
use gnss::raw::rtcm_msm::WEEK_MS;
use gnss::rinex::nav::{NavFile, NavKind, NavRecord};
use gnss::sv::{Constellation, Sv};
use gnss::time::from_week_tow;
use hifitime::Duration;
use std::f64::consts::PI;

fn p2(e: i32) -> f64 {
    2f64.powi(e)
}

fn payload(f: &[u8]) -> &[u8] {
    &f[3..f.len() - 3]
}

#[test]
fn gps_fields_at_their_bits() {
    let mut p = [0u8; 61];
    set_bits(&mut p, 0, 12, 1019);
    set_bits(&mut p, 12, 6, 7); // PRN 7
    set_bits(&mut p, 18, 10, 255); // week 2048 + 255 = 2303
    set_bits(&mut p, 48, 8, 42); // IODE
    set_bits(&mut p, 56, 16, 22_500); // toc 360 000 s
    set_bits(&mut p, 96, 22, 0x3F_FFFF); // af0 = −1 LSB (two's complement)
    set_bits(&mut p, 160, 32, 0x8000_0000); // M0 = −1 semicircle
    set_bits(&mut p, 208, 32, 1 << 23); // e = 2^23 · 2^-33
    set_bits(&mut p, 256, 32, 0xA100_0000); // √A = 5152 √m
    set_bits(&mut p, 288, 16, 22_500); // toe 360 000 s
    set_bits(&mut p, 448, 24, 0xFF_FFFE); // Ω̇ = −2 · 2^-43 semicircles/s
    set_bits(&mut p, 480, 6, 0);
    let now = 2303 * WEEK_MS + 350_000_000;
    let r = decode_ephemeris(&p, Some(now), None).unwrap();
    assert_eq!(r.sv, Sv::new(Constellation::Gps, 7));
    assert_eq!(r.toc, from_week_tow(2303, 360_000.0));
    assert_eq!(r.clock[0], -p2(-31));
    let o = &r.orbit;
    assert_eq!(o[0], 42.0);
    assert_eq!(o[3], -PI);
    assert_eq!(o[5], p2(-10));
    assert_eq!(o[7], 5152.0);
    assert_eq!(o[8], 360_000.0);
    assert_eq!(o[15], -2.0 * p2(-43) * PI);
    assert_eq!(o[18], 2303.0);
    assert_eq!(o[25], 4.0, "fit flag 0: 4 h");
    // the broadcast week is that of transmission: sent late in week 2302, a toe of 0 s
    // belongs to week 2303
    let mut q = p;
    set_bits(&mut q, 18, 10, 254);
    set_bits(&mut q, 288, 16, 0);
    let late = decode_ephemeris(&q, Some(2302 * WEEK_MS + 600_000_000), None).unwrap();
    assert_eq!(late.orbit[18], 2303.0);
    assert_eq!(
        decode_ephemeris(&p[..60], Some(now), None).unwrap_err(),
        EphError::Short
    );
    set_bits(&mut p, 12, 6, 0);
    assert_eq!(
        decode_ephemeris(&p, Some(now), None).unwrap_err(),
        EphError::Satellite(0)
    );
}

#[test]
fn ten_bit_weeks_follow_the_reference() {
    assert_eq!(gps_week(255, None), 2303);
    assert_eq!(gps_week(255, Some(1300)), 1279);
    assert_eq!(gps_week(1000, Some(2050)), 2024);
    assert_eq!(gps_week(10, Some(3070)), 3082);
}

/// GLONASS signed fields are sign-magnitude: the top bit is the sign alone.
#[test]
fn glonass_sign_magnitude_fields() {
    let mut p = [0u8; 45];
    set_bits(&mut p, 0, 12, 1020);
    set_bits(&mut p, 12, 6, 3); // slot 3
    set_bits(&mut p, 18, 5, 3); // channel −4
    set_bits(&mut p, 27, 5, 13); // tk 13:25:30 Moscow
    set_bits(&mut p, 32, 6, 25);
    set_bits(&mut p, 38, 1, 1);
    set_bits(&mut p, 41, 7, 54); // tb 54 × 15 min = 13:30 Moscow = 10:30 UTC
    set_bits(&mut p, 48, 24, 1 << 23 | 1000); // ẋ = −1000 · 2^-20 km/s
    set_bits(&mut p, 72, 27, 5); // x = +5 · 2^-11 km
    set_bits(&mut p, 99, 5, 0b10011); // ẍ = −3 · 2^-30 km/s²
    set_bits(&mut p, 128, 27, 1 << 26 | 12_345_678); // y negative
    set_bits(&mut p, 217, 11, 1 << 10 | 3); // γ = −3 · 2^-40
    set_bits(&mut p, 231, 22, 7); // τ = +7 · 2^-30 s → clock[0] = −τ
    set_bits(&mut p, 258, 5, 2); // age
    let day = 2303 * WEEK_MS + 3 * 86_400_000; // Wednesday 2024-02-28, 00:00 GPST
    let r = decode_ephemeris(&p, Some(day + 36_000_000), None).unwrap();
    assert_eq!(r.kind, NavKind::Glonass);
    let o = &r.orbit;
    assert_eq!(o[0], 5.0 * p2(-11));
    assert_eq!(o[1], -1000.0 * p2(-20));
    assert_eq!(o[2], -3.0 * p2(-30));
    assert_eq!(o[4], -12_345_678.0 * p2(-11));
    assert_eq!((o[7], o[11]), (-4.0, 2.0));
    assert_eq!(r.clock[0], -7.0 * p2(-30));
    assert_eq!(r.clock[1], -3.0 * p2(-40));
    // toe 10:30 UTC + 18 s; frame time 10:25:30 UTC as seconds of the (UTC) week
    let toc = from_week_tow(2303, 3.0 * 86_400.0 + 37_800.0 + 18.0);
    assert_eq!(r.toc, toc);
    assert_eq!(r.clock[2], 3.0 * 86_400.0 + 37_530.0);
    assert_eq!(
        decode_ephemeris(&p, None, None).unwrap_err(),
        EphError::NoTime
    );
}

fn kepler(sys: Constellation, prn: u8, week: u32, toe: f64, tail: &[f64]) -> NavRecord {
    let sc = PI * p2(-31);
    let mut orbit = vec![
        9.0,
        -123.0 * p2(-5),
        4567.0 * p2(-43) * PI,
        -1_234_567_890.0 * sc,
        -2222.0 * p2(-29),
        87_654_321.0 * p2(-33),
        3333.0 * p2(-29),
        2_702_000_000.0 * p2(-19),
        toe,
        -44.0 * p2(-29),
        987_654_321.0 * sc,
        55.0 * p2(-29),
        666_666_666.0 * sc,
        7777.0 * p2(-5),
        -1_111_111_111.0 * sc,
        -8_000_000.0 * p2(-43) * PI,
        -1234.0 * p2(-43) * PI,
    ];
    if sys == Constellation::BeiDou {
        for (k, v) in [1usize, 4, 6, 9, 11, 13]
            .iter()
            .zip([-5.0, 7.0, 9.0, -3.0, 4.0, 11.0])
        {
            orbit[*k] = v * if *k == 1 || *k == 13 { p2(-6) } else { p2(-31) };
        }
    }
    orbit.extend_from_slice(tail);
    let shift = if sys == Constellation::BeiDou {
        14.0
    } else {
        0.0
    };
    let week = if sys == Constellation::BeiDou {
        week + 1356
    } else {
        week
    };
    NavRecord {
        sv: Sv::new(sys, prn),
        kind: NavKind::Kepler,
        toc: from_week_tow(week, toe) + Duration::from_seconds(shift),
        clock: [-12345.0 * p2(-34), 77.0 * p2(-46), 0.0],
        orbit,
        line: 0,
    }
}

/// Encode then decode: every value back (on the grid, exactly but for the transmission time).
#[test]
fn every_system_round_trips() {
    let w = 2303u32;
    let now = w as i64 * WEEK_MS + 300_000_000;
    let ttr = 300_000.0;
    let mut recs = vec![
        // GPS: codes, week, L2P, URA, health, TGD, IODC, ttr, fit
        kepler(
            Constellation::Gps,
            5,
            w,
            302_400.0,
            &[
                1.0,
                w as f64,
                0.0,
                2.0,
                0.0,
                -3.0 * p2(-31),
                265.0,
                ttr,
                4.0,
            ],
        ),
        kepler(
            Constellation::Qzss,
            2,
            w,
            302_400.0,
            &[2.0, w as f64, 1.0, 2.8, 1.0, 5.0 * p2(-31), 521.0, ttr, 2.0],
        ),
        // Galileo I/NAV and F/NAV: source, week, spare, SISA, health, BGDs, ttr
        kepler(
            Constellation::Galileo,
            11,
            w,
            302_400.0,
            &[
                517.0,
                w as f64,
                0.0,
                2.0 + 7.0 * 0.16,
                0.0,
                7.0 * p2(-32),
                -2.0 * p2(-32),
                ttr,
            ],
        ),
        kepler(
            Constellation::Galileo,
            12,
            w,
            302_400.0,
            &[258.0, w as f64, 0.0, 0.5, 24.0, 7.0 * p2(-32), 0.0, ttr],
        ),
        // BeiDou: spare, BDT week, spare, URA, SatH1, TGD1, TGD2, ttr, AODC
        kepler(
            Constellation::BeiDou,
            20,
            w - 1356,
            302_392.0,
            &[
                0.0,
                (w - 1356) as f64,
                0.0,
                2.0,
                0.0,
                12.0 * 1e-10,
                -5.0 * 1e-10,
                ttr - 14.0,
                3.0,
            ],
        ),
    ];
    for r in &mut recs[..2] {
        r.clock = [-12345.0 * p2(-31), 77.0 * p2(-43), -2.0 * p2(-55)];
    }
    recs[4].clock = [-12345.0 * p2(-33), 77.0 * p2(-50), 3.0 * p2(-66)];
    recs[4].orbit[0] = 17.0;
    for r in &recs {
        let f = ephemeris_frame(r).unwrap();
        let back = decode_ephemeris(payload(&f), Some(now), None).unwrap();
        assert_eq!(
            (back.sv, back.kind, back.toc),
            (r.sv, r.kind, r.toc),
            "{}",
            r.sv
        );
        assert_eq!(back.clock, r.clock, "{}", r.sv);
        assert_eq!(back.orbit.len(), r.orbit.len(), "{}", r.sv);
        for (k, (a, b)) in back.orbit.iter().zip(&r.orbit).enumerate() {
            let ttr_field = k == 24;
            assert!(ttr_field || a == b, "{} field {k}: {a} vs {b}", r.sv);
        }
    }
    // GLONASS, its times on the 30 s / 15 min grid
    let toe = from_week_tow(w, 3.0 * 86_400.0 + 37_818.0);
    let glo = NavRecord {
        sv: Sv::new(Constellation::Glonass, 9),
        kind: NavKind::Glonass,
        toc: toe,
        clock: [-5.0 * p2(-30), 2.0 * p2(-40), 3.0 * 86_400.0 + 37_530.0],
        orbit: vec![
            -1e7 * p2(-11),
            3.0 * p2(-20),
            -p2(-30),
            0.0,
            2e7 * p2(-11),
            -3e5 * p2(-20),
            0.0,
            6.0,
            -1.5e7 * p2(-11),
            2e6 * p2(-20),
            2.0 * p2(-30),
            1.0,
        ],
        line: 0,
    };
    let f = ephemeris_frame(&glo).unwrap();
    let back = decode_ephemeris(payload(&f), Some(now), None).unwrap();
    assert_eq!(
        (back.toc, back.clock, &back.orbit),
        (glo.toc, glo.clock, &glo.orbit)
    );
    // satellite positions agree exactly through the orbit code too
    let nav = |r: Vec<NavRecord>| {
        Ephemerides::from_nav(&[NavFile {
            records: r,
            ..NavFile::default()
        }])
    };
    let decoded: Vec<NavRecord> = recs
        .iter()
        .map(|r| decode_ephemeris(payload(&ephemeris_frame(r).unwrap()), Some(now), None).unwrap())
        .collect();
    let (a, b) = (nav(recs.clone()), nav(decoded));
    for r in &recs {
        let (Some(Eph::Kepler(x)), Some(Eph::Kepler(y))) = (a.of(r.sv).first(), b.of(r.sv).first())
        else {
            panic!("{}", r.sv)
        };
        let t = x.toe + Duration::from_seconds(1800.0);
        assert!(
            (x.compute(t).pos.0 - y.compute(t).pos.0).norm() < 1e-6,
            "{}",
            r.sv
        );
    }
}
