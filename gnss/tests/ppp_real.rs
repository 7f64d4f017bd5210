//! Static precise point positioning on ONSA (IGS station, 2005-08-12, 24 h of 30-s GPS data)
//! with the IGS final orbits and their 15-min clocks and the relative antenna model of the
//! time (`igs_01.atx`, blocks assigned to satellites by `igs05.atx`), against the station's
//! ITRF2014 marker coordinate at the epoch of the data.

mod common;

use gnss::frame::{enu_rotation, Ecef};
use gnss::model::antex::Antex;
use gnss::orbit::{Ephemerides, Orbits, PreciseOrbits, Sp3};
use gnss::ppp::{process, PppEpoch, PppOptions};
use gnss::rinex::ObsFile;
use nalgebra::Vector3;

/// ITRF2014 marker of ONSA at 2005.61 (the data set's truth.txt).
const TRUTH: [f64; 3] = [3370658.5313, 711877.1456, 5349786.9559];

/// East, north, up error (m) and σ (m) of a solution.
fn enu_error(e: &PppEpoch) -> ([f64; 3], [f64; 3]) {
    let truth = Ecef::new(TRUTH[0], TRUTH[1], TRUTH[2]);
    let r = enu_rotation(&truth.to_geodetic());
    let d = r * (e.pos.0 - truth.0);
    let c = r * e.cov * r.transpose();
    ([d.x, d.y, d.z], [0, 1, 2].map(|i| c[(i, i)].sqrt()))
}

#[test]
fn onsa_static_ppp_reaches_centimetres_with_honest_sigmas() {
    let Some(dir) = common::data("gnss/onsa-2005-224") else {
        return;
    };
    let Some(bell) = common::data("gnss/bell-ebre-2002-030") else {
        return;
    };
    let obs = ObsFile::read(&dir.join("onsa2240.05o")).unwrap();
    let sp3: Vec<Sp3> = ["igs13354.sp3", "igs13355.sp3", "igs13356.sp3"]
        .iter()
        .map(|n| Sp3::read(&dir.join(n)).unwrap())
        .collect();
    let orbits = Orbits {
        broadcast: Ephemerides::from_nav(&[]),
        precise: Some(PreciseOrbits::new(&sp3, &[]).unwrap()),
    };
    let opts = PppOptions {
        antex: vec![
            Antex::read(&dir.join("igs_01.atx")).unwrap(),
            Antex::read(&bell.join("igs05.atx")).unwrap(),
        ],
        ..PppOptions::default()
    };
    // The header's approximate position (0.42 m off) as the start.
    let start = obs.header.approx_position.unwrap();
    let r = process(&obs, &orbits, &opts, start, &::common::progress::NoProgress).unwrap();
    assert_eq!(r.epochs.len(), 2880, "every epoch solved");
    assert!(
        r.warnings
            .iter()
            .all(|w| !w.contains("no satellite antenna")),
        "{:?}",
        r.warnings
    );
    // After 2 h (the forward filter has seen the first 2 h only) and after 24 h.
    let two_hours = r
        .epochs
        .iter()
        .find(|e| e.time >= r.epochs[0].time + hifitime::Duration::from_seconds(7170.0))
        .unwrap();
    for (e, limit) in [(two_hours, 0.10), (r.epochs.last().unwrap(), 0.03)] {
        let (d, sd) = enu_error(e);
        let d3 = Vector3::from(d).norm();
        assert!(
            d3 <= limit,
            "{}: 3D error {d3:.3} m > {limit} m ({d:?})",
            e.time
        );
        for k in 0..3 {
            assert!(
                d[k].abs() <= 3.0 * sd[k],
                "{}: axis {k} error {:.3} m, σ {:.3} m",
                e.time,
                d[k],
                sd[k]
            );
        }
    }
    let (_, sd) = enu_error(r.epochs.last().unwrap());
    assert!(
        sd[2] < 0.03 && sd[0] < 0.02,
        "σ after a day not uselessly large: {sd:?}"
    );
    assert!(
        r.residual_rms(0) < 0.06,
        "phase residual RMS {}",
        r.residual_rms(0)
    );
}

