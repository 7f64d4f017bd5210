//! Single-point positioning on real data against known station coordinates.

mod common;

use gnss::frame::{Ecef, Geodetic};
use gnss::orbit::{Ephemerides, Orbits};
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use gnss::spp::{self, SppOptions};

fn errors(run: &spp::SppRun, truth: Ecef) -> (Vec<f64>, Vec<f64>) {
    let mut h = Vec::new();
    let mut v = Vec::new();
    for s in &run.solutions {
        let e = s.pos.enu_from(&truth);
        h.push(e.horizontal());
        v.push(e.up());
    }
    (h, v)
}

#[test]
fn esbc_day_multi_gnss() {
    let Some(dir) = common::data("gnss/esbc-2020-177") else {
        return;
    };
    let obs = ObsFile::read(&dir.join("ESBC00DNK_R_20201770000_01D_30S_MO.crx.gz")).unwrap();
    let nav = NavFile::read(&dir.join("ESBC00DNK_R_20201770000_01D_MN.rnx.gz")).unwrap();
    let orbits = Orbits::broadcast(Ephemerides::from_nav(&[nav]));
    let run = spp::run(&obs.epochs, &obs.header, &orbits, &SppOptions::default());
    // Truth: the marker plus the 0.216 m antenna height (ARP).
    let marker = Ecef::new(3582105.2910, 532589.7313, 5232754.8054).to_geodetic();
    let truth = Geodetic {
        h: marker.h + 0.216,
        ..marker
    }
    .to_ecef();
    let (h, v) = errors(&run, truth);
    eprintln!(
        "ESBC: {} of {} epochs solved, H RMS {:.3} m, V RMS {:.3} m, failures {:?}",
        run.solutions.len(),
        obs.epochs.len(),
        common::rms(&h),
        common::rms(&v),
        run.failures.iter().take(3).collect::<Vec<_>>()
    );
    // Every epoch with ≥ 5 satellites above the mask must be solved: all of them here.
    assert_eq!(run.solutions.len(), obs.epochs.len());
    assert!(common::rms(&h) <= 1.5);
    assert!(common::rms(&v) <= 3.0);
}

#[test]
fn geonet_rover_gps_only() {
    let Some(dir) = common::data("gnss/geonet-2005") else {
        return;
    };
    let obs = ObsFile::read(&dir.join("07590920.05o")).unwrap();
    let nav = NavFile::read(&dir.join("07590920.05n")).unwrap();
    let orbits = Orbits::broadcast(Ephemerides::from_nav(&[nav]));
    let run = spp::run(&obs.epochs, &obs.header, &orbits, &SppOptions::default());
    let truth = Ecef::new(-3976219.1869, 3382371.6036, 3652511.1410);
    let (h, v) = errors(&run, truth);
    eprintln!(
        "GEONET: {} of {} epochs solved, H RMS {:.3} m, V RMS {:.3} m",
        run.solutions.len(),
        obs.epochs.len(),
        common::rms(&h),
        common::rms(&v)
    );
    assert!(run.solutions.len() >= 110);
    assert!(common::rms(&h) <= 1.5);
    assert!(common::rms(&v) <= 3.0);
    // Each unsolved epoch says why.
    assert_eq!(run.failures.len() + run.solutions.len(), obs.epochs.len());
}
