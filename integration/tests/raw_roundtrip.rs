//! The simulator's rover and base also as u-blox UBX logs (`simulate --raw ubx`) and RTCM 3
//! logs (`--raw rtcm3`): read through the observation-source seam, they give the same
//! observations and camera events as the RINEX files, and PPK from the logs equals PPK from
//! RINEX to 1 mm. The RTCM logs carry the constellation's ephemerides (1019, 1046) and the
//! base station (1006): PPK on their own orbits and the base's announced position agrees too,
//! and the ephemerides survive encode → decode within 1 cm over a whole day. The SBF logs
//! (`--raw sbf`) carry the ephemerides (GPSNav, GALNav), the Klobuchar parameters and the
//! exposures (ExtEvent): every observation comes back as in the RINEX file and PPK on the
//! logs alone agrees to 1 mm.

use gnss::obs::{read_obs, ObsFormat};
use gnss::orbit::{Ephemerides, Orbits};
use gnss::ppk::PpkOptions;
use gnss::raw::rtcm_eph::decode_ephemeris;
use gnss::raw::rtcm_eph_write::ephemeris_frame;
use gnss::raw::RawFormat;
use gnss::rinex::nav::NavFile;
use integration::demo::SimInputs;
use integration::simulate;

use testkit::scratch_path as tmp;

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
    let rover = read_obs(&rover_ubx, None, None).unwrap();
    let base = read_obs(&base_ubx, None, None).unwrap();
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
    let rover = read_obs(&rover_rtcm, None, None).unwrap();
    let base = read_obs(&base_rtcm, None, None).unwrap();
    assert_eq!(rover.format, ObsFormat::Raw(RawFormat::Rtcm3));
    let st = rover.raw.as_ref().unwrap();
    assert_eq!((st.checksum_failures, st.dropped.len()), (0, 0), "{st}");
    assert_eq!(rover.obs.epochs.len(), rinex.rover.epochs.len());
    assert_eq!(base.obs.epochs.len(), rinex.base.epochs.len());

    // the base station: 1006 carries the ARP and antenna height; the marker comes back
    let (a, b) = (&base.obs.header, &rinex.base.header);
    let d = (a.approx_position.unwrap().0 - b.approx_position.unwrap().0).norm();
    assert!(d < 2e-4, "{d} m");
    assert!((a.antenna_delta.up - b.antenna_delta.up).abs() < 1e-4);
    // the logs' own ephemerides: every record of the navigation file
    let nav = NavFile::read(&rep.nav).unwrap();
    let mut own = rover.nav.clone().unwrap();
    assert_eq!(own.records.len(), nav.records.len());
    // RTCM 3 has no message for the Klobuchar parameters: those of the file
    own.gps_iono = nav.gps_iono;
    let from_rtcm = SimInputs {
        rover: rover.obs,
        base: base.obs,
        orbits: Orbits::broadcast(Ephemerides::from_nav(&[own])),
    };
    let (n, worst) = assert_same_ppk(&rep, &rinex, &from_rtcm);
    eprintln!("PPK from RTCM 3 (own ephemerides) vs RINEX: {n} epochs, worst {worst:.1e} m");
}

