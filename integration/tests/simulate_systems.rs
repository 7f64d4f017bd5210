//! The simulator's GLONASS-like and QZSS-like constellations: GLONASS records that are samples
//! of one trajectory (a record switch moves a satellite by less than a centimetre), QZSS
//! orbits where they belong, and a G+R+J flight over Japan that single-point positioning and
//! PPK solve against the truth.

use gnss::orbit::{Ephemerides, C};
use gnss::ppk::PpkOptions;
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use gnss::solution::Quality;
use gnss::sv::{Constellation, Sv};
use integration::demo::SimInputs;
use integration::simulate::{self, constellation, Scenario};
use nalgebra::Vector3;
use testkit::scratch_path as tmp;

/// PZ-90 Earth rotation rate (GLONASS ICD), rad/s.
const OMEGA_GLO: f64 = 7.292_115e-5;

/// A day of the synthetic constellation of `systems`, read back: the ephemerides.
fn day_of(systems: &[Constellation], name: &str) -> (hifitime::Epoch, Ephemerides) {
    let start = gnss::time::gpst(2024, 3, 5, 0, 0, 0, 0);
    let end = start + hifitime::Duration::from_seconds(86_400.0);
    let path = tmp(name);
    std::fs::write(
        &path,
        constellation::navigation_text_of(start, end, 11, systems),
    )
    .unwrap();
    let nav = NavFile::read(&path).unwrap();
    let eph = Ephemerides::from_nav(&[nav]);
    assert!(eph.stats.skipped.is_empty(), "{:?}", eph.stats.skipped);
    assert_eq!(eph.stats.unhealthy, 0);
    (start, eph)
}

/// Over a day, every GLONASS record hands over to the next at the mid-point (where ppkat
/// switches) with the satellite moved by less than 1 cm and its clock by less than 1 ps;
/// records sit on the UTC half-hours (GPST − UTC = 18 s in 2024); the orbits and channels are
/// those of the real constellation's design.
#[test]
fn glonass_record_switch_moves_satellites_by_less_than_1_cm() {
    let (start, eph) = day_of(&[Constellation::Glonass], "glonass_day.nav");
    let svs: Vec<Sv> = eph.satellites().copied().collect();
    assert_eq!(svs.len(), 24);
    let (mut worst, mut worst_vel, mut worst_clock, mut switches) = (0.0f64, 0.0f64, 0.0f64, 0);
    for &sv in &svs {
        let recs = eph.of(sv);
        assert!(recs.len() >= 2 * 24 + 8, "{sv}: {} records", recs.len());
        for pair in recs.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            assert_eq!((b.toe() - a.toe()).to_seconds(), 1800.0, "{sv}");
            // UTC half-hours: 18 s past the GPST half-hour.
            assert_eq!(b.toe().to_gpst_seconds().rem_euclid(1800.0), 18.0, "{sv}");
            let mid = a.toe() + hifitime::Duration::from_seconds(900.0);
            let before = mid - hifitime::Duration::from_seconds(0.001);
            let after = mid + hifitime::Duration::from_seconds(0.001);
            assert_eq!(eph.select(sv, before).unwrap().toe(), a.toe());
            assert_eq!(eph.select(sv, after).unwrap().toe(), b.toe());
            let (x, y) = (a.compute(mid), b.compute(mid));
            worst = worst.max((x.pos.0 - y.pos.0).norm());
            worst_vel = worst_vel.max((x.vel - y.vel).norm());
            worst_clock = worst_clock.max((x.clock - y.clock).abs());
            switches += 1;
        }
    }
    eprintln!(
        "GLONASS: {switches} record switches over a day: worst jump {:.3} mm, {:.2e} m/s, clock {:.2e} s",
        worst * 1e3,
        worst_vel,
        worst_clock
    );
    assert!(switches > 24 * 48);
    assert!(
        worst < 0.01,
        "a record switch moves a satellite by {worst} m"
    );
    assert!(worst_vel < 1e-5, "velocity jump {worst_vel} m/s");
    assert!(worst_clock < 1e-12, "clock jump {worst_clock} s");
    glonass_design_holds(&eph, start);
}

