//! The simulator's rover and base also as u-blox UBX logs (`simulate --raw ubx`): read through
//! the observation-source seam, they give the same observations and camera events as the
//! RINEX files, and PPK from the logs equals PPK from RINEX to 1 mm.

use gnss::obs::{read_obs, ObsFormat};
use gnss::ppk::PpkOptions;
use gnss::raw::RawFormat;
use integration::demo::SimInputs;
use integration::simulate;
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("ppkat-rawrt-{}-{name}", std::process::id()))
}

/// The demo flight cut to one 1-km strip, simulated into `dir`.
fn short_flight(dir: &str) -> simulate::SimReport {
    let mut s = simulate::builtin("demo").unwrap();
    s.flight.strips = 1;
    s.flight.strip_length = 1000.0;
    simulate::run(&s, &tmp(dir)).unwrap()
}

/// PPK of `rinex` and of `from_log` (the same flight read from logs) agree: same epochs and
/// qualities, positions within 1 mm. Returns the epochs and the worst difference (m).
fn assert_same_ppk(
    rep: &simulate::SimReport,
    rinex: &SimInputs,
    from_log: &SimInputs,
) -> (usize, f64) {
    let opts = PpkOptions::default();
    let a = rinex.ppk(rep, &opts).unwrap();
    let b = from_log.ppk(rep, &opts).unwrap();
    let (ta, tb) = (&a.trajectory.epochs, &b.trajectory.epochs);
    assert_eq!(ta.len(), tb.len());
    let mut worst = 0.0f64;
    for (x, y) in ta.iter().zip(tb) {
        assert_eq!(x.time, y.time);
        assert_eq!(x.quality, y.quality, "{:?}", x.time);
        worst = worst.max((x.pos.0 - y.pos.0).norm());
    }
    assert!(worst <= 1e-3, "{worst} m");
    (ta.len(), worst)
}

#[test]
fn ppk_from_ubx_logs_equals_ppk_from_rinex() {
    let rep = short_flight("flight");
    let (rover_ubx, base_ubx, dropped) = simulate::write_ubx(&rep).unwrap();
    assert_eq!(
        dropped, 0,
        "GPS L1/L2 and Galileo E1/E5a all have u-blox signals"
    );

    let rinex = SimInputs::read(&rep).unwrap();
    let rover = read_obs(&rover_ubx, None).unwrap();
    let base = read_obs(&base_ubx, None).unwrap();
    assert_eq!(rover.format, ObsFormat::Raw(RawFormat::Ubx));
    let st = rover.raw.as_ref().unwrap();
    assert_eq!((st.checksum_failures, st.dropped.len()), (0, 0));
    assert_eq!(rover.obs.epochs.len(), rinex.rover.epochs.len());
    assert_eq!(base.obs.epochs.len(), rinex.base.epochs.len());
    // Every exposure, at the same instant.
    let ev = |f: &gnss::rinex::ObsFile| f.exposure_events().map(|e| e.time).collect::<Vec<_>>();
    assert_eq!(ev(&rover.obs), ev(&rinex.rover));
    assert_eq!(ev(&rover.obs).len(), rep.exposures);
    assert!(rep.exposures > 0);

    let from_ubx = SimInputs {
        rover: rover.obs,
        base: base.obs,
        orbits: rinex.orbits.clone(),
    };
    let (n, worst) = assert_same_ppk(&rep, &rinex, &from_ubx);
    eprintln!(
        "PPK from UBX vs RINEX: {n} epochs, {} exposures, worst {worst:.1e} m",
        rep.exposures
    );
}

#[test]
fn ppk_from_rtcm_logs_equals_ppk_from_rinex() {
    let rep = short_flight("flight-rtcm");
    let (rover_rtcm, base_rtcm, dropped) = simulate::write_rtcm(&rep).unwrap();
    assert_eq!(
        dropped, 0,
        "GPS L1/L2 and Galileo E1/E5a all have MSM signal ids"
    );

    let rinex = SimInputs::read(&rep).unwrap();
    let rover = read_obs(&rover_rtcm, None).unwrap();
    let base = read_obs(&base_rtcm, None).unwrap();
    assert_eq!(rover.format, ObsFormat::Raw(RawFormat::Rtcm3));
    let st = rover.raw.as_ref().unwrap();
    assert_eq!((st.checksum_failures, st.dropped.len()), (0, 0), "{st}");
    assert_eq!(rover.obs.epochs.len(), rinex.rover.epochs.len());
    assert_eq!(base.obs.epochs.len(), rinex.base.epochs.len());

    let from_rtcm = SimInputs {
        rover: rover.obs,
        base: base.obs,
        orbits: rinex.orbits.clone(),
    };
    let (n, worst) = assert_same_ppk(&rep, &rinex, &from_rtcm);
    eprintln!("PPK from RTCM 3 vs RINEX: {n} epochs, worst {worst:.1e} m");
}
