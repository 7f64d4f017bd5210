//! A whole loosely coupled run from files, as `ppkat ins` makes it: the IMU log (RTKLIB-style
//! CSV and time tags, a plain CSV with a header, or KF-GINS' increments) turned into the body frame by its mounting and shifted by its logging
//! delay, the GNSS `.pos`, the alignment (levelled while still before the first motion,
//! heading from the course once the antenna moves faster than [`ALIGN_SPEED`]), the forward
//! filter and the smoother, and the smoothed trajectory written as CSV.
//!
//! GNSS epochs may be withheld in windows (seconds from the first GNSS epoch), to see how
//! the IMU bridges outages against the fixes left out.

use crate::align::{course, level};
use crate::attitude::{ned_to_ecef, Euler};
use crate::crossval::{self, TrialCheck};
use crate::errstate::{idx, Mat};
use crate::filter::{Estimate, PositionFix};
use crate::gnss_pos::{read_pos, GnssEpoch};
use crate::imu::{to_body, ImuSample};
use crate::loose::{run_with_phases, LooseOptions, LooseRun};
use crate::mech::NavState;
use crate::spec::ImuSpec;
use crate::tight::{thin, PhaseEpoch, Phases};
use crate::{plain_imu, rtklib_imu, Error, Result};
use common::frame::{enu_rotation, Ecef};
use gnss::solution::Quality;
use hifitime::{Duration, Epoch};
use nalgebra::{Matrix3, Vector3};
use std::path::PathBuf;

/// Horizontal speed (m/s) past which the course gives the heading.
pub const ALIGN_SPEED: f64 = 1.0;
/// Horizontal speed (m/s) below which the body is taken as still for levelling.
const STILL_SPEED: f64 = 0.3;

/// How an IMU log is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImuFormat {
    /// The RTKLIB-style raw CSV (g, °/s, ms ticks) with its time-tag file ([`rtklib_imu`]).
    RtklibCsv,
    /// A CSV whose header states its quantities and units ([`crate::plain_imu`]).
    Csv,
    /// KF-GINS' text increments ([`crate::plain_imu`]).
    KfGins,
}

/// What a run reads and how.
#[derive(Clone, Debug)]
pub struct InsJob {
    /// IMU log.
    pub imu_csv: PathBuf,
    /// Its format.
    pub imu_format: ImuFormat,
    /// Its RTKLIB time-tag file (read for [`ImuFormat::RtklibCsv`] only).
    pub imu_tag: PathBuf,
    /// GNSS antenna positions (`.pos`).
    pub gnss: PathBuf,
    /// The IMU's figures.
    pub spec: ImuSpec,
    /// The body's axes in the IMU's, as roll, pitch, yaw (the IMU → body rotation is this
    /// matrix's transpose; the data's own configuration files give it so).
    pub mount: Euler,
    /// Seconds added to the IMU's times (its logging delay, negative when it logs late).
    pub imu_time_offset: f64,
    /// IMU → antenna in the body frame, m.
    pub lever_arm: Vector3<f64>,
    /// A land vehicle's no-side-slip σ, m/s.
    pub no_side_slip: Option<f64>,
    /// GNSS epochs withheld: windows in seconds from the first GNSS epoch.
    pub withhold: Vec<(f64, f64)>,
    /// An output every this many IMU samples (besides each GNSS epoch).
    pub every: usize,
    /// Tight coupling: the receivers' observations whose double-differenced phases update
    /// the filter where the positions are withheld.
    pub phases: Option<PhaseFiles>,
}

