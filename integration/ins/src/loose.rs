//! Loosely coupled GNSS/INS: the IMU carried forward by the filter, each GNSS antenna
//! position an update through the lever arm, a checkpoint at every update and every
//! `every` samples, then the smoother backward over the checkpoints.
//!
//! What enters: IMU samples in time order, GNSS fixes in time order (each applied after the
//! IMU sample that ends within half an interval of its time; the others are counted), the
//! initial estimate and covariance, the IMU's figures and the lever arm. What leaves:
//! forward and smoothed estimates with covariances at every checkpoint, and each update's
//! normalised innovation.

use crate::errstate::Mat;
use crate::filter::{Checkpoint, Estimate, Forward, PositionFix};
use crate::imu::ImuSample;
use crate::smoother::{smooth, Smoothed};
use crate::spec::ImuSpec;
use crate::tight::{self, Integers, Phases};
use hifitime::Epoch;
use nalgebra::Vector3;

/// σ of the zero velocity while still, m/s.
pub const STILL_SIGMA: f64 = 0.01;
/// A GNSS gap (s) longer than this is a bridge whose end checks the prediction's σ.
pub const BRIDGE: f64 = 2.0;

/// What a loosely coupled run takes besides the data.
#[derive(Clone, Debug)]
pub struct LooseOptions {
    /// IMU → antenna lever arm in the body frame (x forward, y right, z down), m.
    pub lever_arm: Vector3<f64>,
    /// A checkpoint (an output) every this many IMU samples, besides every update.
    pub every: usize,
    /// A land vehicle: no side slip nor jump within this σ (m/s), applied at every
    /// checkpoint while the speed is above 1 m/s ([`Forward::update_no_side_slip`]).
    pub no_side_slip: Option<f64>,
    /// Spans where the body stands still (from the GNSS velocities used): zero velocity and
    /// angular rate at every checkpoint there ([`Forward::update_still`]).
    pub still: Vec<(Epoch, Epoch)>,
    /// Times (in order) that each want a checkpoint at the IMU sample nearest them, besides
    /// the updates and every `every` samples: where a check compares the run with data it
    /// was not given ([`crate::crossval`]).
    pub marks: Vec<Epoch>,
}

/// A run's results.
#[derive(Clone, Debug, Default)]
pub struct LooseRun {
    /// Forward filter at every checkpoint: time, estimate, covariance.
    pub forward: Vec<(Epoch, Estimate, Mat)>,
    /// Smoothed at every checkpoint.
    pub smoothed: Vec<(Epoch, Smoothed)>,
    /// Normalised innovation squared of each update (χ²(3) when the σ hold).
    pub nis: Vec<f64>,
    /// GNSS fixes outside the IMU data (before its first sample or after its last): not used.
    pub unused_fixes: usize,
    /// The factor on the IMU's random walks the innovations asked for, at the end.
    pub noise_scale: f64,
    /// Double-differenced phases that updated the filter (rows), and their NIS per row.
    pub phase_rows: usize,
    /// NIS per row of each phase update (1 when the σ hold).
    pub phase_nis: Vec<f64>,
    /// Integers learnt.
    pub integers: usize,
    /// Integers dropped again (a residual beyond [`tight::DROP_SIGMAS`]).
    pub integers_dropped: usize,
    /// Zero-velocity and zero-rate updates made while still.
    pub still_updates: usize,
    /// Normalised innovation squared of the first update after each GNSS gap longer than
    /// [`BRIDGE`]: how well the IMU's prediction across the gap met the GNSS (χ²(3) when
    /// the σ hold).
    pub bridge_nis: Vec<f64>,
}

/// Run the filter forward over `samples` with `fixes`, then smooth.
pub fn run(
    samples: &[ImuSample],
    fixes: &[(Epoch, PositionFix)],
    start: (Estimate, Mat),
    spec: &ImuSpec,
    o: &LooseOptions,
) -> LooseRun {
    run_with_phases(samples, fixes, &Phases::default(), start, spec, o)
}