/// Radius 25 510 ± 60 km, inclination 64.8 ± 0.5°, channels within −7…6 with each used by
/// exactly two satellites, 180° apart in one plane.
fn glonass_design_holds(eph: &Ephemerides, start: hifitime::Epoch) {
    let t = start + hifitime::Duration::from_seconds(3600.0);
    let mut by_channel: std::collections::BTreeMap<i8, Vec<Vector3<f64>>> = Default::default();
    for slot in 1..=24u8 {
        let sv = Sv::new(Constellation::Glonass, slot);
        let s = eph.select(sv, t).unwrap().compute(t);
        let r = s.pos.0;
        let v_inertial = s.vel + Vector3::new(0.0, 0.0, OMEGA_GLO).cross(&r);
        let h = r.cross(&v_inertial);
        let inc = (h.z / h.norm()).acos().to_degrees();
        assert!((r.norm() - 25_510e3).abs() < 60e3, "{sv}: r = {}", r.norm());
        assert!((inc - 64.8).abs() < 0.5, "{sv}: i = {inc}");
        let ch = eph.glonass_channel(slot).unwrap();
        assert!((-7..=6).contains(&ch), "{sv}: channel {ch}");
        by_channel.entry(ch).or_default().push(r);
    }
    for (ch, rs) in by_channel {
        assert_eq!(rs.len(), 2, "channel {ch}");
        let cos = rs[0].dot(&rs[1]) / (rs[0].norm() * rs[1].norm());
        assert!(
            cos < -0.99,
            "channel {ch}: the pair is not antipodal ({cos})"
        );
    }
}

/// The QZSS-like satellites over a day: three quasi-zenith ones reaching 41° N and 41° S on a
/// figure-eight centred on 135° E, the geostationary one at 127° E within 0.1°; hourly
/// records handing over by centimetres (their values lie on the LNAV grid).
#[test]
fn qzss_orbits_lie_over_japan() {
    let (start, eph) = day_of(&[Constellation::Qzss], "qzss_day.nav");
    let svs: Vec<Sv> = eph.satellites().copied().collect();
    assert_eq!(svs.iter().map(|s| s.prn).collect::<Vec<_>>(), [2, 3, 4, 7]);
    let mut worst_jump = 0.0f64;
    for &sv in &svs {
        let (mut lat_min, mut lat_max, mut lon_sum, mut n) = (90.0f64, -90.0f64, 0.0, 0);
        for k in 0..=288 {
            let t = start + hifitime::Duration::from_seconds(300.0 * k as f64);
            let s = eph.select(sv, t).unwrap().compute(t);
            let g = s.pos.to_geodetic();
            let (lat, lon) = (g.lat.to_degrees(), g.lon.to_degrees());
            lat_min = lat_min.min(lat);
            lat_max = lat_max.max(lat);
            lon_sum += lon;
            n += 1;
            assert!((s.pos.0.norm() - 42_164e3).abs() < 3_300e3, "{sv}");
        }
        let lon_mean = lon_sum / n as f64;
        eprintln!("{sv}: latitude {lat_min:.1}…{lat_max:.1}°, mean longitude {lon_mean:.2}° E");
        if sv.prn == 7 {
            assert!(
                (lon_mean - 127.0).abs() < 0.1 && lat_max.abs() < 0.1,
                "{sv}"
            );
        } else {
            assert!(
                (lat_max - 41.0).abs() < 1.0 && (lat_min + 41.0).abs() < 1.0,
                "{sv}"
            );
            assert!((lon_mean - 135.0).abs() < 5.0, "{sv}: {lon_mean}");
        }
        for pair in eph.of(sv).windows(2) {
            let mid = pair[0].toe() + hifitime::Duration::from_seconds(1800.0);
            let (x, y) = (pair[0].compute(mid), pair[1].compute(mid));
            let jump = (x.pos.0 - y.pos.0).norm() + C * (x.clock - y.clock).abs();
            worst_jump = worst_jump.max(jump);
        }
    }
    eprintln!(
        "QZSS: worst record switch {:.1} mm (range + clock)",
        worst_jump * 1e3
    );
    assert!(worst_jump < 0.2, "{worst_jump} m");
}

