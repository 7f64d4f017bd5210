//! The simulator against its own acceptance: consistency with our models, a PPK round trip
//! on a 20-minute 10 Hz flight, determinism, and clear errors for bad scenarios.

use gnss::frame::Ecef;
use gnss::orbit::{Ephemerides, Orbits, C};
use gnss::ppk::PpkOptions;
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use gnss::solution::Quality;
use integration::demo::{read_truth, truth_at, SimInputs};
use integration::simulate::{self, ErrorModel, Scenario, SimError};

use testkit::scratch_path as tmp;

const OMEGA_E: f64 = 7.292_115_146_7e-5;

/// With every error off, the geometric range (satellite at transmission time from the
/// pseudorange, Earth rotation) minus the satellite clock reproduces each pseudorange, and the
/// phase equals the pseudorange, to 1 mm.
#[test]
fn observations_match_the_models_with_errors_off() {
    let mut s = simulate::builtin("demo").unwrap();
    s.errors = ErrorModel::none();
    s.flight.strips = 1;
    s.flight.strip_length = 1000.0;
    let dir = tmp("consistency");
    let rep = simulate::run(&s, &dir).unwrap();
    let rover = ObsFile::read(&rep.rover).unwrap();
    let truth = read_truth(&dir.join("truth_trajectory.csv")).unwrap();
    let orbits = Orbits::broadcast(Ephemerides::from_nav(&[NavFile::read(&rep.nav).unwrap()]));
    let mut worst_p: f64 = 0.0;
    let mut worst_l: f64 = 0.0;
    let mut n = 0;
    for e in rover.epochs.iter().step_by(7) {
        let rx = truth_at(&truth, e.time.to_gpst_seconds())
            .or_else(|| truth.last().map(|t| t.pos))
            .unwrap();
        for sat in &e.sats {
            let p = sat.get(0).value;
            let t0 = e.time - hifitime::Duration::from_seconds(p / C);
            let first = orbits.sat(sat.sv, t0, b'1').unwrap();
            let s2 = orbits
                .sat(
                    sat.sv,
                    t0 - hifitime::Duration::from_seconds(first.clock),
                    b'1',
                )
                .unwrap();
            let tau = (s2.pos.0 - rx).norm() / C;
            let (sn, cs) = (OMEGA_E * tau).sin_cos();
            let sp = nalgebra::Vector3::new(
                cs * s2.pos.0.x + sn * s2.pos.0.y,
                -sn * s2.pos.0.x + cs * s2.pos.0.y,
                s2.pos.0.z,
            );
            let model = (sp - rx).norm() - C * s2.clock;
            worst_p = worst_p.max((p - model).abs());
            let lam = C / 1575.42e6;
            worst_l = worst_l.max((sat.get(1).value * lam - p).abs());
            n += 1;
        }
    }
    eprintln!(
        "{n} observations: worst code misfit {:.3} mm, worst phase−code {:.3} mm",
        worst_p * 1e3,
        worst_l * 1e3
    );
    assert!(n > 1000);
    assert!(worst_p < 1e-3, "code misfit {worst_p}");
    assert!(worst_l < 1e-3, "phase misfit {worst_l}");
}

/// A 20-minute 10 Hz flight with the default errors: PPK fixes ≥ 99 % and stays within 2 cm
/// 3D RMS of the truth; single point stays at its metre level.
#[test]
fn ppk_round_trip_on_a_20_minute_flight() {
    let s = simulate::builtin("block20").unwrap();
    let dir = tmp("roundtrip");
    let rep = simulate::run(&s, &dir).unwrap();
    assert!(rep.duration_s >= 1200.0, "{} s", rep.duration_s);
    let truth = read_truth(&dir.join("truth_trajectory.csv")).unwrap();
    let inputs = SimInputs::read(&rep).unwrap();
    let (rover, orbits) = (&inputs.rover, &inputs.orbits);
    let r = inputs.ppk(&rep, &PpkOptions::default()).unwrap();
    let mut d = Vec::new();
    for s in r
        .trajectory
        .epochs
        .iter()
        .filter(|s| s.quality == Quality::Fixed)
    {
        let t = truth_at(&truth, s.time.to_gpst_seconds()).unwrap();
        d.push((s.pos.0 - t).norm_squared());
    }
    let rms = (d.iter().sum::<f64>() / d.len() as f64).sqrt();
    let fixed = r.fixed() as f64 / r.rover_epochs as f64;
    eprintln!(
        "round trip: {} epochs, {} solved, {:.2} % fixed, 3D RMS {:.1} mm",
        r.rover_epochs,
        r.trajectory.epochs.len(),
        100.0 * fixed,
        rms * 1e3
    );
    assert!(fixed >= 0.99, "fixed {fixed}");
    assert!(rms <= 0.02, "3D RMS {rms}");
    // No slips are simulated: the geometry-free test must not invent them at 10 Hz (a rate
    // extrapolated from epochs 0.1 s apart once reset hundreds of ambiguities per pass).
    let gf = r
        .forward
        .as_ref()
        .and_then(|s| s.slips.get(&gnss::ppk::slip::SlipCause::GeometryFree))
        .copied()
        .unwrap_or(0);
    eprintln!("geometry-free resets (forward): {gf}");
    assert!(gf <= 10, "false geometry-free slips: {gf}");
    let spp = gnss::spp::run(&rover.epochs, &rover.header, orbits, &Default::default());
    let mut h = Vec::new();
    for s in &spp.solutions {
        let clock = s.clocks.values().next().copied().unwrap_or(0.0) / C;
        let t = truth_at(&truth, s.time.to_gpst_seconds() - clock).unwrap();
        h.push(s.pos.enu_from(&Ecef(t)).0.norm_squared());
    }
    let spp3d = (h.iter().sum::<f64>() / h.len() as f64).sqrt();
    eprintln!("single point 3D RMS {spp3d:.2} m");
    assert!(
        spp3d > 0.1 && spp3d < 3.0,
        "SPP at the metre level: {spp3d}"
    );
}

