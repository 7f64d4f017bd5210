//! Logs as low-cost receivers write them.
//!
//! A u-blox base logs RXM-RAWX beside the RTCM 3 it sends (1005 station, MSM7, 1230, …) and
//! NMEA: every frame is read as its protocol (no checksum failure), the observations are the
//! RAWX ones (the same as the UBX alone), the station comes from 1005 and the GGA fixes become
//! the receiver's own `.pos`.
//!
//! A DJI-like RTCM 3 log carries stale GPS ephemerides of other weeks (first in the log)
//! beside the current ones and Galileo ones: it is dated by their consensus, with no hint, a
//! year hint or the right date; a date six weeks off is refused; the stale ones are counted
//! and named. Logs dated before (2018) and after (2039) the 1024-week cycle of today whose
//! Galileo or BeiDou ephemerides are days old are dated by their whole weeks' cycle.

use gnss::obs::read_obs;
use gnss::raw::convert::{convert, Outputs};
use gnss::raw::rtcm_msm::WEEK_MS;
use gnss::raw::rtcm_write::{
    msm, station_1005, week_1019, week_1042, week_1046, MsmSat, MsmSignal,
};
use gnss::raw::ubx_write::ubx_from_obs;
use gnss::raw::TimeHint;
use gnss::rinex::ObsFile;
use gnss::solution::{read_pos, Quality};
use gnss::sv::Constellation;
use std::path::PathBuf;
use testkit::scratch_path as tmp;

const STATION: [f64; 3] = [3_582_105.291, 532_589.731, 5_232_754.805];

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("fixtures")
        .join(name)
}

/// An NMEA sentence with its checksum.
fn nmea(body: &str) -> Vec<u8> {
    let sum = body.bytes().fold(0u8, |a, c| a ^ c);
    format!("${body}*{sum:02X}\r\n").into_bytes()
}

/// The frames of a UBX byte stream, in order.
fn ubx_frames(b: &[u8]) -> Vec<&[u8]> {
    let mut out = Vec::new();
    let mut i = 0;
    while i + 8 <= b.len() {
        let n = u16::from_le_bytes([b[i + 4], b[i + 5]]) as usize + 8;
        out.push(&b[i..i + n]);
        i += n;
    }
    out
}

fn gps_msm(tow_ms: i64) -> Vec<u8> {
    let sat = MsmSat {
        id: 7,
        glo_channel: None,
        sigs: vec![MsmSignal {
            id: 2,
            pr: 21_234_567.89,
            cp: 111_589_000.25,
            doppler: -1234.5,
            cno: 44.0,
            lock_ms: 60_000,
            half: false,
        }],
    };
    msm(Constellation::Gps, 7, tow_ms as u32, false, &[sat])
}

