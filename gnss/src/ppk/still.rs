//! Where the rover stood still: a walker at a point, a drone before take-off, a car at a
//! light. The carrier phase says so to millimetres: between two consecutive epochs, each
//! satellite's phase change less the change of its range from a fixed point and of its clock
//! is the rover's displacement along the line of sight plus the receiver clock's change
//! (time-differenced carrier phase); a robust least-squares fit of displacement and clock
//! change over the satellites that did not slip gives the displacement. Where it is within
//! [`STILL_M`] the filter holds the position from one epoch to the next (with the sway of a
//! hand-held pole as its process noise) instead of starting it afresh from the code
//! solution, so the code of the whole stand averages into one position and every arc that
//! starts during it meets a position known from the arcs before.
//!
//! What enters: the rover's times, measurements, satellite views, start positions and arc
//! breaks. What leaves: per epoch, whether the rover stood still since the epoch before.

use super::geometry::SatView;
use super::obs::{SatMeas, NF};
use super::slip::Slips;
use crate::frame::Ecef;
use crate::orbit::C;
use hifitime::Epoch;
use nalgebra::{Matrix4, Vector3, Vector4};

/// Largest displacement between two epochs (horizontal, vertical; metres per second of
/// interval) taken for standing still: a hand-held pole sways by millimetres a second,
/// walking starts at centimetres.
pub const STILL_M: (f64, f64) = (0.02, 0.03);
/// The displacement's own noise between two epochs however close (horizontal, vertical, m):
/// at 10 Hz the rate above would ask for 2 mm, below what the phase tells.
const STILL_FLOOR_M: (f64, f64) = (0.01, 0.015);
/// Fewest satellites the displacement is fitted from.
const MIN_SATS: usize = 5;
/// Residual beyond which a satellite is dropped from the fit (m): the phase between two
/// epochs is good to millimetres, a slip is a decimetre or more (a half cycle 9.5 cm), and
/// the fit of a few satellites spreads it over the others.
const RESIDUAL_FLOOR: f64 = 0.03;
/// Largest interval between the two epochs, seconds.
const MAX_INTERVAL_S: f64 = 2.0;

/// One satellite's time-differenced phase: line of sight (unit, receiver → satellite) and
/// the phase change less the modelled range and satellite clock change, metres.
struct Row {
    e: Vector3<f64>,
    y: f64,
}

/// The rows of two consecutive epochs seen from `at`: each satellite and slot with phase at
/// both, no arc break at the second and an orbit at both.
fn rows(
    prev: (&[SatMeas], &[Option<SatView>]),
    cur: (&[SatMeas], &[Option<SatView>]),
    breaks: &Slips,
    at: &Ecef,
) -> Vec<Row> {
    let mut out = Vec::new();
    for (m, v) in cur.0.iter().zip(cur.1) {
        let Some(k) = prev.0.iter().position(|h| h.sv == m.sv) else {
            continue;
        };
        let (h, Some(vh), Some(v)) = (&prev.0[k], prev.1[k], v) else {
            continue;
        };
        let (rho1, e) = v.range(&at.0);
        let (rho0, _) = vh.range(&at.0);
        let model = rho1 - rho0 - C * (v.clock - vh.clock);
        for f in 0..NF {
            let broken = breaks.get(&m.sv).is_some_and(|c| c[f].is_some());
            if broken || m.lli[f] & 1 != 0 || !(m.l[f].is_finite() && h.l[f].is_finite()) {
                continue;
            }
            let y = m.wavelength(f) * (m.l[f] - h.l[f]) - model;
            out.push(Row { e, y });
        }
    }
    out
}

/// Displacement and clock change fitted to `rows` (but `skip`), None when singular.
fn fit(rows: &[Row], skip: Option<usize>) -> Option<Vector4<f64>> {
    let mut n = Matrix4::zeros();
    let mut b = Vector4::zeros();
    for (k, r) in rows.iter().enumerate() {
        if Some(k) == skip {
            continue;
        }
        let a = Vector4::new(-r.e.x, -r.e.y, -r.e.z, 1.0);
        n += a * a.transpose();
        b += a * r.y;
    }
    n.try_inverse().map(|ni| ni * b)
}

