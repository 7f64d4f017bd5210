//! RTCM 3 logs: a synthetic log written by the MSM encoder (`gnss::raw::rtcm_write`), read
//! back through the observation seam (format detected from content) and through `convert`,
//! gives every observation back within the message's resolution (plus RINEX's 0.001), with
//! the right times (GPS/Galileo/QZSS week time, BeiDou BDT, GLONASS Moscow time of day),
//! GLONASS channels from 1020, loss-of-lock indicators from the lock times, the station
//! position from 1005, and a corrupted frame counted.

use gnss::obs::{read_obs, ObsFormat};
use gnss::raw::convert::{convert, Outputs};
use gnss::raw::rtcm_msm::WEEK_MS;
use gnss::raw::rtcm_write::{
    channel_1020, msm, station_1005, week_1019, week_1046, MsmSat, MsmSignal,
};
use gnss::raw::{RawFormat, TimeHint};
use gnss::rinex::{ObsCode, ObsFile};
use gnss::signal::frequency;
use gnss::sv::{Constellation, Sv};
use std::path::PathBuf;
use testkit::scratch_path as tmp;

const WEEK: i64 = 2300;
const TOW0_MS: i64 = 345_600_000;
const STATION: [f64; 3] = [4_027_893.654_2, 307_045.743_1, 4_919_474.910_4];

