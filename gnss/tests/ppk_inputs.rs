//! The input habits of the carrier-phase engine on real data altered in memory: a base whose
//! Doppler has the wrong sign, base epochs holding only a system that is not processed, base
//! epochs missing for ten minutes, a base put 700 km away.

mod common;

use gnss::frame::Ecef;
use gnss::orbit::Ephemerides;
use gnss::ppk::{self, PpkOptions, PpkResult};
use gnss::rinex::ObsFile;
use gnss::solution::Quality;

/// Reverse the sign of every Doppler observation of a file, as some converters write it.
fn flip_doppler(f: &mut ObsFile) {
    let header = f.header.clone();
    for e in &mut f.epochs {
        for s in &mut e.sats {
            for (c, o) in header.types_of(s.sv.sys).iter().zip(&mut s.obs) {
                if c.kind() == b'D' {
                    o.value = -o.value;
                }
            }
        }
    }
}

/// The Doppler-over-phase ratio of a file, and the Doppler slips its arc breaks would hold
/// with the Doppler test on.
fn doppler_of(f: &ObsFile, opts: &PpkOptions, max_gap: f64) -> (f64, usize) {
    let plan = ppk::obs::SignalPlan::new(&f.header);
    let eph = Ephemerides::default();
    let meas: Vec<_> = f
        .epochs
        .iter()
        .map(|e| ppk::obs::extract(e, &f.header, &plan, &opts.systems, opts.nf, &eph))
        .collect();
    let times: Vec<_> = f.epochs.iter().map(|e| e.time).collect();
    let ratio = ppk::slip::doppler_phase_ratio(&times, &meas, max_gap).unwrap();
    let slips = ppk::slip::arc_breaks(&times, &meas, None, max_gap, true)
        .iter()
        .flat_map(|e| e.values().flatten().flatten())
        .filter(|c| **c == ppk::slip::SlipCause::Doppler)
        .count();
    (ratio.median, slips)
}

/// A base whose Doppler has the wrong sign: measured as −1, left out of the slip test with a
/// warning naming the file, and the solution is the original data's to the bit. With the
/// Doppler test on, the reversed Doppler would have cut thousands of arcs.
#[test]
fn reversed_base_doppler_is_ignored_for_slip_detection() {
    let sets = [
        (
            "gnss/cssrlib-2021-265",
            "SEPT265G.21O",
            "3034265G.21O",
            vec!["SEPT2650.21P"],
            Ecef::new(-3959400.631, 3385704.533, 3667523.111),
        ),
        (
            "gnss/spirent-rose-2023",
            "Rover-dynamic_MO_Spirent.obs",
            "Base-static_MO_Spirent.obs",
            vec!["RINEX_GN_Spirent.23N", "RINEX_EN_Spirent.23L"],
            Ecef::new(4157177.06580187, 671230.476590636, 4774767.03105544),
        ),
    ];
    let opts = PpkOptions::default();
    for (set, rover, base, navs, base_pos) in sets {
        let Some(dir) = common::data(set) else {
            return;
        };
        let r = ObsFile::read(&dir.join(rover)).unwrap();
        let b = ObsFile::read(&dir.join(base)).unwrap();
        let mut flipped = b.clone();
        flip_doppler(&mut flipped);
        // The slip test's gap at the base: 3 × the 30 s age limit.
        let (ratio, slips) = doppler_of(&b, &opts, 90.0);
        let (ratio_flipped, slips_flipped) = doppler_of(&flipped, &opts, 90.0);
        eprintln!("{set}: base Doppler/phase {ratio:.4} ({slips} Doppler slips), reversed {ratio_flipped:.4} ({slips_flipped})");
        assert!((ratio - 1.0).abs() < 0.01, "{set}: {ratio}");
        assert!((ratio_flipped + 1.0).abs() < 0.01, "{set}: {ratio_flipped}");
        assert!(slips_flipped > 1000, "{set}: {slips_flipped}");
        let want = common::ppk_on(&dir, &r, &b, &navs, base_pos, &opts);
        common::assert_inputs_clean(&want);
        let got = common::ppk_on(&dir, &r, &flipped, &navs, base_pos, &opts);
        let warned: Vec<&String> = got
            .warnings
            .iter()
            .filter(|w| w.contains("Doppler ignored for slip detection"))
            .collect();
        assert_eq!(warned.len(), 1, "{set}: {:?}", got.warnings);
        assert!(warned[0].starts_with("base ") && warned[0].contains(base));
        assert!(warned[0].contains("is -1.000"), "{}", warned[0]);
        assert_eq!(got.fixed(), want.fixed(), "{set}");
        let slips = |x: &PpkResult| x.forward.as_ref().map(|s| s.slips.clone());
        assert_eq!(slips(&got), slips(&want), "{set}");
        assert_eq!(got.trajectory.epochs.len(), want.trajectory.epochs.len());
        for (g, w) in got.trajectory.epochs.iter().zip(&want.trajectory.epochs) {
            assert_eq!((g.time, g.pos.0, g.quality), (w.time, w.pos.0, w.quality));
        }
    }
}