/// The residual of row `r` against a fit `x`.
fn residual(r: &Row, x: &Vector4<f64>) -> f64 {
    r.y - Vector4::new(-r.e.x, -r.e.y, -r.e.z, 1.0).dot(x)
}

/// The displacement (ECEF, m) fitted to `rows` with the clock change, dropping while one
/// stands out by [`RESIDUAL_FLOOR`] the row whose residual against the fit of the others is
/// largest (with a few satellites a slip spreads over the fit of all, and the largest
/// residual of that fit may be a good one); None with fewer than [`MIN_SATS`] rows left or
/// a singular fit.
fn displacement(mut rows: Vec<Row>) -> Option<Vector3<f64>> {
    loop {
        if rows.len() < MIN_SATS {
            return None;
        }
        let all = fit(&rows, None)?;
        if rows
            .iter()
            .all(|r| residual(r, &all).abs() <= RESIDUAL_FLOOR)
        {
            return Some(Vector3::new(all[0], all[1], all[2]));
        }
        let (worst, _) = (0..rows.len())
            .filter_map(|k| Some((k, residual(&rows[k], &fit(&rows, Some(k))?).abs())))
            .max_by(|a, b| a.1.total_cmp(&b.1))?;
        rows.swap_remove(worst);
    }
}

/// Per rover epoch, whether the rover stood still since the epoch before (false at the first
/// epoch, across gaps and where the phase cannot tell).
pub(super) fn stood_still(
    times: &[Epoch],
    meas: &[Vec<SatMeas>],
    views: &[Vec<Option<SatView>>],
    starts: &[Result<(Ecef, f64), String>],
    breaks: &[Slips],
) -> Vec<bool> {
    let mut out = vec![false; times.len()];
    for i in 1..times.len().min(meas.len()).min(views.len()) {
        let dt = (times[i] - times[i - 1]).to_seconds();
        let Ok((at, _)) = &starts[i] else {
            continue;
        };
        if !(dt > 0.0 && dt <= MAX_INTERVAL_S) {
            continue;
        }
        let empty = Slips::new();
        let r = rows(
            (&meas[i - 1], &views[i - 1]),
            (&meas[i], &views[i]),
            breaks.get(i).unwrap_or(&empty),
            at,
        );
        let Some(d) = displacement(r) else {
            continue;
        };
        let g = at.to_geodetic();
        let enu = crate::frame::enu_rotation(&g) * d;
        let horizontal = (enu.x * enu.x + enu.y * enu.y).sqrt();
        out[i] = horizontal <= (STILL_M.0 * dt).max(STILL_FLOOR_M.0)
            && enu.z.abs() <= (STILL_M.1 * dt).max(STILL_FLOOR_M.1);
    }
    out
}

/// Epochs the rover stood still at (since the epoch before) and the stretches of them.
pub fn stretches(still: &[bool]) -> (usize, usize) {
    let epochs = still.iter().filter(|s| **s).count();
    let stretches = still.windows(2).filter(|w| w[1] && !w[0]).count()
        + usize::from(still.first() == Some(&true));
    (epochs, stretches)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A displacement of 1 cm east and 3 cm up with a clock jump, seen by eight satellites,
    /// one of which slipped a cycle: the fit finds it to millimetres and drops the slip.
    #[test]
    fn the_displacement_is_fitted_past_a_slip() {
        let truth = Vector3::new(0.01, -0.004, 0.03);
        let dirs = [
            (0.3, 0.2),
            (1.2, 0.5),
            (2.0, 0.9),
            (3.1, 0.3),
            (4.0, 1.1),
            (4.9, 0.6),
            (5.7, 0.25),
            (0.7, 1.4),
        ];
        let rows: Vec<Row> = dirs
            .iter()
            .enumerate()
            .map(|(k, &(az, el)): (usize, &(f64, f64))| {
                let e = Vector3::new(el.cos() * az.sin(), el.cos() * az.cos(), el.sin());
                let slip = if k == 3 { 0.19 } else { 0.0 };
                Row {
                    e,
                    y: -e.dot(&truth) + 1234.5 + slip + 0.001 * ((k as f64) * 1.7).sin(),
                }
            })
            .collect();
        let d = displacement(rows).unwrap();
        // a millimetre of noise on each, through the geometry of seven
        assert!((d - truth).norm() < 0.005, "{d}");
    }
}
