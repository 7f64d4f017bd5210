//! Carrier-phase kinematic positioning on real and hardware-simulated data against truth.

mod common;

use gnss::frame::Ecef;
use gnss::orbit::{Ephemerides, Orbits};
use gnss::ppk::{self, BasePosition, FilterMode, PpkOptions, PpkResult};
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use gnss::solution::Quality;
use gnss::trajectory::SegmentSource;
use std::path::Path;

struct Stats {
    fixed_pct: f64,
    h_rms: f64,
    v_rms: f64,
    max_fixed_err: f64,
}

fn stats(
    r: &PpkResult,
    truth: impl Fn(&gnss::trajectory::TrajectoryEpoch) -> Option<Ecef>,
) -> Stats {
    let mut h = Vec::new();
    let mut v = Vec::new();
    let mut max_fixed: f64 = 0.0;
    for s in &r.trajectory.epochs {
        let Some(t) = truth(s) else { continue };
        let e = s.pos.enu_from(&t);
        h.push(e.horizontal());
        v.push(e.up());
        if s.quality == Quality::Fixed {
            max_fixed = max_fixed.max(e.0.norm());
        }
    }
    Stats {
        fixed_pct: 100.0 * r.fixed() as f64 / r.trajectory.epochs.len().max(1) as f64,
        h_rms: common::rms(&h),
        v_rms: common::rms(&v),
        max_fixed_err: max_fixed,
    }
}

fn run(
    dir: &Path,
    rover: &str,
    base: &str,
    navs: &[&str],
    base_pos: Ecef,
    opts: &PpkOptions,
) -> PpkResult {
    let r = ObsFile::read(&dir.join(rover)).unwrap();
    let b = ObsFile::read(&dir.join(base)).unwrap();
    let n: Vec<NavFile> = navs
        .iter()
        .map(|f| NavFile::read(&dir.join(f)).unwrap())
        .collect();
    let orbits = Orbits::broadcast(Ephemerides::from_nav(&n));
    ppk::process(
        &r,
        &b,
        BasePosition::Given(base_pos),
        &orbits,
        opts,
        &|_| {},
    )
    .unwrap()
}

#[test]
fn geonet_static_rover_processed_kinematically() {
    let Some(dir) = common::data("gnss/geonet-2005") else {
        return;
    };
    let base = Ecef::new(-3978241.958, 3382840.234, 3649900.853);
    let truth = Ecef::new(-3976219.1869, 3382371.6036, 3652511.1410);
    for mode in [FilterMode::Combined, FilterMode::Forward] {
        let opts = PpkOptions {
            filter: mode,
            ..PpkOptions::default()
        };
        let r = run(
            &dir,
            "07590920.05o",
            "30400920.05o",
            &["07590920.05n"],
            base,
            &opts,
        );
        let s = stats(&r, |_| Some(truth));
        eprintln!(
            "GEONET {mode:?}: {} solved of {}, fixed {:.1} %, H RMS {:.2} cm, V RMS {:.2} cm, worst fixed {:.2} cm; fw {:?}",
            r.trajectory.epochs.len(),
            r.rover_epochs,
            s.fixed_pct,
            s.h_rms * 100.0,
            s.v_rms * 100.0,
            s.max_fixed_err * 100.0,
            r.forward
        );
        // Every epoch with a valid code solution is solved (the last five have GDOP > 30).
        assert_eq!(r.trajectory.epochs.len(), 115);
        assert!(s.max_fixed_err < 0.10, "no fixed epoch more than 10 cm off");
        // The filter assigns the ambiguity segments: ids grow by one at each boundary, a Q
        // change is one, and the fixed set is held throughout the combined solution.
        assert_eq!(r.trajectory.segments_from, SegmentSource::Filter);
        let segments: Vec<u32> = r.trajectory.epochs.iter().map(|e| e.segment).collect();
        assert_eq!(segments[0], 0);
        assert!(segments
            .windows(2)
            .all(|w| w[1] == w[0] || w[1] == w[0] + 1));
        for w in r.trajectory.epochs.windows(2) {
            if w[0].quality != w[1].quality {
                assert_ne!(w[0].segment, w[1].segment, "a Q change starts a segment");
            }
        }
        match mode {
            FilterMode::Combined => {
                assert!(segments.iter().all(|&s| s == 0), "{segments:?}");
                assert_eq!(s.fixed_pct, 100.0);
                // RTKLIB: H 0.53 cm, V 1.12 cm.
                assert!(s.h_rms <= 0.006, "H RMS {}", s.h_rms);
                assert!(s.v_rms <= 0.012, "V RMS {}", s.v_rms);
            }
            _ => assert!(s.fixed_pct >= 88.0, "forward fix rate {}", s.fixed_pct),
        }
    }
}