/// A short flight over Tokyo with GPS, GLONASS and QZSS.
fn japan(systems: &str, strips: usize) -> Scenario {
    let text = format!(
        r#"
name = "japan"
seed = 5
start = "2024-06-12T03:00:00"
[site]
lat_deg = 35.68
lon_deg = 139.77
ground_height = 40.0
[flight]
altitude = 300.0
speed = 50.0
strips = {strips}
strip_length = 1500.0
strip_spacing = 150.0
heading_deg = 0.0
rate_hz = 5.0
static_start_s = 60.0
[camera]
focal_mm = 35.0
width_px = 4000
height_px = 6000
pixel_um = 3.9
forward_overlap = 0.8
lever_arm = [0.10, -0.05, 0.45]
[base]
east = 300.0
north = -2000.0
height_above_ground = 2.0
interval_s = 1.0
[ground]
gcps = 5
checks = 6
ties = 100
relief = 10.0
[gnss]
systems = {systems}
"#
    );
    Scenario::from_toml(&text).unwrap()
}

/// How many records of `sys` a file holds, and whether every one has both phases.
fn records_of(f: &ObsFile, sys: Constellation) -> usize {
    let types = f.header.types_of(sys);
    let l1 = types.iter().position(|t| &t.0 == b"L1C").unwrap();
    let l2 = types
        .iter()
        .position(|t| t.0[0] == b'L' && t.0[1] == b'2')
        .unwrap();
    f.epochs
        .iter()
        .flat_map(|e| &e.sats)
        .filter(|s| s.sv.sys == sys && s.get(l1).is_present() && s.get(l2).is_present())
        .count()
}

