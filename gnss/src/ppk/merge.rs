//! What leaves the passes: their solutions merged into one per epoch (the smoother's, checked
//! by its halves; or the forward and backward combined), the trajectory epochs of those, how
//! their ambiguities were resolved, and the passes' separation and resets for the report.
//!
//! What enters: the passes' outputs ([`PassOutput`]) and the run's inputs and options. What
//! leaves: the merged solutions, [`OutputEpochs`], [`AmbiguityRates`] and [`PassDiagnostics`].

use super::combine;
use super::consistency;
use super::inputs::PassInputs;
use super::options::{Motion, PpkOptions, Reference};
use super::output::{AmbiguityRates, EpochSol, PassDiagnostics, PassStats};
use super::refusal::Refusal;
use super::{output, segment, smooth};
use crate::frame::{enu_rotation, Ecef};
use crate::rinex::ObsHeader;
use crate::solution::Quality;
use crate::trajectory::TrajectoryEpoch;
use hifitime::Epoch;
use nalgebra::Vector3;

/// What a pass hands back: its solution per epoch (None when unsolved), its counters and,
/// when it recorded them, its states before each epoch's measurements.
pub(super) struct PassOutput {
    pub(super) sols: Vec<Option<EpochSol>>,
    pub(super) stats: PassStats,
    pub(super) priors: Vec<Option<smooth::Prior>>,
    /// Rover epochs (index) at which ambiguities were reset, with how many, in pass order.
    pub(super) resets: Vec<(usize, u32)>,
}

/// ENU antenna offset (header H/E/N) as an ECEF vector at `at`.
pub(super) fn arp_offset(h: &ObsHeader, at: &Ecef) -> Vector3<f64> {
    let d = h.antenna_delta;
    let r = enu_rotation(&at.to_geodetic());
    r.transpose() * Vector3::new(d.east, d.north, d.up)
}

/// The covariance (ECEF) of a static run's time-correlated errors at `at` (see
/// [`PpkOptions::static_sigma`]); zero for kinematic runs.
fn static_cov(at: &Ecef, base: &Ecef, o: &PpkOptions) -> nalgebra::Matrix3<f64> {
    if o.motion != Motion::Static {
        return nalgebra::Matrix3::zeros();
    }
    let km = (at.0 - base.0).norm() / 1000.0;
    let (h, v) = (o.static_sigma, o.static_sigma_per_km);
    systematic(at, (h.0 + v.0 * km, h.1 + v.1 * km))
}

/// A covariance (ECEF) of `sigma` horizontal and vertical in the local frame at `at`.
fn systematic(at: &Ecef, sigma: (f64, f64)) -> nalgebra::Matrix3<f64> {
    let r = enu_rotation(&at.to_geodetic());
    let d = nalgebra::Matrix3::from_diagonal(&Vector3::new(
        sigma.0 * sigma.0,
        sigma.0 * sigma.0,
        sigma.1 * sigma.1,
    ));
    r.transpose() * d * r
}

/// How the output epochs' ambiguities were resolved (see [`AmbiguityRates`]).
pub(super) fn ambiguity_rates(
    merged: &[Option<(EpochSol, u32)>],
    passes: [&Option<PassStats>; 2],
    dual_frequency: bool,
) -> AmbiguityRates {
    let solved = merged.iter().flatten();
    AmbiguityRates {
        solved: solved.clone().count(),
        widelane: solved.clone().filter(|(s, _)| s.widelanes >= 3).count(),
        narrowlane: solved.filter(|(s, _)| s.quality == Quality::Fixed).count(),
        arcs_held: passes
            .iter()
            .flat_map(|p| p.iter())
            .map(|p| p.held_arcs.len())
            .sum(),
        dual_frequency,
    }
}

/// The output solution of each epoch with its ambiguity segment (see
/// [`segment::output_segments`]): the one pass; with both, the forward pass's when it carries
/// the smoother's solutions (`smoothed`; a fix that the backward pass's float solution puts
/// beyond 4σ, or where the halves' disagreement passes [`consistency::HALVES_REFUTE`], is
/// demoted to the smoothed float, and float covariances are scaled by that disagreement),
/// else the two combined.
pub(super) fn merge_passes(
    fw: Option<&PassOutput>,
    bw: Option<&PassOutput>,
    smoothed: bool,
) -> Vec<Option<(EpochSol, u32)>> {
    let merged: Vec<Option<EpochSol>> = match (fw, bw) {
        (Some(f), Some(b)) if smoothed => {
            let scale = consistency::halves_disagreement(&f.sols, &b.sols);
            f.sols
                .iter()
                .zip(&b.sols)
                .zip(scale)
                .map(|((a, b), k)| {
                    let mut c = combine::checked(a.as_ref()?, b.as_ref());
                    if c.quality == Quality::Fixed && k > consistency::HALVES_REFUTE {
                        c = combine::as_float(&c);
                    }
                    if c.quality != Quality::Fixed {
                        c.cov *= k;
                    }
                    Some(c)
                })
                .collect()
        }
        (Some(f), Some(b)) => {
            let fc = combine::confirmed_segments(&f.sols, &b.sols);
            let bc = combine::confirmed_segments(&b.sols, &f.sols);
            let sure = |s: &Option<EpochSol>, c: &std::collections::BTreeSet<u32>| {
                s.as_ref().is_some_and(|s| c.contains(&s.segment))
            };
            let scale = consistency::disagreement(&f.sols, &b.sols);
            f.sols
                .iter()
                .zip(&b.sols)
                .zip(scale)
                .map(|((x, y), k)| {
                    let mut c =
                        combine::combine(x.as_ref(), y.as_ref(), (sure(x, &fc), sure(y, &bc)))?;
                    if c.quality != Quality::Fixed {
                        c.cov *= k;
                    }
                    Some(c)
                })
                .collect()
        }
        (Some(f), None) => f.sols.clone(),
        (None, Some(b)) => b.sols.clone(),
        (None, None) => Vec::new(),
    };
    let segments_of = |p: &PassOutput| -> Vec<Option<(u32, Quality)>> {
        p.sols
            .iter()
            .map(|s| s.as_ref().map(|s| (s.segment, s.quality)))
            .collect()
    };
    let pass_segments: Vec<Vec<Option<(u32, Quality)>>> =
        [fw, bw].into_iter().flatten().map(segments_of).collect();
    let passes: Vec<&[Option<(u32, Quality)>]> =
        pass_segments.iter().map(|p| p.as_slice()).collect();
    let quality: Vec<Option<Quality>> = merged
        .iter()
        .map(|s| s.as_ref().map(|s| s.quality))
        .collect();
    let segments = segment::output_segments(&passes, &quality);
    merged
        .into_iter()
        .zip(segments)
        .map(|(s, id)| s.map(|s| (s, id.unwrap_or(0))))
        .collect()
}