/// Truth of the dynamic Spirent rover at 10 Hz, by GPS time of week (0.1 s resolution).
fn spirent_truth(dir: &Path) -> std::collections::HashMap<i64, Ecef> {
    let text = std::fs::read_to_string(dir.join("Rover-dynamic_PVA_Spirent.csv")).unwrap();
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<f64> = l
                .split(',')
                .map(|x| x.trim().parse().unwrap_or(f64::NAN))
                .collect();
            (f.len() >= 7).then(|| ((f[3] * 10.0).round() as i64, Ecef::new(f[4], f[5], f[6])))
        })
        .collect()
}

#[test]
fn spirent_dynamic_and_static_rovers() {
    let Some(dir) = common::data("gnss/spirent-rose-2023") else {
        return;
    };
    let base = Ecef::new(4157177.06580187, 671230.476590636, 4774767.03105544);
    let navs = ["RINEX_GN_Spirent.23N", "RINEX_EN_Spirent.23L"];
    let opts = PpkOptions::default();
    let truth = spirent_truth(&dir);
    let r = run(
        &dir,
        "Rover-dynamic_MO_Spirent.obs",
        "Base-static_MO_Spirent.obs",
        &navs,
        base,
        &opts,
    );
    let s = stats(&r, |s| {
        truth
            .get(&((gnss::time::week_tow(s.time).1 * 10.0).round() as i64))
            .copied()
    });
    let d3 = (s.h_rms.powi(2) + s.v_rms.powi(2)).sqrt();
    eprintln!(
        "Spirent dynamic: {} solved of {}, fixed {:.1} %, 3D RMS {:.2} mm, worst fixed {:.1} mm",
        r.trajectory.epochs.len(),
        r.rover_epochs,
        s.fixed_pct,
        d3 * 1000.0,
        s.max_fixed_err * 1000.0
    );
    assert_eq!(r.trajectory.epochs.len(), r.rover_epochs);
    assert_eq!(s.fixed_pct, 100.0);
    assert!(d3 <= 0.005, "3D RMS {d3}");
    let st = Ecef::new(4156857.1195929, 673209.028774142, 4774767.03105544);
    let r2 = run(
        &dir,
        "Rover-static-2km-east_MO_Spirent.obs",
        "Base-static_MO_Spirent.obs",
        &navs,
        base,
        &opts,
    );
    let s2 = stats(&r2, |_| Some(st));
    let d3s = (s2.h_rms.powi(2) + s2.v_rms.powi(2)).sqrt();
    eprintln!(
        "Spirent static 2 km: {} solved, fixed {:.1} %, 3D RMS {:.2} mm",
        r2.trajectory.epochs.len(),
        s2.fixed_pct,
        d3s * 1000.0
    );
    assert_eq!(s2.fixed_pct, 100.0);
    assert!(d3s <= 0.005, "3D RMS {d3s}");
}

#[test]
fn cssrlib_car() {
    let Some(dir) = common::data("gnss/cssrlib-2021-265") else {
        return;
    };
    let base = Ecef::new(-3959400.631, 3385704.533, 3667523.111);
    let start = gnss::frame::Geodetic::from_degrees(35.342058098, 139.521986657, 47.5515).to_ecef();
    let r = run(
        &dir,
        "SEPT265G.21O",
        "3034265G.21O",
        &["SEPT2650.21P"],
        base,
        &PpkOptions::default(),
    );
    let t0 = r.trajectory.epochs.first().map(|s| s.time).unwrap();
    let s = stats(&r, |s| ((s.time - t0).to_seconds() < 35.0).then_some(start));
    eprintln!(
        "cssrlib car: {} solved of {}, fixed {:.1} %, first 35 s H RMS {:.2} cm V RMS {:.2} cm; fw {:?}",
        r.trajectory.epochs.len(),
        r.rover_epochs,
        s.fixed_pct,
        s.h_rms * 100.0,
        s.v_rms * 100.0,
        r.forward
    );
    assert!(s.fixed_pct >= 90.0, "fix rate {}", s.fixed_pct);
    assert!(s.h_rms <= 0.08, "H RMS over the static start {}", s.h_rms);
}
