//! Base and rover given the wrong way round: before PPK, a few epochs of each file are solved
//! by single-point positioning. A base must stand still, so a "base" whose positions spread
//! far beyond a static receiver's (the rover's file given as `--base`), or a "rover" that
//! stands still while the base position the run would use lies far from where the base's
//! own observations put it (the base's file given as `--rover`, with the other receiver's
//! position as base), is refused with a message saying what was found.

use gnss::error::{Error, Result};
use gnss::frame::Ecef;
use gnss::orbit::Orbits;
use gnss::rinex::ObsFile;
use gnss::spp::SppOptions;
use nalgebra::Vector3;
use std::path::Path;

/// Epochs of each file solved for the check (evenly spread over the file).
const SAMPLES: usize = 40;
/// Spread (90th percentile of the distance from the median) beyond which a receiver moves,
/// metres: single-point scatter of a static receiver stays within a few tens of metres.
const MOVING_M: f64 = 100.0;
/// Spread below which a receiver stands still, metres.
const STATIC_M: f64 = 30.0;
/// Distance between the base position used and the base's own single-point position beyond
/// which the base position cannot be that receiver's, metres.
const FAR_M: f64 = 1000.0;

/// The median single-point position of a sample of `obs`'s epochs and its spread (m), or
/// `None` when too few epochs solve to judge.
fn sample(
    obs: &ObsFile,
    orbits: &Orbits,
    systems: &[gnss::sv::Constellation],
) -> Option<(Vector3<f64>, f64)> {
    let n = obs.epochs.len();
    let step = (n / SAMPLES).max(1);
    let epochs: Vec<_> = obs
        .epochs
        .iter()
        .step_by(step)
        .take(SAMPLES)
        .cloned()
        .collect();
    let opts = SppOptions {
        systems: systems.to_vec(),
        ..SppOptions::default()
    };
    let run = gnss::spp::run(&epochs, &obs.header, orbits, &opts);
    let pos: Vec<Vector3<f64>> = run.solutions.iter().map(|s| s.pos.0).collect();
    if pos.len() < 5 {
        return None;
    }
    let median = Vector3::from_fn(|k, _| {
        let mut c: Vec<f64> = pos.iter().map(|p| p[k]).collect();
        c.sort_by(f64::total_cmp);
        c[c.len() / 2]
    });
    let mut d: Vec<f64> = pos.iter().map(|p| (p - median).norm()).collect();
    d.sort_by(f64::total_cmp);
    Some((median, d[(d.len() * 9) / 10]))
}

/// `Err` naming the files when base and rover look swapped (see the module); `stated` is the
/// base position the run would use (given, or the base header's).
pub fn check(
    (rover_path, rover): (&Path, &ObsFile),
    (base_path, base): (&Path, &ObsFile),
    stated: Option<Ecef>,
    orbits: &Orbits,
    systems: &[gnss::sv::Constellation],
) -> Result<()> {
    let swapped = "were --rover and --base swapped? Give the moving receiver as --rover and the static one as --base";
    let Some((base_median, base_spread)) = sample(base, orbits, systems) else {
        return Ok(());
    };
    if base_spread > MOVING_M {
        return Err(Error::input(
            base_path,
            format!("the base moves: its single-point positions spread over {base_spread:.0} m (a static receiver's stay within tens of metres); {swapped}"),
        ));
    }
    let (Some(stated), Some((_, rover_spread))) = (stated, sample(rover, orbits, systems)) else {
        return Ok(());
    };
    let off = (stated.0 - base_median).norm();
    if rover_spread < STATIC_M && off > FAR_M {
        return Err(Error::input(
            rover_path,
            format!("the rover stands still (single-point spread {rover_spread:.0} m) and the base position used lies {:.1} km from where the base's own observations ({}) put it; {swapped}, or give the base's position with --base-pos", off / 1000.0, base_path.display()),
        ));
    }
    Ok(())
}