/// What [`output_epochs`] makes of the merged solutions.
pub(super) struct OutputEpochs {
    /// The trajectory's epochs.
    pub(super) epochs: Vec<TrajectoryEpoch>,
    /// Rover epochs without a solution, with why.
    pub(super) unsolved: Vec<(Epoch, String)>,
    /// Float epochs whose fix a check refused, with which.
    pub(super) refusals: Vec<(Epoch, Refusal)>,
}

/// The trajectory epochs of the merged solutions (the rover's ARP or marker, `opts.refer`,
/// at the true reception times, with the antenna and static sigmas added), the rover
/// epochs without a solution with why, and the float epochs whose fix a check refused.
pub(super) fn output_epochs(
    merged: Vec<Option<(EpochSol, u32)>>,
    inputs: &PassInputs,
    opts: &PpkOptions,
    antenna_sigma: (f64, f64),
    base_arp: &Ecef,
) -> OutputEpochs {
    let mut epochs = Vec::with_capacity(inputs.rover_times.len());
    let mut unsolved = Vec::new();
    let mut refusals = Vec::new();
    for (i, s) in merged.into_iter().enumerate() {
        match s {
            Some((s, segment)) => {
                // Rover marker = antenna reference point − header offset.
                let pos = match opts.refer {
                    Reference::Arp => s.pos,
                    Reference::Marker => Ecef(s.pos.0 - arp_offset(&inputs.rover_header, &s.pos)),
                };
                // The position belongs to the true reception time: the receiver's time tag
                // minus its clock offset (as RTKLIB reports it). A moving rover at 60 m/s
                // moves 6 cm in a millisecond of clock offset.
                if let (Quality::Float, Some(why)) = (s.quality, s.refused) {
                    refusals.push((s.time, why));
                }
                let mut time = s.time;
                if let Ok((_, clock)) = &inputs.starts[i] {
                    time -= hifitime::Duration::from_seconds(*clock);
                }
                epochs.push(TrajectoryEpoch {
                    time,
                    pos,
                    cov: s.cov + systematic(&pos, antenna_sigma) + static_cov(&pos, base_arp, opts),
                    vel: None,
                    quality: s.quality,
                    nsat: s.nsat,
                    ratio: s.ratio,
                    age: s.age,
                    segment,
                });
            }
            None => {
                let why = if inputs.matched[i].is_none() {
                    format!(
                        "no base epoch within {} s with phase of the processed systems",
                        opts.max_age
                    )
                } else if let Err(why) = &inputs.starts[i] {
                    format!("no single-point solution: {why}")
                } else {
                    "fewer than two satellites common to rover and base above the mask".to_string()
                };
                unsolved.push((inputs.rover_times[i], why));
            }
        }
    }
    OutputEpochs {
        epochs,
        unsolved,
        refusals,
    }
}

/// The passes' separation per epoch and their resets, in time order.
pub(super) fn diagnostics(
    fw: Option<&PassOutput>,
    bw: Option<&PassOutput>,
    rover_times: &[Epoch],
) -> PassDiagnostics {
    let separation = match (fw, bw) {
        (Some(f), Some(b)) => f
            .sols
            .iter()
            .zip(&b.sols)
            .filter_map(|(a, b)| Some((a.as_ref()?, b.as_ref()?)))
            .map(|(a, b)| output::Separation {
                time: a.time,
                d: a.pos.0 - b.pos.0,
                both_fixed: a.quality == Quality::Fixed && b.quality == Quality::Fixed,
            })
            .collect(),
        _ => Vec::new(),
    };
    let resets = |p: Option<&PassOutput>| -> Vec<(hifitime::Epoch, u32)> {
        let mut v: Vec<(hifitime::Epoch, u32)> = p
            .map(|p| p.resets.iter().map(|&(i, n)| (rover_times[i], n)).collect())
            .unwrap_or_default();
        v.sort_by_key(|a| a.0);
        v
    };
    PassDiagnostics {
        separation,
        forward_resets: resets(fw),
        backward_resets: resets(bw),
    }
}
