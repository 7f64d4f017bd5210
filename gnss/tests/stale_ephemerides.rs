//! Stale broadcast ephemerides (issue 49): merged daily navigation files keep the sets of an
//! older upload beside the fresh ones, with almost the same toe; the selection must take the
//! fresh upload's (the later transmitted) and say how many it passed over.

mod common;

use gnss::orbit::{supersedes, Eph, Ephemerides};
use gnss::rinex::nav::{NavFile, NavKind, NavRecord};
use gnss::sv::{Constellation, Sv};
use hifitime::Epoch;
use std::path::PathBuf;

/// A GPS record of G01 (2020-06-25 elements) with its toc/toe at `toe` (GPST), the
/// transmission time `sent` (GPST) and the issue of data `iode`.
fn record(toe: Epoch, sent: Epoch, iode: f64) -> NavRecord {
    let sow = |t: Epoch| gnss::time::week_tow(t).1;
    let mut orbit = vec![0.0; 28];
    orbit[..17].copy_from_slice(&[
        iode, -52.0, 4.3e-9, 1.2, -2.7e-6, 0.0089, 8.1e-6, 5153.7, 0.0, 1.1e-7, -1.3, -5.6e-8,
        0.97, 220.0, 0.81, -8.0e-9, 1.0e-10,
    ]);
    orbit[8] = sow(toe);
    orbit[24] = sow(sent);
    orbit[25] = 4.0;
    NavRecord {
        sv: Sv::new(Constellation::Gps, 1),
        kind: NavKind::Kepler,
        toc: toe,
        clock: [-1.7e-4, -1.1e-11, 0.0],
        orbit,
        line: 1,
    }
}

/// The ephemerides of `records`, as read from one navigation file.
fn index(records: Vec<NavRecord>) -> Ephemerides {
    let nav = NavFile {
        path: PathBuf::from("test.nav"),
        records,
        ..NavFile::default()
    };
    Ephemerides::from_nav(&[nav])
}

fn iode(e: &Eph) -> f64 {
    match e {
        Eph::Kepler(k) => k.iode,
        Eph::Glonass(_) => f64::NAN,
    }
}

fn at(h: u8, m: u8, s: u8) -> Epoch {
    gnss::time::gpst(2020, 6, 25, h, m, s, 0)
}

#[test]
fn a_fresh_upload_wins_over_the_stale_set_with_the_nearer_toe() {
    // The pattern of BELL–EBRE's PRN 15: the old upload's sets at 12:00 and 14:00 (sent two
    // hours before their toe), the new upload's first set at 13:59:44 (sent at 12:05), its
    // next at 16:00.
    let stale12 = record(at(12, 0, 0), at(10, 0, 0), 178.0);
    let stale14 = record(at(14, 0, 0), at(12, 0, 0), 179.0);
    let fresh = record(at(13, 59, 44), at(12, 5, 0), 201.0);
    let next = record(at(16, 0, 0), at(14, 23, 0), 202.0);
    let e = index(vec![stale12, stale14, fresh, next]);
    let sv = Sv::new(Constellation::Gps, 1);
    let pick = |t: Epoch| iode(e.select(sv, t).expect("an ephemeris"));
    // Before the new upload's sets are valid, the old one is all there is.
    assert_eq!(pick(at(11, 0, 0)), 178.0);
    // From 11:59:44 the new upload's first set supersedes every set sent before it; the
    // nearest toe (14:00:00, 16 s nearer at 14:30) would be the stale one.
    assert_eq!(pick(at(12, 30, 0)), 201.0);
    assert_eq!(pick(at(14, 30, 0)), 201.0);
    // Within the new upload, the nearest toe as usual.
    assert_eq!(pick(at(15, 30, 0)), 202.0);
    // The two stale sets are passed over at their own toe, and counted.
    assert_eq!(e.stats.superseded, 2);
    let all = e.of(sv);
    assert!(
        supersedes(&all[1], &all[2]),
        "13:59:44 set over the 14:00 one"
    );
    assert!(!supersedes(&all[2], &all[1]));
    assert!(
        !supersedes(&all[3], &all[1]),
        "a later set of the same upload"
    );
}