#[test]
fn same_seed_same_bytes() {
    let mut s = simulate::builtin("demo").unwrap();
    s.flight.strips = 1;
    s.flight.strip_length = 800.0;
    let (a, b) = (tmp("det-a"), tmp("det-b"));
    simulate::run(&s, &a).unwrap();
    simulate::run(&s, &b).unwrap();
    for f in [
        "rover.obs",
        "base.obs",
        "nav.rnx",
        "truth_trajectory.csv",
        "truth_exposures.csv",
        "image_observations.csv",
        "ground_points.csv",
    ] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
    // Exposure events are in the rover file, one per exposure.
    let rover = ObsFile::read(&a.join("rover.obs")).unwrap();
    let exposures = std::fs::read_to_string(a.join("truth_exposures.csv"))
        .unwrap()
        .lines()
        .filter(|l| l.chars().next().is_some_and(|c| c.is_ascii_digit()))
        .count();
    assert_eq!(rover.exposure_events().count(), exposures);
}

fn scenario_with(edit: impl Fn(&mut String)) -> Result<Scenario, SimError> {
    let mut text = include_str!("../../fixtures/scenario_small.toml").to_string();
    edit(&mut text);
    Scenario::from_toml(&text)
}

#[test]
fn bad_scenarios_name_the_key() {
    assert!(scenario_with(|_| {}).is_ok());
    let e = scenario_with(|t| *t = t.replace("[flight]", "[flight]\nsped = 50.0"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("sped"), "{e}");
    let e = scenario_with(|t| *t = t.replace("speed = 55.0", "speed = -5.0"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("flight.speed"), "{e}");
    let e = scenario_with(|t| *t = t.replace("2024-06-12T09:00:00", "1975-01-01T00:00:00"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("start") && e.contains("outside the ephemeris set"),
        "{e}"
    );
    let blind =
        scenario_with(|t| *t = t.replace("focal_mm = 35.0", "focal_mm = 1000000.0")).unwrap();
    let e = simulate::run(&blind, &tmp("blind"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("camera") && e.contains("no ground point"), "{e}");
}

/// Injected cycle slips and data gaps are found (each injected slip sets the loss-of-lock
/// flag), the fixed solution stays at centimetres, and every fixed epoch's error lies within
/// four of its own reported sigmas.
#[test]
fn injected_slips_and_gaps_are_survived() {
    let mut s = simulate::builtin("demo").unwrap();
    s.errors.cycle_slips = 40;
    s.errors.gaps = 6;
    let dir = tmp("slips");
    let rep = simulate::run(&s, &dir).unwrap();
    assert!(rep.rover_stats.slips > 0 && rep.rover_stats.gap_records > 0);
    let truth = read_truth(&dir.join("truth_trajectory.csv")).unwrap();
    let inputs = SimInputs::read(&rep).unwrap();
    let r = inputs.ppk(&rep, &PpkOptions::default()).unwrap();
    let fw = r.forward.as_ref().unwrap();
    let lli = fw
        .slips
        .get(&gnss::ppk::slip::SlipCause::LossOfLock)
        .copied()
        .unwrap_or(0);
    // Errors against truth, and normalised by the solution's own 3D sigma: a weak-geometry
    // epoch (a satellite in a gap) may be off by several centimetres, but must say so.
    let errs: Vec<(f64, f64)> = r
        .trajectory
        .epochs
        .iter()
        .filter(|s| s.quality == Quality::Fixed)
        .map(|s| {
            let e = (s.pos.0 - truth_at(&truth, s.time.to_gpst_seconds()).unwrap()).norm();
            (e, e / s.cov.trace().sqrt())
        })
        .collect();
    let rms = (errs.iter().map(|e| e.0 * e.0).sum::<f64>() / errs.len() as f64).sqrt();
    let worst = errs.iter().map(|e| e.1).fold(0.0, f64::max);
    eprintln!("{} slips and {} gap records injected; resets {:?}; {} of {} fixed; 3D RMS {:.1} mm; worst error/sigma {:.2}", rep.rover_stats.slips, rep.rover_stats.gap_records, fw.slips, r.fixed(), r.rover_epochs, rms * 1e3, worst);
    assert!(lli >= 1, "loss-of-lock resets {:?}", fw.slips);
    assert!(r.fixed() as f64 >= 0.97 * r.rover_epochs as f64);
    assert!(rms <= 0.02, "3D RMS {rms}");
    assert!(worst < 4.0, "an error beyond 4 sigma: {worst}");
}
