#![deny(missing_docs)]
//! # exposure — from exposure times to camera stations
//!
//! Camera exposure times (RINEX events, DJI MRK, CSV) → antenna position
//! interpolated on the trajectory → lever arm rotated by the camera attitude → projection
//! centres with covariance and quality, and exports for photogrammetry software.
//!
//! Enters: [`events::ExposureEvent`]s (GPST, from [`events`]), a `gnss::trajectory::Trajectory`
//! (ECEF, GPST; from `gnss::ppk::process` in memory or a `.pos` read back) and
//! [`ExposureOptions`] (lever arm, [`attitude::AttitudeTable`], delay, gap limit). Leaves: an
//! [`ExposureResult`] — [`CameraStation`]s (antenna and centre in ECEF, ECEF covariance in m²,
//! quality, ambiguity segment, rotation camera → ENU) and the exposures refused — which
//! [`export`] writes and [`photos`] geotags; [`names`] names the exposures beforehand (photos,
//! a names file, DJI numbers, `E0001`). [`leverarm`] solves a lever arm
//! from tape measurements. Uses `gnss` (trajectory, frames, time) and `photo` (rotations,
//! lever arm) and `georef` (systems, heights, trajectory files); used by the adjustment, the
//! importers, the tie points (EXIF), the simulator and `integration`'s pipelines and demo.
//!
//! Lever-arm convention (as the whole project): X_A = X_S + R·(u, v, w), (u, v, w) the antenna
//! phase centre in the camera frame, R camera → local ENU.

pub mod attitude;
pub mod events;
pub mod exif_io;
pub mod export;
pub mod leverarm;
pub mod names;
pub mod photos;
mod station;
pub mod xmp;

pub use station::{AttitudeSource, CameraStation};

use attitude::{from_yaw_pitch_roll, AttitudeTable};
use events::ExposureEvent;
use gnss::frame::{enu_rotation, Ecef};
use gnss::solution::Quality;
use gnss::trajectory::{InterpError, Trajectory};
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;

/// Options of the exposure stage.
#[derive(Clone, Debug, Default)]
pub struct ExposureOptions {
    /// Antenna phase centre in the camera frame (u, v, w), metres.
    pub lever_arm: Option<photo::lever::LeverArm>,
    /// Camera attitude over time (None: the trajectory heading is used).
    pub attitude: Option<AttitudeTable>,
    /// Camera latency added to every event time, milliseconds.
    pub delay_ms: f64,
    /// Longest trajectory gap to interpolate across, seconds (None: 2.5 intervals).
    pub max_gap: Option<f64>,
}

/// An exposure that got no station, and why.
#[derive(Clone, Debug)]
pub struct Refused {
    /// Exposure name.
    pub id: String,
    /// Exposure time, GPST.
    pub time: Epoch,
    /// Why it got no station.
    pub why: String,
}

/// Result of the exposure stage.
#[derive(Clone, Debug, Default)]
pub struct ExposureResult {
    /// The camera stations, in time order.
    pub stations: Vec<CameraStation>,
    /// Exposures without a station, and why.
    pub refused: Vec<Refused>,
    /// Problems worth a look (sorting, time system, attitude fallback).
    pub warnings: Vec<String>,
    /// Facts a reader of the results should know (where the ambiguity segments came from).
    pub notes: Vec<String>,
}

/// Compute projection centres for events on a trajectory.
pub fn compute(
    mut events: Vec<ExposureEvent>,
    traj: &Trajectory,
    opts: &ExposureOptions,
) -> ExposureResult {
    let mut res = ExposureResult::default();
    res.notes.extend(traj.segments_from.note());
    let (unsorted, dups) = events::sort_and_dedup(&mut events);
    if unsorted {
        res.warnings
            .push("exposure times were not in time order: sorted".into());
    }
    for d in dups {
        res.refused.push(Refused {
            id: d.id,
            time: d.time,
            why: "duplicate time (same as the previous exposure)".into(),
        });
    }
    if let Some(shift) = events::utc_as_gpst_shift(&events, traj) {
        res.warnings.push(format!("the MRK positions match the trajectory {shift:.0} s later: the times look like UTC declared as GPST"));
    }
    let max_gap = opts.max_gap.unwrap_or(2.5 * traj.interval);
    let mut heading_flagged = 0;
    for e in events {
        let t = e.time + Duration::from_seconds(opts.delay_ms / 1000.0);
        let ip = match traj.interpolate(t, max_gap) {
            Ok(ip) => ip,
            Err(InterpError::Outside) => {
                res.refused.push(Refused {
                    id: e.id,
                    time: t,
                    why: "outside the trajectory".into(),
                });
                continue;
            }
            Err(InterpError::Gap(g)) => {
                res.refused.push(Refused {
                    id: e.id,
                    time: t,
                    why: format!("in a trajectory gap of {g:.1} s (limit {max_gap:.1} s)"),
                });
                continue;
            }
        };
        // An INS attitude comes with its σ: a photograph outside it (before the INS's
        // alignment, after its end) would take a heading-only attitude the adjustment cannot
        // weigh: refused, named.
        let ins = opts.attitude.as_ref().filter(|a| a.sigmas.is_some());
        if ins.is_some_and(|a| a.at(t).is_none()) {
            res.refused.push(Refused {
                id: e.id,
                time: t,
                why: "outside the INS trajectory (before its alignment or after its end): no attitude with σ".into(),
            });
            continue;
        }
        let mut flags = Vec::new();
        if ip.quality != Quality::Fixed {
            flags.push(format!("next to a {:?} epoch", ip.quality));
        }
        let g = ip.pos.to_geodetic();
        let enu_to_ecef = enu_rotation(&g).transpose();
        let (rotation, source) = match opts.attitude.as_ref().and_then(|a| a.at(t)) {
            Some(r) => (r, AttitudeSource::Table),
            None => {
                let v = enu_rotation(&g) * ip.vel;
                heading_flagged += 1;
                flags.push(
                    "attitude from the trajectory heading (pitch and roll taken as zero)".into(),
                );
                (
                    from_yaw_pitch_roll(v.x.atan2(v.y), 0.0, 0.0),
                    AttitudeSource::Heading,
                )
            }
        };
        let centre = if let Some(m) = &e.mrk {
            // DJI: the antenna → camera offset is given in north, east, up.
            Ecef(
                ip.pos.0
                    + enu_to_ecef * Vector3::new(m.offset_neu[1], m.offset_neu[0], m.offset_neu[2]),
            )
        } else if let Some(l) = opts.lever_arm {
            Ecef(ip.pos.0 - enu_to_ecef * l.offset(&rotation))
        } else {
            flags.push("no lever arm: the projection centre is the antenna".into());
            ip.pos
        };
        res.stations.push(CameraStation {
            id: e.id,
            time: t,
            antenna: ip.pos,
            velocity: ip.vel,
            centre,
            cov: ip.cov,
            quality: ip.quality,
            segment: ip.segment,
            rotation,
            attitude: source,
            rotation_sigma: opts.attitude.as_ref().and_then(|a| a.sigma_at(t)),
            flags,
        });
    }
    if heading_flagged > 0 && opts.attitude.is_some() {
        res.warnings.push(format!("{heading_flagged} exposures outside the attitude file: heading from the trajectory used"));
    } else if heading_flagged > 0 && opts.lever_arm.is_some() {
        res.warnings.push("no attitude given: the lever arm is rotated by the trajectory heading with zero pitch and roll (flagged on every station)".into());
    }
    res
}
