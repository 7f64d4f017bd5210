//! Carrier-phase kinematic positioning on real and hardware-simulated data against truth.

mod common;

use gnss::frame::Ecef;
use gnss::orbit::{Ephemerides, Orbits};
use gnss::ppk::{self, BasePosition, FilterMode, PpkOptions, PpkResult};
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use gnss::solution::Quality;
use std::path::Path;

struct Stats {
    fixed_pct: f64,
    h_rms: f64,
    v_rms: f64,
    max_fixed_err: f64,
}

fn stats(r: &PpkResult, truth: impl Fn(&ppk::EpochSol) -> Option<Ecef>) -> Stats {
    let mut h = Vec::new();
    let mut v = Vec::new();
    let mut max_fixed: f64 = 0.0;
    for s in &r.solutions {
        let Some(t) = truth(s) else { continue };
        let e = s.pos.enu_from(&t);
        h.push(e.horizontal());
        v.push(e.up());
        if s.quality == Quality::Fixed {
            max_fixed = max_fixed.max(e.0.norm());
        }
    }
    Stats {
        fixed_pct: 100.0 * r.fixed() as f64 / r.solutions.len().max(1) as f64,
        h_rms: common::rms(&h),
        v_rms: common::rms(&v),
        max_fixed_err: max_fixed,
    }
}

fn run(dir: &Path, rover: &str, base: &str, navs: &[&str], base_pos: Ecef, opts: &PpkOptions) -> PpkResult {
    let r = ObsFile::read(&dir.join(rover)).unwrap();
    let b = ObsFile::read(&dir.join(base)).unwrap();
    let n: Vec<NavFile> = navs.iter().map(|f| NavFile::read(&dir.join(f)).unwrap()).collect();
    let orbits = Orbits::broadcast(Ephemerides::from_nav(&n));
    ppk::process(&r, &b, BasePosition::Given(base_pos), &orbits, opts, &|_| {}).unwrap()
}

#[test]
fn geonet_static_rover_processed_kinematically() {
    let Some(dir) = common::data("gnss/geonet-2005") else { return };
    let base = Ecef::new(-3978241.958, 3382840.234, 3649900.853);
    let truth = Ecef::new(-3976219.1869, 3382371.6036, 3652511.1410);
    for mode in [FilterMode::Combined, FilterMode::Forward] {
        let opts = PpkOptions {
            filter: mode,
            ..PpkOptions::default()
        };
        let r = run(&dir, "07590920.05o", "30400920.05o", &["07590920.05n"], base, &opts);
        let s = stats(&r, |_| Some(truth));
        eprintln!(
            "GEONET {mode:?}: {} solved of {}, fixed {:.1} %, H RMS {:.2} cm, V RMS {:.2} cm, worst fixed {:.2} cm; fw {:?}",
            r.solutions.len(),
            r.rover_epochs,
            s.fixed_pct,
            s.h_rms * 100.0,
            s.v_rms * 100.0,
            s.max_fixed_err * 100.0,
            r.forward
        );
    }
}

#[test]
#[ignore]
fn geonet_series() {
    let Some(dir) = common::data("gnss/geonet-2005") else { return };
    let base = Ecef::new(-3978241.958, 3382840.234, 3649900.853);
    let truth = Ecef::new(-3976219.1869, 3382371.6036, 3652511.1410);
    let mode = match std::env::var("MODE").as_deref() { Ok("b") => FilterMode::Backward, Ok("c") => FilterMode::Combined, _ => FilterMode::Forward };
    let r = run(&dir, "07590920.05o", "30400920.05o", &["07590920.05n"], base, &PpkOptions { filter: mode, ..PpkOptions::default() });
    for s in &r.solutions {
        let e = s.pos.enu_from(&truth);
        eprintln!("{} {:?} ns={} nfix={} ratio={:.1} e={:+.3} n={:+.3} u={:+.3}", gnss::time::format_ymdhms(s.time), s.quality, s.nsat, s.nfix, s.ratio, e.east(), e.north(), e.up());
    }
}
