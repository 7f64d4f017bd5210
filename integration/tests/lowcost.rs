//! The low-cost bench (`simulate --builtin lowcost`): shaped after the real cases of issue 47,
//! its logs read back as the observations simulated, and PPK on it right and honest.

use gnss::obs::read_obs;
use gnss::rinex::ObsFile;
use gnss::sv::Constellation;
use integration::simulate::lowcost::{self, LowCostReport};
use std::path::PathBuf;
use std::sync::OnceLock;

/// The bench, simulated once for all tests of this file.
fn bench() -> &'static (PathBuf, LowCostReport) {
    static BENCH: OnceLock<(PathBuf, LowCostReport)> = OnceLock::new();
    BENCH.get_or_init(|| {
        let dir = testkit::scratch_path("lowcost");
        let _ = std::fs::remove_dir_all(&dir);
        let rep = lowcost::run(&dir, 47).expect("the bench runs");
        (dir, rep)
    })
}

/// The walk looks like the real M8P walk: C/N0 30/43/51 dB-Hz at p10/p50/p90, unresolved half
/// cycles on 8 % of GPS and 6 % of GLONASS phases, a base log of 763 epochs over 3,683 s.
#[test]
fn the_walk_is_shaped_after_the_real_one() {
    let (_, rep) = bench();
    let r = &rep.walk_rover;
    let (p10, p50, p90) = (
        r.cn0_percentile(10.0),
        r.cn0_percentile(50.0),
        r.cn0_percentile(90.0),
    );
    eprintln!("{rep}");
    assert!((28.0..=32.0).contains(&p10), "p10 {p10}");
    assert!((40.0..=45.0).contains(&p50), "p50 {p50}");
    assert!((49.0..=53.0).contains(&p90), "p90 {p90}");
    let (g, rr) = (
        r.half_share(Constellation::Gps),
        r.half_share(Constellation::Glonass),
    );
    assert!((0.05..=0.12).contains(&g), "GPS half cycles {g}");
    assert!((0.03..=0.09).contains(&rr), "GLONASS half cycles {rr}");
    assert!(r.reacquisitions > 100 && r.unflagged_slips > 0, "{r:?}");
    let b = &rep.walk_base;
    assert!((700..=850).contains(&b.epochs), "base epochs {}", b.epochs);
}

/// The rover's UBX log reads back as its RINEX (GLONASS with its channels, the half-cycle
/// flags); the base's mixed log gives its RTCM 1005 position and no checksum failure.
#[test]
fn the_walks_logs_read_back_as_simulated() {
    let (dir, rep) = bench();
    let walk = dir.join("walk");
    let rinex = ObsFile::read(&walk.join("rover_rinex.obs")).unwrap();
    let ubx = read_obs(&walk.join("rover.ubx"), None, None).unwrap();
    assert_eq!(ubx.obs.epochs.len(), rinex.epochs.len());
    // The log knows the channels of the satellites it tracked; the RINEX header lists all.
    let chans = &ubx.obs.header.glonass_channels;
    assert!(chans.len() >= 5, "{chans:?}");
    for (slot, ch) in chans {
        assert_eq!(
            rinex.header.glonass_channels.get(slot),
            Some(ch),
            "R{slot:02}"
        );
    }
    let (mut values, mut halves) = (0, 0);
    for (a, b) in ubx.obs.epochs.iter().zip(&rinex.epochs) {
        assert_eq!(a.time, b.time);
        assert_eq!(a.sats.len(), b.sats.len(), "{}", a.time);
        for (x, y) in a.sats.iter().zip(&b.sats) {
            assert_eq!(x.sv, y.sv);
            // L1 phase (column 1) and its loss-of-lock indicator, half-cycle bit included.
            let (l, m) = (x.get(1), y.get(1));
            assert_eq!(l.value.is_nan(), m.value.is_nan(), "{} {}", x.sv, a.time);
            if m.value.is_finite() {
                assert!((l.value - m.value).abs() < 2e-3, "{} {}", x.sv, a.time);
                assert_eq!(l.lli & 2, m.lli & 2, "{} {}", x.sv, a.time);
                values += 1;
                halves += usize::from(m.lli & 2 != 0);
            }
        }
    }
    assert!(values > 15_000 && halves > 900, "{values} {halves}");
    let base = read_obs(&walk.join("base.ubx"), None, None).unwrap();
    let st = base.raw.unwrap();
    assert_eq!(st.checksum_failures, 0, "{st}");
    assert_eq!(st.protocols.len(), 3, "{st}");
    assert_eq!(st.epochs as usize, rep.walk_base.epochs, "{st}");
    let p = base.obs.header.approx_position.unwrap();
    assert!((p.0 - rep.walk_base_position.0).norm() < 1e-3, "{p:?}");
}
