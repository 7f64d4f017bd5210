//! Flag-5 external events (camera exposures) are recovered with their exact times from
//! hand-made RINEX 2.11 and 3.04 files, and the observation epochs around them stay intact.

use gnss::rinex::ObsFile;
use gnss::sv::{Constellation, Sv};
use gnss::time::gpst;
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures")
        .join(name)
}

fn check(name: &str) {
    let f = ObsFile::read(&fixture(name)).unwrap();
    assert!(f.warnings.is_empty(), "{name}: {:?}", f.warnings);
    let ev: Vec<_> = f.exposure_events().collect();
    let want = [
        gpst(2024, 3, 10, 12, 0, 0, 250_000_000),
        gpst(2024, 3, 10, 12, 0, 0, 751_234_500),
        gpst(2024, 3, 10, 12, 0, 1, 333_333_300),
    ];
    assert_eq!(ev.len(), 3, "{name}");
    for (e, w) in ev.iter().zip(want) {
        assert_eq!(
            e.time,
            Some(w),
            "{name}: event time exact to the nanosecond"
        );
    }
    // Two events within one second, one followed by its special record.
    assert_eq!(ev[1].records.len(), 1);
    assert!(ev[1].records[0].starts_with("EXPOSURE 0002"));
    // The flag-4 record (header lines) is kept as an event of its own, not as data.
    let other: Vec<_> = f.events.iter().filter(|e| e.flag == 4).collect();
    assert_eq!(other.len(), 1);
    assert_eq!(other[0].records.len(), 2);
    // Observation epochs intact: times, satellites, values.
    assert_eq!(f.epochs.len(), 3);
    for (k, e) in f.epochs.iter().enumerate() {
        assert_eq!(e.time, gpst(2024, 3, 10, 12, 0, k as u8, 0));
        assert_eq!(e.sats.len(), 2);
        let g05 = &e.sats[0];
        assert_eq!(g05.sv, Sv::new(Constellation::Gps, 5));
        assert!((g05.get(0).value - (21000000.123 + 100.0 * k as f64)).abs() < 1e-6);
        assert!((g05.get(3).value - (85991234.567 + 100.0 * k as f64)).abs() < 1e-6);
        assert_eq!(g05.get(0).ssi, 7);
    }
}

#[test]
fn rinex_304_events() {
    check("events_v304.rnx");
}

#[test]
fn rinex_211_events() {
    check("events_v211.rnx");
    let f = ObsFile::read(&fixture("events_v211.rnx")).unwrap();
    // The loss-of-lock indicator of G09 L1 survives.
    assert_eq!(f.epochs[0].sats[1].get(1).lli, 1);
}

/// A hand-made CRINEX 1 file of the same data (written to the format of Hatanaka 2008:
/// `&` initialises an epoch line, `n&value` a difference of order n, event epochs and their
/// special records pass uncompressed), plus one more epoch sent as a text difference.
#[test]
fn crinex_1_events_and_differences() {
    let f = ObsFile::read(&fixture("events_v211.crx")).unwrap();
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    assert_eq!(f.header.crinex, Some(1.0));
    let plain = ObsFile::read(&fixture("events_v211.rnx")).unwrap();
    let times = |o: &ObsFile| {
        o.events
            .iter()
            .map(|e| (e.flag, e.time))
            .collect::<Vec<_>>()
    };
    assert_eq!(times(&f), times(&plain));
    assert_eq!(f.epochs.len(), 4);
    for (k, e) in f.epochs.iter().enumerate() {
        assert_eq!(e.time, gpst(2024, 3, 10, 12, 0, k as u8, 0));
        if let Some(p) = plain.epochs.get(k) {
            for (a, b) in e.sats.iter().zip(&p.sats) {
                assert_eq!(a.sv, b.sv);
                assert_eq!(a.obs, b.obs, "epoch {k} {}", a.sv);
            }
        }
    }
    // The fourth epoch continues the linear trend through second and third differences.
    assert!((f.epochs[3].sats[1].get(3).value - (90086963.0 + 300.0)).abs() < 1e-6);
    assert_eq!(f.epochs[3].sats[1].get(1).lli, 1);
}