/// Fix rate (%), horizontal and vertical RMS and the worst fixed 3D error (m) of a static
/// rover against its truth.
struct Errors {
    fixed_pct: f64,
    h_rms: f64,
    v_rms: f64,
    max_fixed_err: f64,
}

fn errors(r: &PpkResult, truth: &Ecef) -> Errors {
    let e: Vec<_> = r
        .trajectory
        .epochs
        .iter()
        .map(|s| (s.pos.enu_from(truth), s.quality))
        .collect();
    let h: Vec<f64> = e.iter().map(|(d, _)| d.horizontal()).collect();
    let v: Vec<f64> = e.iter().map(|(d, _)| d.up()).collect();
    Errors {
        fixed_pct: 100.0 * r.fixed() as f64 / e.len().max(1) as f64,
        h_rms: common::rms(&h),
        v_rms: common::rms(&v),
        max_fixed_err: e
            .iter()
            .filter(|(_, q)| *q == Quality::Fixed)
            .map(|(d, _)| d.0.norm())
            .fold(0.0, f64::max),
    }
}

/// GEONET's base with every odd epoch holding GLONASS only (its GPS satellites relabelled),
/// processed GPS-only: each rover epoch pairs with a neighbouring GPS epoch 30 s away instead
/// of losing half the epochs, and the 60 skipped epochs are told with their span.
#[test]
fn base_epochs_of_other_systems_are_skipped_when_pairing() {
    let Some(dir) = common::data("gnss/geonet-2005") else {
        return;
    };
    let base_pos = Ecef::new(-3978241.958, 3382840.234, 3649900.853);
    let truth = Ecef::new(-3976219.1869, 3382371.6036, 3652511.1410);
    let r = ObsFile::read(&dir.join("07590920.05o")).unwrap();
    let mut b = ObsFile::read(&dir.join("30400920.05o")).unwrap();
    for e in b.epochs.iter_mut().skip(1).step_by(2) {
        for s in &mut e.sats {
            s.sv.sys = gnss::sv::Constellation::Glonass;
        }
    }
    // Both receivers' time tags drift by up to 5 ms: a neighbour lies up to 30.01 s away.
    let opts = PpkOptions {
        systems: vec![gnss::sv::Constellation::Gps],
        max_age: 31.0,
        ..PpkOptions::default()
    };
    let res = common::ppk_on(&dir, &r, &b, &["07590920.05n"], base_pos, &opts);
    let s = errors(&res, &truth);
    eprintln!(
        "GEONET, odd base epochs GLONASS only: {} solved of {}, fixed {:.1} %, H RMS {:.2} cm, V RMS {:.2} cm, worst fixed {:.2} cm; {:?}",
        res.trajectory.epochs.len(),
        res.rover_epochs,
        s.fixed_pct,
        s.h_rms * 100.0,
        s.v_rms * 100.0,
        s.max_fixed_err * 100.0,
        res.warnings
    );
    assert_eq!(res.trajectory.epochs.len(), 120, "{:?}", res.unsolved);
    assert!(res.trajectory.epochs.iter().all(|e| e.age.abs() <= 30.01));
    let skipped: Vec<&String> = res
        .warnings
        .iter()
        .filter(|w| w.contains("hold no carrier phase of the processed systems (G)"))
        .collect();
    assert_eq!(skipped.len(), 1, "{:?}", res.warnings);
    assert!(
        skipped[0].starts_with(
            "60 base epochs between 2005/04/02 00:00:30.000 and 2005/04/02 00:59:29.996 GPST"
        ),
        "{}",
        skipped[0]
    );
    // Half the epochs difference against a base 30 s old (measured: 100 % fixed, H RMS
    // 2.6 cm, V RMS 3.9 cm, worst fixed 12.2 cm, on such an epoch; with every base epoch
    // 0.5, 1.0 and 3.2 cm).
    assert_eq!(s.fixed_pct, 100.0);
    assert!(
        s.h_rms <= 0.04 && s.v_rms <= 0.05,
        "{} {}",
        s.h_rms,
        s.v_rms
    );
    assert!(s.max_fixed_err < 0.15, "worst fixed {}", s.max_fixed_err);
}