/// A satellite of the plan: system, id, signals (MSM id, band), GLONASS channel.
type Planned = (Constellation, u8, &'static [(u8, u8)], Option<i8>);

/// What a signal should read back as.
struct Expect {
    sv: Sv,
    code: [u8; 2],
    epoch: usize,
    sig: MsmSignal,
    lli: u8,
    msm4: bool,
}

fn lam(sys: Constellation, band: u8, ch: Option<i8>) -> f64 {
    299_792_458.0 / frequency(sys, band, ch).unwrap()
}

/// One satellite with signals of `codes` (MSM id, band), values varying with the epoch.
fn sat(sys: Constellation, id: u8, ch: Option<i8>, sigs: &[(u8, u8)], k: usize) -> MsmSat {
    let range = 21_000_000.0 + 1_234.567_89 * id as f64 + 150.0 * k as f64;
    let rate = -480.123_4 + id as f64;
    let sigs = sigs
        .iter()
        .enumerate()
        .map(|(j, &(sid, band))| {
            let l = lam(sys, band, ch);
            MsmSignal {
                id: sid,
                pr: range + 2.345 * j as f64,
                cp: range / l + 7.25 + j as f64,
                doppler: -rate / l,
                cno: 40.0 + j as f64 + 0.25 * k as f64,
                // the second epoch loses lock on the first signal of satellite 5
                lock_ms: if k == 1 && id == 5 && j == 0 {
                    10
                } else {
                    60_000 + 1000 * k as u64
                },
                half: id == 12 && j == 1,
            }
        })
        .collect();
    MsmSat {
        id,
        glo_channel: ch,
        sigs,
    }
}

/// The log, written to a file of its own per test (tests run in parallel).
fn write_log(name: &str) -> (PathBuf, Vec<Expect>) {
    use Constellation::*;
    let mut bytes = b"\r\n$GPGGA,noise*00\r\n".to_vec();
    bytes.extend(station_1005(STATION));
    bytes.extend(week_1019(WEEK as u16, (TOW0_MS / 1000) as u32));
    bytes.extend(channel_1020(3, -4));
    let plan: [Planned; 6] = [
        (Gps, 5, &[(2, b'1'), (16, b'2')], None),
        (Gps, 12, &[(2, b'1'), (16, b'2')], None),
        (Glonass, 3, &[(2, b'1'), (8, b'2')], Some(-4)),
        (Galileo, 11, &[(2, b'1'), (15, b'7'), (23, b'5')], None),
        (BeiDou, 20, &[(2, b'2'), (14, b'7')], None),
        (Qzss, 2, &[(2, b'1'), (16, b'2')], None),
    ];
    let mut exp = Vec::new();
    for k in 0..3 {
        let t = WEEK * WEEK_MS + TOW0_MS + 1000 * k as i64;
        for sys in [Gps, Glonass, Galileo, BeiDou, Qzss] {
            let sats: Vec<MsmSat> = plan
                .iter()
                .filter(|p| p.0 == sys)
                .map(|p| sat(sys, p.1, p.3, p.2, k))
                .collect();
            let epoch = match sys {
                Glonass => (((t - 18_000).rem_euclid(86_400_000) + 10_800_000) % 86_400_000) as u32,
                BeiDou => ((t - 14_000) % WEEK_MS) as u32,
                _ => (t % WEEK_MS) as u32,
            };
            let kind = if sys == Glonass { 4 } else { 7 };
            let f = msm(sys, kind, epoch, sys != Qzss, &sats);
            if k == 1 && sys == Galileo {
                let mut bad = f.clone();
                bad[8] ^= 0x10;
                bytes.extend(bad);
            }
            bytes.extend(f);
            for (s, p) in sats.iter().zip(plan.iter().filter(|p| p.0 == sys)) {
                for (g, &(_, band)) in s.sigs.iter().zip(p.2) {
                    let code = gnss::raw::rtcm_msm::msm_code(sys, g.id).unwrap();
                    assert_eq!(code[0], band);
                    let slip = k == 1 && s.id == 5 && g.id == 2;
                    exp.push(Expect {
                        sv: Sv::new(sys, s.id),
                        code,
                        epoch: k,
                        sig: *g,
                        lli: u8::from(slip) | u8::from(g.half) << 1,
                        msm4: kind == 4,
                    });
                }
            }
        }
    }
    let p = tmp(name);
    std::fs::write(&p, bytes).unwrap();
    (p, exp)
}

fn value(f: &ObsFile, e: usize, sv: Sv, code: [u8; 2], kind: u8) -> (f64, u8) {
    let types = &f.header.obs_types[&sv.sys];
    let i = types
        .iter()
        .position(|t| *t == ObsCode([kind, code[0], code[1]]))
        .unwrap_or_else(|| panic!("{sv:?} {kind} {code:?} not in header"));
    let s = f.epochs[e].sats.iter().find(|s| s.sv == sv).unwrap();
    (s.get(i).value, s.get(i).lli)
}

fn check(f: &ObsFile, exp: &[Expect]) {
    assert_eq!(f.epochs.len(), 3);
    for (k, e) in f.epochs.iter().enumerate() {
        let t = gnss::raw::items::gpst(WEEK as u16, (TOW0_MS as f64 + 1000.0 * k as f64) / 1000.0);
        assert_eq!(e.time, t, "epoch {k}");
        assert_eq!(e.sats.len(), 6, "epoch {k}: all systems in one epoch");
    }
    for x in exp {
        let (pr, _) = value(f, x.epoch, x.sv, x.code, b'C');
        let (cp, lli) = value(f, x.epoch, x.sv, x.code, b'L');
        let (cno, _) = value(f, x.epoch, x.sv, x.code, b'S');
        let what = format!(
            "{:?} {} epoch {}",
            x.sv,
            String::from_utf8_lossy(&x.code),
            x.epoch
        );
        let (tpr, tcp, tcno) = if x.msm4 {
            (0.0095, 0.0025, 0.51)
        } else {
            (0.0009, 0.0015, 0.04)
        };
        assert!(
            (pr - x.sig.pr).abs() < tpr,
            "{what}: pr {pr} vs {}",
            x.sig.pr
        );
        assert!(
            (cp - x.sig.cp).abs() < tcp,
            "{what}: cp {cp} vs {}",
            x.sig.cp
        );
        assert!(
            (cno - x.sig.cno).abs() < tcno,
            "{what}: cno {cno} vs {}",
            x.sig.cno
        );
        assert_eq!(lli, x.lli, "{what}: lli");
        if !x.msm4 {
            let (d, _) = value(f, x.epoch, x.sv, x.code, b'D');
            assert!(
                (d - x.sig.doppler).abs() < 0.0015,
                "{what}: doppler {d} vs {}",
                x.sig.doppler
            );
        }
    }
}

#[test]
fn msm_round_trip_through_the_observation_seam_and_convert() {
    let (log, exp) = write_log("seam.rtcm3");
    let input = read_obs(&log, None, None).unwrap();
    assert_eq!(input.format, ObsFormat::Raw(RawFormat::Rtcm3));
    let st = input.raw.as_ref().unwrap();
    // The corrupted Galileo MSM, and the NMEA line whose checksum is wrong.
    assert_eq!(st.checksum_failures, 2, "{st}");
    assert_eq!(st.epochs, 3, "{st}");
    assert!(st.dropped.is_empty(), "{st}");
    let pos = st.station.arp.unwrap();
    for i in 0..3 {
        assert!((pos[i] - STATION[i]).abs() < 1e-6);
    }
    assert_eq!(input.obs.header.glonass_channels.get(&3), Some(&-4));
    check(&input.obs, &exp);

    let out = tmp("log.obs");
    let outs = Outputs {
        obs: &out,
        nav: None,
        events: None,
        nmea: None,
    };
    let st2 = convert(&log, None, None, outs).unwrap();
    assert_eq!(st2.epochs, 3);
    let f = ObsFile::read(&out).unwrap();
    check(&f, &exp);
}

#[test]
fn msm_without_a_week_is_refused_unless_a_date_is_given() {
    let sats = [sat(Constellation::Gps, 5, None, &[(2, b'1')], 0)];
    let p = tmp("noweek.rtcm3");
    std::fs::write(&p, msm(Constellation::Gps, 7, 1000, false, &sats)).unwrap();
    let rtcm = Some(ObsFormat::Raw(RawFormat::Rtcm3));
    let e = read_obs(&p, rtcm, None).unwrap_err().to_string();
    assert!(e.contains("1019") && e.contains("--date-hint"), "{e}");
    let e = read_obs(&p, rtcm, Some(TimeHint::Year(2024)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("a year alone"), "{e}");
    // Monday 2024-02-26 is in GPS week 2303: the epoch is its Sunday 00:00:01
    let ok = read_obs(&p, rtcm, Some(TimeHint::Date(2024, 2, 26))).unwrap();
    let t = ok.obs.epochs[0].time;
    assert_eq!(gnss::time::week_tow(t), (2303, 1.0));
    let st = ok.raw.unwrap();
    assert!(st.time_source.unwrap().contains("--date-hint 2024-02-26"));
}

#[test]
fn a_date_hint_contradicting_the_log_is_refused() {
    // A GPS-only log dates itself weakly (week modulo 1024): the hint wins, with a warning.
    let (log, _) = write_log("other.rtcm3");
    let weak = read_obs(&log, None, Some(TimeHint::Date(2020, 1, 1))).unwrap();
    let st = weak.raw.unwrap();
    assert!(
        st.warnings
            .iter()
            .any(|w| w.contains("--date-hint 2020-01-01 taken over")),
        "{st}"
    );
    assert_eq!(gnss::time::week_tow(weak.obs.epochs[0].time).0, 2086);
    // A Galileo ephemeris of the observations' time dates it strongly: the hint is refused,
    // naming both weeks.
    let mut bytes = std::fs::read(&log).unwrap();
    bytes.extend(week_1046(7, WEEK as u16, (TOW0_MS / 1000) as u32 - 1800));
    let strong = tmp("strong.rtcm3");
    std::fs::write(&strong, bytes).unwrap();
    let e = read_obs(&strong, None, Some(TimeHint::Date(2020, 1, 1)))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("contradicts") && e.contains("2086") && e.contains("2300"),
        "{e}"
    );
    // the log's own week agrees with a hint of its own day
    let day = gnss::time::from_week_tow(WEEK as u32, TOW0_MS as f64 / 1000.0);
    let (y, m, d, ..) = day.to_gregorian(hifitime::TimeScale::GPST);
    assert!(read_obs(&strong, None, Some(TimeHint::Date(y, m, d))).is_ok());
    assert!(read_obs(&log, None, Some(TimeHint::Date(y, m, d))).is_ok());
}