#[test]
fn without_transmission_times_the_nearest_toe_is_kept() {
    // RINEX writes 0.9999E9 when the transmission time is unknown: no set can be told
    // fresher, and the selection is the nearest toe.
    let mut a = record(at(14, 0, 0), at(12, 0, 0), 179.0);
    let mut b = record(at(13, 59, 44), at(12, 5, 0), 201.0);
    a.orbit[24] = 0.9999e9;
    b.orbit[24] = 0.9999e9;
    let e = index(vec![a, b]);
    let sv = Sv::new(Constellation::Gps, 1);
    assert_eq!(iode(e.select(sv, at(14, 30, 0)).unwrap()), 179.0);
    assert_eq!(iode(e.select(sv, at(13, 30, 0)).unwrap()), 201.0);
    assert_eq!(e.stats.superseded, 0);
}

#[test]
fn bell_ebre_day_uses_the_fresh_uploads() {
    let Some(dir) = common::data("gnss/bell-ebre-2002-030") else {
        return;
    };
    let nav = NavFile::read(&dir.join("brdc0300.02n")).unwrap();
    let e = Ephemerides::from_nav(&[nav]);
    let t = |h: u8, m: u8| gnss::time::gpst(2002, 1, 30, h, m, 0, 0);
    let g = |prn: u8| Sv::new(Constellation::Gps, prn);
    // PRN 15: the 13:59:44 set (IODE 201, sent 12:05) over the day-old 14:00 set (IODE 179):
    // 8.6 m apart at 14:30. PRN 24: the 15:59:44 set (IODE 76) over the 16:00 one (IODE 51),
    // and not its own upload's next set (17:59:44, IODE 77) either.
    // PRN 21: the 22:00 upload (IODE 185) over the 23:00 set of the old one (IODE 162).
    for (sv, when, want) in [
        (g(15), t(14, 30), 201.0),
        (g(15), t(2, 30), 174.0),
        (g(24), t(16, 30), 76.0),
        (g(21), t(23, 30), 185.0),
    ] {
        let got = iode(e.select(sv, when).unwrap());
        assert_eq!(got, want, "{sv} at {}", gnss::time::format_ymdhms(when));
    }
    let stale = e.select(g(15), t(14, 30)).unwrap();
    let old = e
        .of(g(15))
        .iter()
        .find(|x| iode(x) == 179.0)
        .expect("the stale set");
    let d = (stale.compute(t(14, 30)).pos.0 - old.compute(t(14, 30)).pos.0).norm();
    assert!((8.0..9.5).contains(&d), "PRN 15 stale set {d} m away");
    // Measured: 69 of the 369 records are an older upload's, passed over.
    assert!(
        (65..=75).contains(&e.stats.superseded),
        "{}",
        e.stats.superseded
    );
}

#[test]
fn transmission_times_in_the_week_before_toe_count_as_earlier() {
    // Toe at the start of a GPS week (Sunday 2020-06-28 00:00): the fresh set was sent an
    // hour before, written as −3600 s of toe's week (RINEX allows it) or as 601,200 s of the
    // week before; the stale 01:00 set of the older upload was sent at −5400 s.
    let week_start = gnss::time::gpst(2020, 6, 28, 0, 0, 0, 0);
    let h = |x: f64| week_start + hifitime::Duration::from_seconds(x * 3600.0);
    for fresh_sent in [-3600.0, 601_200.0] {
        let mut fresh = record(h(0.0), h(-1.0), 10.0);
        fresh.orbit[24] = fresh_sent;
        let mut stale = record(h(1.0), h(-1.5), 138.0);
        stale.orbit[24] = -5400.0;
        let e = index(vec![stale, fresh]);
        let sv = Sv::new(Constellation::Gps, 1);
        assert_eq!(iode(e.select(sv, h(0.75)).unwrap()), 10.0, "{fresh_sent}");
        assert_eq!(e.stats.superseded, 1, "{fresh_sent}");
    }
}