/// [`run`] with double-differenced phases besides the positions ([`crate::tight`]): they
/// teach integers where the positions hold the filter and update it where they are missing.
pub fn run_with_phases(
    samples: &[ImuSample],
    fixes: &[(Epoch, PositionFix)],
    phases: &Phases,
    start: (Estimate, Mat),
    spec: &ImuSpec,
    o: &LooseOptions,
) -> LooseRun {
    let mut f = Forward::new(start.0, start.1, spec);
    let mut out = LooseRun::default();
    let (mut times, mut cps): (Vec<Epoch>, Vec<Checkpoint>) = (Vec::new(), Vec::new());
    let mut next = 0;
    let mut last_update: Option<Epoch> = None;
    let (mut next_phase, mut known) = (0, Integers::default());
    let (mut turned, mut since) = (Vector3::zeros(), 0.0);
    let mut next_mark = 0;
    for (k, s) in samples.iter().enumerate() {
        f.predict(s);
        turned += s.dtheta;
        since += s.dt;
        // The sample takes the fixes from half its interval before it to half the next one
        // after it: contiguous windows, however the IMU's intervals jitter or gap.
        let before = 0.5 * s.dt;
        let after = 0.5 * samples.get(k + 1).map_or(s.dt, |n| n.dt);
        while next < fixes.len() && (fixes[next].0 - s.time).to_seconds() < -before {
            out.unused_fixes += 1;
            next += 1;
        }
        let mut updated = false;
        if next < fixes.len() && (fixes[next].0 - s.time).to_seconds() <= after {
            let offset = (fixes[next].0 - s.time).to_seconds();
            let nis = f.update_position(&fixes[next].1, &o.lever_arm, offset);
            out.nis.push(nis);
            if last_update.is_some_and(|l| (fixes[next].0 - l).to_seconds() > BRIDGE) {
                out.bridge_nis.push(nis);
            }
            last_update = Some(fixes[next].0);
            next += 1;
            updated = true;
        }
        let fixed = updated;
        while let Some(e) = phases.epochs.get(next_phase) {
            let dt = (e.time - s.time).to_seconds();
            if dt > after {
                break;
            }
            next_phase += 1;
            if dt < -before {
                continue;
            }
            if fixed {
                let at = (&o.lever_arm, dt);
                out.integers += tight::learn(&f, e, at, phases.baseline_km, &mut known);
            } else if let Some((rows, nis)) =
                tight::update(&mut f, e, &o.lever_arm, dt, &known, phases.baseline_km)
            {
                out.phase_rows += rows;
                out.phase_nis.push(nis / rows as f64);
                updated = true;
            }
        }
        let mut marked = false;
        while next_mark < o.marks.len() && (o.marks[next_mark] - s.time).to_seconds() <= after {
            marked |= (o.marks[next_mark] - s.time).to_seconds() >= -before;
            next_mark += 1;
        }
        if updated || marked || (k + 1) % o.every.max(1) == 0 {
            if let Some(sigma) = o.no_side_slip {
                if f.estimate().nav.velocity.norm() > 1.0 {
                    f.update_no_side_slip(sigma);
                }
            }
            if o.still.iter().any(|(a, b)| (*a..=*b).contains(&s.time)) {
                f.update_still(&(turned / since), since, STILL_SIGMA);
                out.still_updates += 1;
            }
            (turned, since) = (Vector3::zeros(), 0.0);
            let cp = f.checkpoint();
            out.forward.push((s.time, cp.post, cp.post_cov));
            times.push(s.time);
            cps.push(cp);
        }
    }
    out.unused_fixes += fixes.len() - next;
    out.integers_dropped = known.dropped;
    out.noise_scale = f.noise_scale();
    out.smoothed = times.into_iter().zip(smooth(&cps)).collect();
    out
}
