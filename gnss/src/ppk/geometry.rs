//! The modelled single-difference range of a satellite between rover and base: satellite
//! positions at each receiver's transmission time, Earth rotation during signal travel,
//! satellite clocks and the troposphere.

use super::obs::SatMeas;
use crate::frame::{az_el, rotate_to_reception, Ecef, Geodetic};
use crate::model::troposphere;
use crate::orbit::{Orbits, C};
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;

/// A satellite as seen by one receiver at its epoch.
#[derive(Clone, Copy, Debug)]
pub struct SatView {
    /// Satellite position at transmission, ECEF at transmission time.
    pub pos: Vector3<f64>,
    /// Satellite clock (s), relativistic term included.
    pub clock: f64,
}

impl SatView {
    /// Satellite seen from `t_rx` with pseudorange `p` (approximate if NaN).
    pub fn at(orbits: &Orbits, m: &SatMeas, t_rx: Epoch) -> Option<SatView> {
        let p =
            m.p.iter()
                .copied()
                .find(|v| v.is_finite())
                .unwrap_or(0.075 * C);
        let t0 = t_rx - Duration::from_seconds(p / C);
        let first = orbits.sat(m.sv, t0, b'1')?;
        let t = t0 - Duration::from_seconds(first.pv.clock);
        let s = orbits.sat(m.sv, t, b'1')?;
        Some(SatView {
            pos: s.pv.pos.0,
            clock: s.pv.clock,
        })
    }

    /// Geometric range with Earth rotation, unit vector receiver→satellite.
    pub fn range(&self, rx: &Vector3<f64>) -> (f64, Vector3<f64>) {
        let sp = rotate_to_reception(&self.pos, (self.pos - rx).norm() / C);
        let d = sp - rx;
        let r = d.norm();
        (r, d / r)
    }

    /// Azimuth and elevation from a receiver.
    pub fn az_el(&self, rx: &Ecef, g: &Geodetic) -> (f64, f64) {
        az_el(rx, g, &Ecef(self.pos))
    }
}

/// Slant troposphere at a receiver for an elevation.
pub fn tropo(g: &Geodetic, el: f64) -> f64 {
    troposphere(g, el)
}