/// GEONET with ten minutes of base epochs removed: the rover epochs left without a base are
/// told with their span and count; the same run with the base put 700 km away is told that
/// the models are not meant for it.
#[test]
fn bad_inputs_are_warned_about() {
    let Some(dir) = common::data("gnss/geonet-2005") else {
        return;
    };
    let base_pos = Ecef::new(-3978241.958, 3382840.234, 3649900.853);
    let r = ObsFile::read(&dir.join("07590920.05o")).unwrap();
    let mut b = ObsFile::read(&dir.join("30400920.05o")).unwrap();
    let from = gnss::time::gpst(2005, 4, 2, 0, 20, 0, 0);
    b.epochs
        .retain(|e| !(0.0..600.0).contains(&(e.time - from).to_seconds()));
    let opts = PpkOptions::default();
    let res = common::ppk_on(&dir, &r, &b, &["07590920.05n"], base_pos, &opts);
    eprintln!(
        "GEONET without 00:20-00:30 at the base: {} solved; {:?}",
        res.trajectory.epochs.len(),
        res.warnings
    );
    // Rover epochs 00:20:30 … 00:29:30 are more than 30 s from a base epoch.
    assert_eq!(res.trajectory.epochs.len(), 120 - 19);
    let lonely: Vec<&String> = res
        .warnings
        .iter()
        .filter(|w| w.contains("no satellite in common"))
        .collect();
    assert_eq!(lonely.len(), 1, "{:?}", res.warnings);
    assert!(
        lonely[0].starts_with("19 rover epochs from 2005/04/02 00:20:30.00")
            && lonely[0].contains(" to 2005/04/02 00:29:30.00"),
        "{}",
        lonely[0]
    );
    // 700 km east of the true base, in the local horizon.
    let east = gnss::frame::enu_rotation(&base_pos.to_geodetic()).transpose()
        * nalgebra::Vector3::new(700_000.0, 0.0, 0.0);
    let far = Ecef(base_pos.0 + east);
    let b = ObsFile::read(&dir.join("30400920.05o")).unwrap();
    let res = common::ppk_on(&dir, &r, &b, &["07590920.05n"], far, &opts);
    let km = res.models.longest_baseline / 1000.0;
    assert!((699.0..703.0).contains(&km), "{km}");
    let long: Vec<&String> = res
        .warnings
        .iter()
        .filter(|w| w.contains("not meant for baselines beyond 500 km"))
        .collect();
    assert_eq!(long.len(), 1, "{:?}", res.warnings);
    assert!(
        long[0].starts_with(&format!("the longest baseline is {km:.0} km")),
        "{}",
        long[0]
    );
}

/// A real single-frequency u-blox log (GPS L1 C/A + Galileo E1, cold start) against itself:
/// a zero baseline. The cold start's wild code solutions (tens of km off, where the log has
/// no phase) must not switch on the long-baseline models, and every fixed epoch is the base.
#[test]
fn ublox_l1_zero_baseline_from_a_cold_start() {
    let Some(dir) = common::data("gnss/ubx-navsol-2025") else {
        return;
    };
    let obs = ObsFile::read(&dir.join("16dBatt_no_interference_coldstart.obs.gz")).unwrap();
    let base = Ecef::new(4313748.470, 452890.220, 4661040.216);
    let r = common::ppk_on(
        &dir,
        &obs,
        &obs,
        &["16dBatt_no_interference_coldstart.nav.gz"],
        base,
        &PpkOptions::default(),
    );
    eprintln!(
        "u-blox zero baseline: {} of {} solved, {} fixed, models {:?}",
        r.trajectory.epochs.len(),
        r.rover_epochs,
        r.fixed(),
        r.models
    );
    assert!(!r.models.iono && !r.models.tropo, "{:?}", r.models);
    assert!(r.models.longest_baseline < 10_000.0);
    assert!(
        r.trajectory.epochs.len() >= 1100,
        "{}",
        r.trajectory.epochs.len()
    );
    for e in &r.trajectory.epochs {
        assert!((e.pos.0 - base.0).norm() < 0.005, "{:?}", e.time);
    }
}