/// The files of a tightly coupled run.
#[derive(Clone, Debug)]
pub struct PhaseFiles {
    /// Rover observations (RINEX or a raw log).
    pub rover: PathBuf,
    /// Base observations.
    pub base: PathBuf,
    /// Navigation files (broadcast orbits); the rover's own when empty.
    pub nav: Vec<PathBuf>,
    /// The base's marker: given, or its header's.
    pub base_position: gnss::ppk::BasePosition,
    /// In the withheld windows, the phases of only this many satellites (the highest): a
    /// sky too narrow for a position.
    pub keep: Option<usize>,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct InsRun {
    /// The filter's results.
    pub run: LooseRun,
    /// The GNSS epochs read.
    pub gnss: Vec<GnssEpoch>,
    /// Roll and pitch levelled (rad), and the alignment's time.
    pub levelled: (f64, f64, Epoch),
    /// The heading taken from the course at the alignment, rad.
    pub heading: f64,
    /// The factor on the IMU's noise the GNSS gaps' ends asked for (1: the data sheet held),
    /// and the gaps checked.
    pub bridge_scale: (f64, usize),
    /// The smoothed σ checked in trial gaps ([`crossval`]): the last check, and the factor
    /// on the noise (beyond the bridges') it asked for; None without real gaps.
    pub trial: Option<(TrialCheck, f64)>,
    /// IMU rows skipped and gaps, named.
    pub imu_notes: Vec<String>,
    /// What was assumed in reading the IMU log (a week for seconds of week).
    pub assumed: Vec<String>,
    /// Tight coupling: rover epochs without double differences, and the input checks'
    /// warnings.
    pub phase_notes: (usize, Vec<String>),
}

/// Seconds from the first GNSS epoch within a withheld window.
pub fn withheld(job: &InsJob, first: Epoch, t: Epoch) -> bool {
    let s = (t - first).to_seconds();
    job.withhold.iter().any(|(a, b)| (*a..=*b).contains(&s))
}

/// Horizontal speed and course at epoch `i` from the epochs two either side.
fn motion(g: &[GnssEpoch], i: usize) -> Option<(f64, f64)> {
    let (a, b) = (g.get(i.checked_sub(2)?)?, g.get(i + 2)?);
    let dt = (b.time - a.time).to_seconds();
    let enu = enu_rotation(&a.position.to_geodetic()) * (b.position.0 - a.position.0) / dt;
    Some((enu.xy().norm(), course(enu.y, enu.x)))
}

/// The IMU samples in the body frame, on GPST (seconds of week in the week nearest `near`),
/// what was skipped and what was assumed.
fn body_samples(job: &InsJob, near: Epoch) -> Result<(Vec<ImuSample>, Vec<String>, Vec<String>)> {
    let (log, assumed) = match job.imu_format {
        ImuFormat::RtklibCsv => (rtklib_imu::read(&job.imu_csv, &job.imu_tag)?, Vec::new()),
        ImuFormat::Csv => plain_imu::read_csv(&job.imu_csv, near)?,
        ImuFormat::KfGins => plain_imu::read_kf_gins(&job.imu_csv, near)?,
    };
    let mut s = log.samples;
    to_body(&mut s, &job.mount.to_matrix().transpose());
    for x in &mut s {
        x.time += Duration::from_seconds(job.imu_time_offset);
    }
    let notes = log
        .skipped
        .into_iter()
        .chain(log.gaps.into_iter().map(|g| format!("gap at {g}")))
        .chain(log.saturated)
        .collect();
    Ok((s, notes, assumed))
}

/// Run the job: the filter's results (the caller writes them).
pub fn run_job(job: &InsJob) -> Result<InsRun> {
    let gnss = read_pos(&job.gnss)?;
    let first = gnss.first().map(|g| g.time).ok_or_else(|| Error::Input {
        path: job.gnss.clone(),
        message: "no positions".into(),
    })?;
    let (samples, imu_notes, assumed) = body_samples(job, first)?;
    let refuse = |m: &str| Error::Input {
        path: job.gnss.clone(),
        message: m.to_string(),
    };
    let moving = (0..gnss.len())
        .find(|&i| motion(&gnss, i).is_some_and(|(v, _)| v > ALIGN_SPEED))
        .ok_or_else(|| refuse("the antenna never moves faster than 1 m/s: the heading cannot be aligned from its course"))?;
    let still_until = (0..gnss.len())
        .find(|&i| motion(&gnss, i).is_some_and(|(v, _)| v > STILL_SPEED))
        .unwrap_or(moving);
    let still = samples.partition_point(|s| s.time < gnss[still_until].time);
    let lv = level(&samples[..still]).ok_or_else(|| refuse("no IMU data while the antenna stands still before it moves: roll and pitch cannot be levelled"))?;
    let (speed, heading) = motion(&gnss, moving).expect("found moving");
    let start = samples
        .iter()
        .position(|s| s.time >= gnss[moving].time)
        .ok_or_else(|| refuse("the IMU log ends before the antenna moves"))?;
    let start_estimate = initial(
        job,
        &gnss[moving],
        &samples[start],
        (lv.roll, lv.pitch, heading),
        speed,
        lv.gyro_bias,
    );
    let fixes: Vec<(Epoch, PositionFix)> = gnss
        .iter()
        .filter(|g| g.time > samples[start].time && !withheld(job, first, g.time))
        .map(|g| (g.time, fix_of(g)))
        .collect();
    let o = LooseOptions {
        lever_arm: job.lever_arm,
        every: job.every,
        no_side_slip: job.no_side_slip,
        still: still_spans(job, &gnss),
        marks: Vec::new(),
    };
    let phases = match &job.phases {
        Some(p) => phase_epochs(job, p, &gnss)?,
        None => Phases::default(),
    };
    let (run, bridge_scale, trial) = checked_run(
        &samples[start + 1..],
        (&fixes, &phases),
        start_estimate,
        &job.spec,
        &o,
    );
    Ok(InsRun {
        run,
        bridge_scale,
        trial,
        gnss,
        levelled: (lv.roll, lv.pitch, samples[start].time),
        heading,
        imu_notes,
        assumed,
        phase_notes: (phases.missing, phases.warnings.clone()),
    })
}

/// Horizontal and vertical speed (m/s) below which a GNSS epoch stands still.
const STILL_SPEED_ZUPT: f64 = 0.05;
/// Shortest stand (s) taken as still.
const STILL_SPAN: f64 = 1.0;

/// The spans (at least [`STILL_SPAN`] long) where consecutive GNSS epochs used, not
/// withheld, move slower than [`STILL_SPEED_ZUPT`] — by the file's velocities, else by the
/// positions two epochs either side.
fn still_spans(job: &InsJob, g: &[GnssEpoch]) -> Vec<(Epoch, Epoch)> {
    let first = g.first().map(|e| e.time);
    let slow = |i: usize| match g[i].velocity {
        Some(v) => v.norm() < STILL_SPEED_ZUPT,
        None => motion(g, i).is_some_and(|(v, _)| v < STILL_SPEED_ZUPT),
    };
    let mut out = Vec::new();
    let mut run: Option<(Epoch, Epoch)> = None;
    for (i, e) in g.iter().enumerate() {
        let used = first.is_some_and(|f| !withheld(job, f, e.time));
        if used && slow(i) {
            run = Some(run.map_or((e.time, e.time), |(a, _)| (a, e.time)));
        } else if let Some((a, b)) = run.take() {
            if (b - a).to_seconds() >= STILL_SPAN {
                out.push((a, b));
            }
        }
    }
    if let Some((a, b)) = run.filter(|(a, b)| (*b - *a).to_seconds() >= STILL_SPAN) {
        out.push((a, b));
    }
    out
}

/// Mean NIS/3 at the bridges' ends beyond which the IMU's noise is raised (the predicted σ
/// 1.2 times too small or more: with few gaps a mean of χ² draws, erring on the safe side).
const BRIDGE_LIMIT: f64 = 1.5;
/// Seconds of data the first pass smooths for the start of the second.
const FIRST_PASS: f64 = 300.0;
/// Reruns at most, each with the noise raised by what the bridges still ask.
const BRIDGE_RERUNS: usize = 5;

/// The filter and smoother run twice and checked at the ends of the GNSS gaps.
///
/// The second run starts from the first one's (over the first [`FIRST_PASS`] s) smoothed
/// attitude and sensor biases at the start (its σ kept): a heading taken from the course can be tens of degrees off (a walker's
/// hand, an aircraft's crab), where the error-state model, linear in small angles, bends the
/// first run's bridges; started near the truth, the second run's are straight.
///
/// Then the gaps' ends: where the IMU's predictions across them met the returning GNSS
/// further off than their σ said (mean NIS/3 beyond [`BRIDGE_LIMIT`]), the data sheet's noise
/// was too kind for this IMU or this motion, and the run is repeated with the angle and
/// velocity random walks raised by √(NIS/3) (the position σ a gap adds grow with them), so
/// that the bridged σ hold. Last the smoothed σ inside the gaps, which the ends cannot
/// test, in trial gaps ([`checked_smoothing`]). Returns the run, the bridges' factor with
/// the number of gaps checked, and the trial gaps' last check with their further factor.
pub fn checked_run(
    samples: &[ImuSample],
    (fixes, phases): (&[(Epoch, PositionFix)], &Phases),
    start: (Estimate, Mat),
    spec: &ImuSpec,
    o: &LooseOptions,
) -> (LooseRun, (f64, usize), Option<(TrialCheck, f64)>) {
    let head = samples.partition_point(|s| (s.time - start.0.nav.time).to_seconds() < FIRST_PASS);
    let first = run_with_phases(&samples[..head], fixes, phases, start, spec, o);
    let start = match (first.forward.first(), first.smoothed.first()) {
        (Some(f), Some(s)) => {
            let mut d = s.1.est.minus(&f.1);
            d.fixed_rows_mut::<6>(idx::POS).fill(0.0);
            (start.0.corrected(&d), start.1)
        }
        _ => start,
    };
    drop(first);
    let mut k = 1.0;
    let mut r = run_with_phases(samples, fixes, phases, start, spec, o);
    for _ in 0..BRIDGE_RERUNS {
        let n = r.bridge_nis.len();
        let ratio = r.bridge_nis.iter().sum::<f64>() / (3.0 * n.max(1) as f64);
        if n == 0 || ratio <= BRIDGE_LIMIT {
            break;
        }
        k *= ratio.sqrt();
        r = run_with_phases(samples, fixes, phases, start, &spec.scaled(k), o);
    }
    let n = r.bridge_nis.len();
    let (trial, k_trial) = checked_smoothing(samples, (fixes, phases), start, &spec.scaled(k), o);
    if k_trial > 1.0 {
        let spec = spec.scaled(k * k_trial);
        r = run_with_phases(samples, fixes, phases, start, &spec, o);
    }
    (r, (k, n), trial.map(|t| (t, k_trial)))
}

/// Trial checks of the smoothed σ inside gaps ([`crossval`]) at most.
const TRIAL_RERUNS: usize = 3;

/// The smoothed σ in gaps checked in trial gaps ([`crossval`]) and, where the errors
/// there exceed them (mean NEES per axis beyond [`BRIDGE_LIMIT`]), the IMU's random walks
/// raised by √ratio and checked again: the last check and the factor found (1 when the σ
/// held, or no real gap asked for a check).
fn checked_smoothing(
    samples: &[ImuSample],
    (fixes, phases): (&[(Epoch, PositionFix)], &Phases),
    start: (Estimate, Mat),
    spec: &ImuSpec,
    o: &LooseOptions,
) -> (Option<TrialCheck>, f64) {
    let times: Vec<Epoch> = fixes.iter().map(|(t, _)| *t).collect();
    let (length, gaps) = crossval::trial_gaps(&times);
    let (mut k, mut last) = (1.0, None);
    if gaps.is_empty() {
        return (None, k);
    }
    for _ in 0..TRIAL_RERUNS {
        let spec = spec.scaled(k);
        let Some(c) = crossval::check(samples, (fixes, phases), start, &spec, o, (length, &gaps))
        else {
            break;
        };
        let ratio = c.ratio;
        last = Some(c);
        if ratio <= BRIDGE_LIMIT {
            break;
        }
        k *= ratio.sqrt();
    }
    (last, k)
}

/// The start: levelled roll and pitch, the course's heading, the antenna's position less
/// the lever arm; σ of 3° (in heading 10° for a land vehicle, 30° otherwise), 0.5 m/s, the
/// gyro biases measured while still.
fn initial(
    job: &InsJob,
    g: &GnssEpoch,
    at: &ImuSample,
    (roll, pitch, heading): (f64, f64, f64),
    speed: f64,
    gyro_bias: Vector3<f64>,
) -> (Estimate, Mat) {
    let att = Euler {
        roll,
        pitch,
        heading,
    };
    let c = ned_to_ecef(&g.position.to_geodetic()) * att.to_matrix();
    let v_ned = Vector3::new(speed * heading.cos(), speed * heading.sin(), 0.0);
    let nav = NavState::from_local(at.time, Ecef(g.position.0 - c * job.lever_arm), v_ned, &att);
    let mut p0 = Mat::zeros();
    for (i, s) in [
        (idx::POS, 0.1),
        (idx::VEL, 0.5),
        (idx::ATT, 3f64.to_radians()),
        (idx::BG, 2e-4),
        (idx::BA, job.spec.accel_turn_on.max(job.spec.accel_bias)),
    ] {
        for j in 0..3 {
            p0[(i + j, i + j)] = s * s;
        }
    }
    let heading_sd: f64 = if job.no_side_slip.is_some() {
        10.0
    } else {
        30.0
    };
    p0[(idx::ATT + 2, idx::ATT + 2)] = heading_sd.to_radians().powi(2);
    let est = Estimate {
        nav,
        gyro_bias,
        accel_bias: Vector3::zeros(),
    };
    (est, p0)
}

/// A GNSS epoch as an update: 2 cm / 4 cm when fixed, 0.3 m / 0.6 m otherwise (a receiver's
/// own σ are often nominal), or the file's σ when they are larger.
fn fix_of(g: &GnssEpoch) -> PositionFix {
    let sd = if g.quality == Quality::Fixed {
        Vector3::new(0.02, 0.02, 0.04)
    } else {
        Vector3::new(0.3, 0.3, 0.6)
    };
    let rot = enu_rotation(&g.position.to_geodetic()).transpose();
    let floor = rot * Matrix3::from_diagonal(&sd.component_mul(&sd)) * rot.transpose();
    let cov = if g.cov.trace() > floor.trace() {
        g.cov
    } else {
        floor
    };
    PositionFix {
        position: g.position,
        cov,
    }
}

/// The double differences of every rover epoch: updates in the withheld windows (thinned to
/// `keep` satellites), teachers elsewhere.
fn phase_epochs(job: &InsJob, p: &PhaseFiles, gnss: &[GnssEpoch]) -> Result<Phases> {
    let g = |path: &PathBuf| {
        let path = path.clone();
        move |e: gnss::Error| Error::Input {
            path: path.clone(),
            message: e.to_string(),
        }
    };
    let rover = gnss::obs::read_obs(&p.rover, None, None).map_err(g(&p.rover))?;
    let base = gnss::obs::read_obs(&p.base, None, None).map_err(g(&p.base))?;
    let mut navs = Vec::new();
    for n in &p.nav {
        navs.push(gnss::rinex::nav::NavFile::read(n).map_err(g(n))?);
    }
    navs.extend(rover.nav.clone());
    if navs.is_empty() {
        return Err(Error::Input {
            path: p.rover.clone(),
            message: "no navigation data for the phases: give nav files".into(),
        });
    }
    let orbits = gnss::orbit::Orbits::broadcast(gnss::orbit::Ephemerides::from_nav(&navs));
    let instants: Vec<Epoch> = rover.obs.epochs.iter().map(|e| e.time).collect();
    let set = gnss::ppk::tight::double_differences(
        &rover.obs,
        &base.obs,
        p.base_position,
        &orbits,
        &gnss::ppk::PpkOptions::default(),
        &instants,
        0.0,
    )
    .map_err(g(&p.rover))?;
    let first = gnss.first().map_or(instants[0], |e| e.time);
    let baseline_km = gnss
        .first()
        .map_or(0.0, |e| (e.position.0 - set.base.0).norm() / 1e3);
    let epochs = set
        .epochs
        .into_iter()
        .map(|e| {
            let rows = match (withheld(job, first, e.rover_time), p.keep) {
                (true, Some(k)) => thin(e.rows, k),
                _ => e.rows,
            };
            PhaseEpoch {
                time: e.rover_time,
                rows,
            }
        })
        .collect();
    Ok(Phases {
        epochs,
        baseline_km,
        missing: set.missing.len(),
        warnings: set.warnings,
    })
}