/// Single point on the rover of a G+R+J flight: GLONASS and QZSS satellites are used in every
/// solution, and the positions lie within a few metres of the truth; GLONASS alone too.
#[test]
fn single_point_uses_glonass_and_qzss_over_japan() {
    let s = japan(r#"["G", "R", "J"]"#, 1);
    let dir = tmp("spp_grj");
    let rep = simulate::run(&s, &dir).unwrap();
    let truth = simulate::truth_flight(&s).unwrap();
    let inputs = SimInputs::read(&rep).unwrap();
    let rover = &inputs.rover;
    assert_eq!(rover.header.glonass_channels.len(), 24);
    assert!(rover.header.types_of(Constellation::Galileo).is_empty());
    let run = |systems: Vec<Constellation>| {
        let opts = gnss::spp::SppOptions {
            systems,
            ..Default::default()
        };
        let spp = gnss::spp::run(&rover.epochs, &rover.header, &inputs.orbits, &opts);
        let errs: Vec<f64> = spp
            .solutions
            .iter()
            .map(|x| {
                let clock = x.clocks.values().next().copied().unwrap_or(0.0) / C;
                let t = x.time - hifitime::Duration::from_seconds(clock);
                x.pos.enu_from(&truth(t)).0.norm()
            })
            .collect();
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
        let worst = errs.iter().copied().fold(0.0, f64::max);
        (spp, rms, worst)
    };
    let (spp, rms, worst) = run(gnss::spp::SppOptions::default().systems);
    let used = |sys: Constellation| {
        spp.solutions
            .iter()
            .map(|x| x.used.iter().filter(|sv| sv.sys == sys).count())
            .min()
            .unwrap_or(0)
    };
    let (g, r, j) = (
        used(Constellation::Gps),
        used(Constellation::Glonass),
        used(Constellation::Qzss),
    );
    eprintln!(
        "SPP G+R+J: {} of {} epochs, at least {g} GPS, {r} GLONASS, {j} QZSS used; 3D RMS {rms:.2} m, worst {worst:.2} m",
        spp.solutions.len(),
        rover.epochs.len()
    );
    assert_eq!(spp.solutions.len(), rover.epochs.len());
    assert!(r >= 4 && j >= 2 && g >= 4, "{g} {r} {j}");
    assert!(rms < 3.0 && worst < 8.0, "SPP {rms} m RMS, worst {worst} m");
    let (glo, rms, worst) = run(vec![Constellation::Glonass]);
    eprintln!(
        "SPP GLONASS alone: {} epochs, 3D RMS {rms:.2} m, worst {worst:.2} m",
        glo.solutions.len()
    );
    assert!(glo.solutions.len() as f64 >= 0.95 * rover.epochs.len() as f64);
    assert!(
        rms < 4.0 && worst < 12.0,
        "GLONASS alone {rms} m RMS, worst {worst} m"
    );
}

/// PPK with default options on a short G+R+J flight (GLONASS in both files, channels in both
/// headers): fixed, and within 2 cm of the truth; with GLONASS added to the systems (its
/// ambiguities float, as ppkat keeps them) too.
#[test]
fn ppk_fixes_a_short_flight_with_glonass_and_qzss() {
    let s = japan(r#"["G", "R", "J"]"#, 2);
    let dir = tmp("ppk_grj");
    let rep = simulate::run(&s, &dir).unwrap();
    let truth = simulate::truth_flight(&s).unwrap();
    let inputs = SimInputs::read(&rep).unwrap();
    for (f, name) in [(&inputs.rover, "rover"), (&inputs.base, "base")] {
        let (r, j) = (
            records_of(f, Constellation::Glonass),
            records_of(f, Constellation::Qzss),
        );
        eprintln!("{name}: {r} GLONASS and {j} QZSS records with both phases");
        assert!(r >= 5 * f.epochs.len() && j >= 2 * f.epochs.len(), "{name}");
        assert_eq!(f.header.glonass_channels.len(), 24, "{name}");
    }
    let mut with_glonass = PpkOptions::default();
    with_glonass.systems.push(Constellation::Glonass);
    for (opts, what) in [
        (PpkOptions::default(), "default options"),
        (with_glonass, "GLONASS added"),
    ] {
        let r = inputs.ppk(&rep, &opts).unwrap();
        let errs: Vec<f64> = r
            .trajectory
            .epochs
            .iter()
            .filter(|e| e.quality == Quality::Fixed)
            .map(|e| (e.pos.0 - truth(e.time).0).norm())
            .collect();
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
        let worst = errs.iter().copied().fold(0.0, f64::max);
        let fixed = r.fixed() as f64 / r.rover_epochs as f64;
        let nsat = r
            .trajectory
            .epochs
            .iter()
            .map(|e| e.nsat)
            .min()
            .unwrap_or(0);
        eprintln!(
            "PPK ({what}): {} epochs, {:.2} % fixed, at least {nsat} satellites, 3D RMS {:.1} mm, worst {:.1} mm",
            r.rover_epochs,
            100.0 * fixed,
            rms * 1e3,
            worst * 1e3
        );
        assert!(fixed >= 0.99, "{what}: fixed {fixed}");
        assert!(
            rms <= 0.02 && worst <= 0.05,
            "{what}: 3D RMS {rms}, worst {worst}"
        );
    }
}

/// The GLONASS inter-channel bias hooks: with slopes set (the rover's and the base's
/// different), every GLONASS phase and code moves by k·slope metres on channel k (both
/// bands) and nothing else changes.
#[test]
fn glonass_inter_channel_bias_hooks_add_k_times_the_slope() {
    let mut s = japan(r#"["G", "R"]"#, 1);
    s.flight.strip_length = 500.0;
    let off = simulate::run(&s, &tmp("icb_off")).unwrap();
    s.errors.glonass_icb_m_per_channel = [0.004, -0.011];
    s.errors.glonass_code_icb_m_per_channel = [0.25, 0.6];
    let on = simulate::run(&s, &tmp("icb_on")).unwrap();
    for (a, b, phase_slope, code_slope) in [
        (&off.rover, &on.rover, 0.004, 0.25),
        (&off.base, &on.base, -0.011, 0.6),
    ] {
        let (a, b) = (ObsFile::read(a).unwrap(), ObsFile::read(b).unwrap());
        let (mut worst_code, mut worst_phase, mut biased) = (0.0f64, 0.0f64, 0);
        for (ea, eb) in a.epochs.iter().zip(&b.epochs) {
            assert_eq!(ea.sats.len(), eb.sats.len());
            for (sa, sb) in ea.sats.iter().zip(&eb.sats) {
                assert_eq!(sa.sv, sb.sv);
                let k = match sa.sv.sys {
                    Constellation::Glonass => a.header.glonass_channel(sa.sv).unwrap() as f64,
                    _ => 0.0,
                };
                biased += (k != 0.0) as usize;
                // C1 L1 · · C2 L2: codes in metres, phases in cycles of the channel's carrier.
                for (col, freq) in [(0, 1602.0e6 + 0.5625e6 * k), (4, 1246.0e6 + 0.4375e6 * k)] {
                    let code = sb.get(col).value - sa.get(col).value;
                    let phase = (sb.get(col + 1).value - sa.get(col + 1).value) * C / freq;
                    worst_code = worst_code.max((code - k * code_slope).abs());
                    worst_phase = worst_phase.max((phase - k * phase_slope).abs());
                }
            }
        }
        eprintln!(
            "inter-channel bias: {biased} biased records; worst misfit code {:.2} mm, phase {:.3} mm",
            worst_code * 1e3,
            worst_phase * 1e3
        );
        assert!(biased > 100);
        assert!(worst_code <= 1.0e-3 + 1e-9, "code {worst_code}");
        assert!(worst_phase <= 0.25e-3, "phase {worst_phase}");
    }
}

/// The `[gnss]` section: default G + E; any order of G, E, R, J; unknown letters,
/// repetitions, an empty list, unknown keys and implausible bias slopes refused by name.
#[test]
fn the_gnss_section_is_checked() {
    let with = |extra: &str| {
        let text = include_str!("../../fixtures/scenario_small.toml").to_string() + extra;
        Scenario::from_toml(&text).map_err(|e| e.to_string())
    };
    use Constellation::*;
    assert_eq!(with("").unwrap().systems(), [Gps, Galileo]);
    let s = with("[gnss]\nsystems = [\"J\", \"R\", \"G\"]\n").unwrap();
    assert_eq!(s.systems(), [Gps, Glonass, Qzss]);
    let e = with("[gnss]\nsystems = [\"C\"]\n").unwrap_err();
    assert!(e.contains("unknown variant") && e.contains("`R`"), "{e}");
    for bad in ["[\"G\", \"G\"]", "[]"] {
        let e = with(&format!("[gnss]\nsystems = {bad}\n")).unwrap_err();
        assert!(e.contains("gnss.systems"), "{e}");
    }
    let e = with("[gnss]\nsystem = [\"G\"]\n").unwrap_err();
    assert!(e.contains("system"), "{e}");
    let e = with("[errors]\nglonass_icb_m_per_channel = [0.01, 3.0]\n").unwrap_err();
    assert!(e.contains("errors.glonass_icb_m_per_channel"), "{e}");
    let s = with("[errors]\nglonass_code_icb_m_per_channel = [0.1, -0.2]\n").unwrap();
    assert_eq!(s.errors.glonass_code_icb_m_per_channel, [0.1, -0.2]);
}
