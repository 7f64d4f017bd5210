//! GNSS epochs for the INS from an RTKLIB-compatible `.pos`: positions and covariances as
//! `gnss::solution::read_pos` reads them, and the antenna velocity where the file has RTKLIB's
//! velocity columns (`vn(m/s) ve(m/s) vu(m/s)`, found by name in the column header).
//!
//! A receiver's velocity may be late against its position (a u-blox NAV-PVT log's was 0.125 s
//! on the shared car drive): [`velocity_latency`] measures it from the file itself, as the lag
//! at which the velocities best match the positions' own differences.

use crate::error::{Error, Result};
use common::frame::{enu_rotation, Ecef};
use gnss::solution::{read_pos as read_records, Quality};
use hifitime::{Duration, Epoch};
use nalgebra::{Matrix3, Vector3};
use std::path::Path;

/// One GNSS epoch.
#[derive(Clone, Copy, Debug)]
pub struct GnssEpoch {
    /// GPST.
    pub time: Epoch,
    /// Antenna position.
    pub position: Ecef,
    /// Its covariance as the file gives it, m².
    pub cov: Matrix3<f64>,
    /// RTKLIB's Q.
    pub quality: Quality,
    /// Antenna velocity (ECEF, m/s) where the file has one.
    pub velocity: Option<Vector3<f64>>,
}

/// The epochs of a `.pos`, with velocities when its header names them.
pub fn read_pos(path: &Path) -> Result<Vec<GnssEpoch>> {
    let recs = read_records(path).map_err(|e| Error::Input {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let text = std::fs::read_to_string(path).map_err(|cause| Error::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    let header = text
        .lines()
        .rfind(|l| l.starts_with('%') && l.contains("GPST"));
    let column =
        |name: &str| header.and_then(|h| h.split_whitespace().position(|t| t.starts_with(name)));
    let cols = (column("vn("), column("ve("), column("vu("));
    let rows = text
        .lines()
        .filter(|l| !l.starts_with('%') && !l.trim().is_empty());
    Ok(recs
        .iter()
        .zip(rows)
        .map(|(r, line)| {
            let f: Vec<&str> = line.split_whitespace().collect();
            let num = |i: Option<usize>| f.get(i?)?.parse::<f64>().ok();
            let velocity = match (num(cols.0), num(cols.1), num(cols.2)) {
                (Some(n), Some(e), Some(u)) => {
                    let rot = enu_rotation(&r.pos.to_geodetic()).transpose();
                    Some(rot * Vector3::new(e, n, u))
                }
                _ => None,
            };
            GnssEpoch {
                time: r.time,
                position: r.pos,
                cov: r.cov,
                quality: r.quality,
                velocity,
            }
        })
        .collect())
}

/// How late (s) the velocities are against the positions: the lag in [−0.5, 0.5] s, on a
/// grid of 1/64 s, at which the velocities, read that much later, best match the positions'
/// differences between consecutive epochs (at most 1 s apart). None with fewer than 20
/// such pairs.
pub fn velocity_latency(epochs: &[GnssEpoch]) -> Option<f64> {
    let pairs: Vec<(Epoch, Vector3<f64>)> = epochs
        .windows(2)
        .filter_map(|w| {
            let dt = (w[1].time - w[0].time).to_seconds();
            (dt > 0.0 && dt <= 1.0).then(|| {
                let mid = w[0].time + Duration::from_seconds(0.5 * dt);
                (mid, (w[1].position.0 - w[0].position.0) / dt)
            })
        })
        .collect();
    if pairs.len() < 20 {
        return None;
    }
    let at = |t: Epoch| velocity_at(epochs, t);
    let cost = |lag: f64| {
        let (mut s, mut n) = (0.0, 0usize);
        for (t, v) in &pairs {
            if let Some(w) = at(*t + Duration::from_seconds(lag)) {
                s += (w - v).norm_squared();
                n += 1;
            }
        }
        (n >= 20).then(|| s / n as f64)
    };
    (-32..=32)
        .filter_map(|k| {
            let lag = f64::from(k) / 64.0;
            cost(lag).map(|c| (lag, c))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(lag, _)| lag)
}

/// The velocity column interpolated at `t` between the epochs around it (at most 1 s apart).
pub fn velocity_at(epochs: &[GnssEpoch], t: Epoch) -> Option<Vector3<f64>> {
    let k = epochs.partition_point(|e| e.time <= t);
    let (a, b) = (epochs.get(k.checked_sub(1)?)?, epochs.get(k)?);
    let span = (b.time - a.time).to_seconds();
    let x = (t - a.time).to_seconds() / span;
    (span <= 1.0).then(|| Some(a.velocity? * (1.0 - x) + b.velocity? * x))?
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Epochs along a curve at 4 Hz whose velocities are written `late` seconds late: the
    /// latency found is that lag, to the grid.
    #[test]
    fn a_late_velocity_is_found_late() {
        let t0 = Epoch::from_gregorian_utc_at_midnight(2026, 1, 1);
        let origin = common::frame::Geodetic::from_degrees(40.0, -105.0, 1600.0);
        let rot = enu_rotation(&origin).transpose();
        let late = 0.140625;
        let track = |t: f64| Vector3::new(30.0 * (0.1 * t).sin(), 20.0 * (0.07 * t).cos(), 0.0);
        let speed = |t: f64| Vector3::new(3.0 * (0.1 * t).cos(), -1.4 * (0.07 * t).sin(), 0.0);
        let epochs: Vec<GnssEpoch> = (0..400)
            .map(|k| {
                let t = k as f64 * 0.25;
                GnssEpoch {
                    time: t0 + Duration::from_seconds(t),
                    position: Ecef(origin.to_ecef().0 + rot * track(t)),
                    cov: Matrix3::identity() * 1e-4,
                    quality: Quality::Fixed,
                    velocity: Some(rot * speed(t - late)),
                }
            })
            .collect();
        let lag = velocity_latency(&epochs).unwrap();
        assert!((lag - late).abs() < 1.0 / 64.0, "{lag}");
        let on_time: Vec<GnssEpoch> = epochs
            .iter()
            .enumerate()
            .map(|(k, e)| GnssEpoch {
                velocity: Some(rot * speed(k as f64 * 0.25)),
                ..*e
            })
            .collect();
        assert_eq!(velocity_latency(&on_time), Some(0.0));
    }
}