/// ESBC (Esbjerg, IGS station, 2020-06-25, multi-GNSS, 30 s) with the GRGS multi-GNSS final
/// orbits and their 15-min clocks, GPS + Galileo, without an ANTEX file (none of 2020 is in
/// the shared data: the satellite and receiver antenna offsets are not applied, so the
/// σ floor is the larger one for unmodelled antennas).
///
/// The header's APPROX POSITION is the station's ETRS89 coordinate, not ITRF: public
/// coordinate lists give ESBC in ITRF2014 as 3582104.8458 532590.0946 5232755.0863 at
/// 2015.0 and 3582104.7300 532590.2159 5232755.1625 at 2022.93, and the header position as
/// the ETRS89 transform of the former. Interpolated linearly to the data's epoch (2020.48),
/// the ITRF2014 coordinate is the truth here; the header lies 0.77 m from it horizontally
/// (ETRS89 moves with Eurasia, about 2.5 cm a year since 1989).
/// ESBC's up error and σ up bounds, metres (measured 0.022 and 0.051).
const ESBC_MAX_UP: f64 = 0.035;
const ESBC_MAX_SIGMA_UP: f64 = 0.08;
/// ESBC's horizontal error bound, metres.
const ESBC_MAX_H: f64 = 0.015;

#[test]
fn esbc_static_ppp_within_centimetres_of_itrf() {
    let Some(dir) = common::data("gnss/esbc-2020-177") else {
        return;
    };
    let obs = ObsFile::read(&dir.join("ESBC00DNK_R_20201770000_01D_30S_MO.crx.gz")).unwrap();
    let sp3 = Sp3::read(&dir.join("GRG0MGXFIN_20201770000_01D_15M_ORB.SP3.gz")).unwrap();
    let orbits = Orbits {
        broadcast: Ephemerides::from_nav(&[]),
        precise: Some(PreciseOrbits::new(&[sp3], &[]).unwrap()),
    };
    let r = process(
        &obs,
        &orbits,
        &PppOptions::default(),
        obs.header.approx_position.unwrap(),
        &::common::progress::NoProgress,
    )
    .unwrap();
    let (a, b) = (
        [3582104.8458, 532590.0946, 5232755.0863],
        [3582104.7300, 532590.2159, 5232755.1625],
    );
    let f = (2020.48 - 2015.0) / (2022.93 - 2015.0);
    let truth = Ecef::new(
        a[0] + f * (b[0] - a[0]),
        a[1] + f * (b[1] - a[1]),
        a[2] + f * (b[2] - a[2]),
    );
    let last = r.epochs.last().unwrap();
    let rot = enu_rotation(&truth.to_geodetic());
    let d = rot * (last.pos.0 - truth.0);
    let c = rot * last.cov * rot.transpose();
    assert!(d.norm() < 0.05, "3D error {:.3} m ({d:?})", d.norm());
    for k in 0..3 {
        assert!(
            d[k].abs() <= 3.0 * c[(k, k)].sqrt(),
            "axis {k}: {:.3} m, σ {:.3} m",
            d[k],
            c[(k, k)].sqrt()
        );
    }
    eprintln!(
        "ESBC: E/N/U error {:.4} {:.4} {:.4} m, σ {:.4} {:.4} {:.4} m",
        d[0],
        d[1],
        d[2],
        c[(0, 0)].sqrt(),
        c[(1, 1)].sqrt(),
        c[(2, 2)].sqrt()
    );
    // The σ floor for unmodelled antennas (5 cm up) makes the 3σ test above easy on the up
    // axis; the error itself is held to what it is, and the σ to not more than its floor
    // needs.
    let sigma_up = c[(2, 2)].sqrt();
    assert!(
        (0.05..=ESBC_MAX_SIGMA_UP).contains(&sigma_up),
        "σ up {sigma_up:.3} m: the unmodelled antennas are in it, and no more"
    );
    assert!(d[2].abs() <= ESBC_MAX_UP, "up error {:.4} m", d[2]);
    // Horizontally to 1.5 cm (measured 0.8 cm; without the solid-Earth tide 2.8 cm).
    assert!(
        d.xy().norm() <= ESBC_MAX_H,
        "horizontal error {:.4} m",
        d.xy().norm()
    );
    let header = obs.header.approx_position.unwrap().enu_from(&last.pos).0;
    assert!(
        (0.7..0.85).contains(&header.xy().norm()) && header.z.abs() < 0.1,
        "header (ETRS89) offset {header:?}"
    );
}
