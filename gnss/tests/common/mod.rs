//! Helpers shared by the real-data tests: find ../shared/data, skip or fail when absent.

#![allow(dead_code)]

use gnss::frame::Ecef;
use gnss::orbit::{Ephemerides, Orbits};
use gnss::ppk::{self, BasePosition, PpkOptions, PpkResult};
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use std::path::Path;

/// The shared data folder `rel`, or `None` (with a message) when it is absent outside CI.
/// On CI (`CI=true`) its absence is a failure.
pub use testkit::shared_data as data;

pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// No warning of the input checks: every base epoch holds phase of the processed systems,
/// both receivers' Doppler follows their phase, the baseline is modelled and every rover
/// epoch has a base epoch with a common satellite.
pub fn assert_inputs_clean(r: &PpkResult) {
    for w in &r.warnings {
        for flag in [
            "Doppler",
            "hold no carrier phase",
            "longest baseline",
            "no satellite in common",
        ] {
            assert!(!w.contains(flag), "{w}");
        }
    }
}

/// The carrier-phase engine on files in memory, with the navigation files `navs` of `dir`.
pub fn ppk_on(
    dir: &Path,
    r: &ObsFile,
    b: &ObsFile,
    navs: &[&str],
    base_pos: Ecef,
    opts: &PpkOptions,
) -> PpkResult {
    let n: Vec<NavFile> = navs
        .iter()
        .map(|f| NavFile::read(&dir.join(f)).unwrap())
        .collect();
    ppk_with(
        r,
        b,
        &Orbits::broadcast(Ephemerides::from_nav(&n)),
        base_pos,
        opts,
    )
}

/// The carrier-phase engine on files in memory with the orbits given.
pub fn ppk_with(
    r: &ObsFile,
    b: &ObsFile,
    orbits: &Orbits,
    base_pos: Ecef,
    opts: &PpkOptions,
) -> PpkResult {
    ppk::process(
        r,
        b,
        BasePosition::Given(base_pos),
        orbits,
        opts,
        &::common::progress::NoProgress,
    )
    .unwrap()
}