#[test]
fn a_base_log_mixing_ubx_rtcm_and_nmea_is_read_as_all_three() {
    let obs = ObsFile::read(&fixture("events_v304.rnx")).unwrap();
    let (ubx, _) = ubx_from_obs(&obs);
    let pure = tmp("pure.ubx");
    std::fs::write(&pure, &ubx).unwrap();
    let mut mixed = station_1005(STATION);
    mixed.extend(nmea("GPGSV,1,1,01,07,45,120,44"));
    let mut ggas = 0;
    for (k, f) in ubx_frames(&ubx).into_iter().enumerate() {
        mixed.extend_from_slice(f);
        if f[2] == 0x02 && f[3] == 0x15 {
            let tod = 12 * 10_000 + k; // 12:00:0k UTC
            mixed.extend(nmea(&format!(
                "GNGGA,{tod:06}.00,5030.4123,N,00931.2345,E,4,12,0.7,120.5,M,47.3,M,1.0,0001"
            )));
            ggas += 1;
            let tow = gnss::time::week_tow(obs.epochs[0].time).1 as i64 * 1000;
            mixed.extend(gps_msm(tow + 1000 * k as i64));
            mixed.extend(gnss::raw::rtcm::frame(&[0x4c, 0xe0, 0, 0])); // 1230
        }
    }
    let log = tmp("base_mixed.ubx");
    std::fs::write(&log, &mixed).unwrap();

    let a = read_obs(&pure, None, None).unwrap();
    let b = read_obs(&log, None, None).unwrap();
    let st = b.raw.as_ref().unwrap();
    assert_eq!(st.checksum_failures, 0, "{st}");
    assert_eq!(st.protocols.get("NMEA"), Some(&(ggas + 1)), "{st}");
    assert_eq!(st.protocols.get("RTCM 3"), Some(&(2 * ggas + 1)), "{st}");
    assert_eq!(
        st.unused
            .get("RTCM 1077 (observations taken from RXM-RAWX)")
            .copied(),
        Some(ggas),
        "{st}"
    );
    assert_eq!(st.unused.get("RTCM 1230").copied(), Some(ggas), "{st}");
    assert_eq!(st.nmea_fixes, ggas, "{st}");
    let p = b
        .obs
        .header
        .approx_position
        .expect("1005 gives the base position");
    for (got, want) in p.0.iter().zip(STATION) {
        assert!((got - want).abs() < 1e-3, "{p:?}");
    }
    assert_eq!(a.obs.epochs.len(), b.obs.epochs.len());
    for (x, y) in a.obs.epochs.iter().zip(&b.obs.epochs) {
        assert_eq!(x.time, y.time);
        assert_eq!(x.sats.len(), y.sats.len());
        for (u, v) in x.sats.iter().zip(&y.sats) {
            assert_eq!(u.sv, v.sv);
            for k in 0..8 {
                let (g, h) = (u.get(k), v.get(k));
                assert!(g.value.to_bits() == h.value.to_bits() && g.lli == h.lli);
            }
        }
    }

    // The receiver's own fixes as a .pos.
    let (out, pos) = (tmp("base_mixed.obs"), tmp("base_mixed_nmea.pos"));
    let outs = Outputs {
        obs: &out,
        nav: None,
        events: None,
        nmea: Some(&pos),
    };
    convert(&log, None, None, outs).unwrap();
    let fixes = read_pos(&pos).unwrap();
    assert_eq!(fixes.len() as u64, ggas);
    assert!(fixes
        .iter()
        .all(|f| f.quality == Quality::Fixed && f.nsat == 12));
    let g = fixes[0].pos.to_geodetic();
    assert!((g.h - 167.8).abs() < 1e-3, "{}", g.h);
    // 12:00:00 UTC of the fixture's day is 12:00:18 GPST.
    let t0 = obs.epochs[0].time;
    assert!((fixes[0].time - t0).to_seconds() - 18.0 < 1e-6);
}

/// 2018-10-24 (Wednesday) 10:00 GPST: GPS week 2024.
const TOW: i64 = 3 * 86_400_000 + 10 * 3_600_000;

fn dji_like_log(name: &str) -> PathBuf {
    let mut b = Vec::new();
    // Stale ephemerides first: one at the same time of week six weeks earlier.
    b.extend(week_1019_sat(5, 2018, TOW / 1000 + 1800));
    b.extend(week_1019_sat(9, 2019, 2 * 86_400));
    b.extend(week_1019_sat(12, 2022, TOW / 1000 - 3600));
    for k in 0..20 {
        b.extend(gps_msm(TOW + 200 * k));
        if k == 3 {
            for prn in 14..20 {
                b.extend(week_1019_sat(prn, 2024, TOW / 1000 + 1200));
            }
            for prn in 1..4 {
                b.extend(week_1046(prn, 2024, (TOW / 1000 - 600) as u32));
            }
        }
    }
    let p = tmp(name);
    std::fs::write(&p, b).unwrap();
    p
}

/// A week-only 1019 of satellite `prn`.
fn week_1019_sat(prn: u8, week: u16, toc_s: i64) -> Vec<u8> {
    let f = week_1019(week, toc_s as u32);
    // The satellite id is bits 12..18 of the payload (after the 3-byte header).
    let mut p = f[3..f.len() - 3].to_vec();
    p[1] = (p[1] & 0xf0) | (prn >> 2);
    p[2] = (p[2] & 0x3f) | ((prn & 3) << 6);
    gnss::raw::rtcm::frame(&p)
}

#[test]
fn a_dji_like_log_is_dated_by_its_current_ephemerides() {
    let log = dji_like_log("dji_like.rtcm3");
    let want = 2024 * WEEK_MS + TOW;
    for hint in [
        None,
        Some(TimeHint::Year(2018)),
        Some(TimeHint::Date(2018, 10, 24)),
    ] {
        let input = read_obs(&log, None, hint).unwrap();
        let t = input.obs.epochs[0].time;
        let ms = (t.to_gpst_seconds() * 1000.0).round() as i64;
        assert_eq!(ms, want, "hint {hint:?}");
        let st = input.raw.unwrap();
        assert!(st.warnings.is_empty(), "{st}");
        assert_eq!(st.nav.stale, 3, "{st}");
        let named = st.nav.stale_named.join(" ");
        assert!(
            named.contains("G05") && named.contains("G09") && named.contains("G12"),
            "{named}"
        );
        assert!(st.time_source.unwrap().contains("2024"));
    }
    let e = read_obs(&log, None, Some(TimeHint::Date(2018, 9, 12)))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("contradicts") && e.contains("2018") && e.contains("2024"),
        "{e}"
    );
}