#[test]
fn ppk_from_sbf_logs_equals_ppk_from_rinex() {
    let rep = short_flight("flight-sbf");
    let (rover_sbf, base_sbf, dropped) = simulate::write_sbf(&rep).unwrap();
    assert_eq!(
        dropped, 0,
        "GPS L1/L2 and Galileo E1/E5a all have SBF signal numbers"
    );

    let rinex = SimInputs::read(&rep).unwrap();
    let rover = read_obs(&rover_sbf, None, None).unwrap();
    let base = read_obs(&base_sbf, None, None).unwrap();
    assert_eq!(rover.format, ObsFormat::Raw(RawFormat::Sbf));
    let st = rover.raw.as_ref().unwrap();
    assert_eq!((st.checksum_failures, st.dropped.len()), (0, 0), "{st}");
    assert!(st.unused.is_empty() && st.malformed.is_empty(), "{st}");
    assert_eq!(rover.obs.epochs.len(), rinex.rover.epochs.len());
    assert_eq!(base.obs.epochs.len(), rinex.base.epochs.len());
    // every pseudorange and phase as in the RINEX file, and the same loss-of-lock indicators
    let (mut n, mut worst_pr, mut worst_cp) = (0usize, 0.0f64, 0.0f64);
    for (a, b) in rover.obs.epochs.iter().zip(&rinex.rover.epochs) {
        assert_eq!(a.time, b.time);
        assert_eq!(a.sats.len(), b.sats.len());
        for (x, y) in a.sats.iter().zip(&b.sats) {
            assert_eq!(x.sv, y.sv);
            let (tx, ty) = (
                &rover.obs.header.obs_types[&x.sv.sys],
                &rinex.rover.header.obs_types[&y.sv.sys],
            );
            for (k, t) in ty.iter().enumerate() {
                let Some(j) = tx.iter().position(|u| u == t) else {
                    panic!("{t:?} missing")
                };
                let (u, v) = (x.get(j), y.get(k));
                match t.kind() {
                    b'C' => worst_pr = worst_pr.max((u.value - v.value).abs()),
                    b'L' => {
                        // whole cycles per arc aside
                        let d = u.value - v.value;
                        worst_cp = worst_cp.max((d - d.round()).abs());
                        assert_eq!(u.lli, v.lli, "{:?} {} {t:?}", a.time, x.sv);
                    }
                    _ => {}
                }
                n += 1;
            }
        }
    }
    assert!(
        worst_pr < 1e-9 && worst_cp < 1e-9,
        "{worst_pr} m, {worst_cp} cycles"
    );
    // Every exposure, at the same instant.
    let ev = |f: &gnss::rinex::ObsFile| f.exposure_events().map(|e| e.time).collect::<Vec<_>>();
    assert_eq!(ev(&rover.obs), ev(&rinex.rover));
    assert_eq!(ev(&rover.obs).len(), rep.exposures);
    // the logs' own ephemerides and Klobuchar parameters: every record of the navigation file
    let nav = NavFile::read(&rep.nav).unwrap();
    let own = rover.nav.clone().unwrap();
    assert_eq!(own.records.len(), nav.records.len());
    // SBF carries them as f4: within 10⁻⁷ relative of the file's decimal values
    let (k, kf) = (own.gps_iono.unwrap(), nav.gps_iono.unwrap());
    for (x, y) in k
        .alpha
        .iter()
        .chain(&k.beta)
        .zip(kf.alpha.iter().chain(&kf.beta))
    {
        assert!((x - y).abs() <= 1e-7 * y.abs(), "{x} vs {y}");
    }
    let from_sbf = SimInputs {
        rover: rover.obs,
        base: base.obs,
        orbits: Orbits::broadcast(Ephemerides::from_nav(&[own])),
    };
    let (epochs, worst) = assert_same_ppk(&rep, &rinex, &from_sbf);
    eprintln!(
        "SBF: {n} observations, worst pseudorange {worst_pr:.1e} m, phase {worst_cp:.1e} \
         cycles; PPK from SBF (own ephemerides) vs RINEX: {epochs} epochs, {} exposures, \
         worst {worst:.1e} m",
        rep.exposures
    );
}

/// The simulator's constellation over a day, each record through RTCM (1019 GPS, 1046
/// Galileo) and back: positions and clocks of every satellite every 5 min agree within 1 cm.
#[test]
fn simulator_ephemerides_survive_rtcm_within_1_cm_over_a_day() {
    let start = gnss::time::gpst(2024, 3, 5, 0, 0, 0, 0);
    let end = start + hifitime::Duration::from_seconds(86_400.0);
    let path = tmp("day.nav");
    std::fs::write(
        &path,
        simulate::constellation::navigation_text(start, end, 11),
    )
    .unwrap();
    let nav = NavFile::read(&path).unwrap();
    let mut decoded = nav.clone();
    for r in &mut decoded.records {
        let f = ephemeris_frame(r).unwrap();
        let now = (r.toc.to_gpst_seconds() * 1000.0) as i64;
        *r = decode_ephemeris(&f[3..f.len() - 3], Some(now), None).unwrap();
    }
    let (a, b) = (
        Ephemerides::from_nav(&[nav]),
        Ephemerides::from_nav(&[decoded]),
    );
    let (mut n, mut worst, mut worst_clock) = (0, 0.0f64, 0.0f64);
    let svs: Vec<_> = a.satellites().copied().collect();
    assert_eq!(svs.len(), 48);
    for sv in svs {
        for k in 0..=288 {
            let t = start + hifitime::Duration::from_seconds(300.0 * k as f64);
            let (Some(x), Some(y)) = (a.select(sv, t), b.select(sv, t)) else {
                panic!("{sv} at {t}: an ephemeris missing")
            };
            assert_eq!(x.toe(), y.toe());
            let (p, q) = (x.compute(t), y.compute(t));
            worst = worst.max((p.pos.0 - q.pos.0).norm());
            worst_clock = worst_clock.max((p.clock - q.clock).abs() * gnss::orbit::C);
            n += 1;
        }
    }
    eprintln!("{n} satellite positions: worst {worst:.1e} m, clock {worst_clock:.1e} m");
    assert!(
        worst < 0.01 && worst_clock < 0.01,
        "{worst} m, clock {worst_clock} m"
    );
}