/// What a DJI-like log carries beside its current GPS ephemerides.
#[derive(Clone, Copy, Debug)]
enum Whole {
    /// Galileo ephemerides of the observations' time.
    GalileoCurrent,
    /// Galileo ephemerides of the week's start, days before the observations (the real
    /// Phantom 4 RTK log of October 2018).
    GalileoStale,
    /// BeiDou ephemerides of the day before.
    BeiDouStale,
    /// None: GPS only.
    None,
}

/// A DJI-like log of GPS week `week` at [`TOW`]: stale GPS ephemerides of weeks before,
/// current GPS ones, and `whole`.
fn dated_log(name: &str, week: u16, whole: Whole) -> PathBuf {
    let mut b = Vec::new();
    b.extend(week_1019_sat(5, week - 6, TOW / 1000 + 1800));
    b.extend(week_1019_sat(9, week - 5, 2 * 86_400));
    for k in 0..20 {
        b.extend(gps_msm(TOW + 200 * k));
        if k == 3 {
            for prn in 14..20 {
                b.extend(week_1019_sat(prn, week, TOW / 1000 + 1200));
            }
            for prn in 1..8 {
                b.extend(match whole {
                    Whole::GalileoCurrent => week_1046(prn, week, (TOW / 1000 - 600) as u32),
                    Whole::GalileoStale => week_1046(prn, week, 0),
                    Whole::BeiDouStale => week_1042(prn, week, (TOW / 1000 - 86_400) as u32),
                    Whole::None => Vec::new(),
                });
            }
        }
    }
    let p = tmp(name);
    std::fs::write(&p, b).unwrap();
    p
}

/// Logs of 2018 (before the 1024-week cycle of today, 2019–2038) and 2039 (after it) are
/// dated right with no hint when they carry Galileo or BeiDou ephemerides, current or days
/// old (before, the old ones were thrown away as stale and the GPS weeks dated the 2018 log
/// 2038). A GPS-only log is dated in the latest cycle not after today — right for 2018 — and
/// the source of its date names `--date-hint`; a 2039 GPS-only log needs the hint.
#[test]
fn logs_of_other_cycles_are_dated_by_their_whole_weeks() {
    for week in [2024u16, 3100] {
        for whole in [
            Whole::GalileoCurrent,
            Whole::GalileoStale,
            Whole::BeiDouStale,
            Whole::None,
        ] {
            let log = dated_log(&format!("dated_{week}_{whole:?}.rtcm3"), week, whole);
            let input = read_obs(&log, None, None).unwrap();
            let ms = (input.obs.epochs[0].time.to_gpst_seconds() * 1000.0).round() as i64;
            let st = input.raw.unwrap();
            let source = st.time_source.clone().unwrap();
            let got = ms.div_euclid(WEEK_MS);
            assert_eq!(ms.rem_euclid(WEEK_MS), TOW);
            match (week, whole) {
                // Read today (before 2039), a GPS-only 2039 log falls in today's cycle.
                (3100, Whole::None) => assert_eq!(got, 3100 - 1024, "{source}"),
                _ => assert_eq!(got, week as i64, "{whole:?}: {source}"),
            }
            if matches!(whole, Whole::None) {
                assert!(source.contains("--date-hint"), "{source}");
                let hinted = read_obs(&log, None, Some(TimeHint::Year(2039))).unwrap();
                let t = hinted.obs.epochs[0].time.to_gpst_seconds();
                let want = week as i64 * (WEEK_MS / 1000) + TOW / 1000;
                let year_cycle = if week == 3100 {
                    want
                } else {
                    want + 1024 * 604_800
                };
                assert_eq!(t.round() as i64, year_cycle, "{whole:?} {week}");
            }
            if matches!(whole, Whole::GalileoStale | Whole::BeiDouStale) {
                assert!(source.contains("7 stale Galileo/BeiDou"), "{source}");
                assert_eq!(st.nav.stale, 9, "{st}");
            }
        }
    }
}
