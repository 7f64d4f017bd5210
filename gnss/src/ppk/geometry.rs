//! The modelled single-difference range of a satellite between rover and base: satellite
//! positions at each receiver's transmission time, Earth rotation during signal travel,
//! satellite clocks and the troposphere.

use super::obs::SatMeas;
use crate::frame::{az_el, rotate_to_reception, Ecef, Geodetic};
use crate::model::{niell, zenith_delays};
use crate::orbit::{Orbits, C};
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;

/// One receiver's epoch as the filter reads it: its time, measurements, and each
/// satellite's view (aligned with `meas`; None without an orbit at that time).
#[derive(Clone, Copy, Debug)]
pub struct ReceiverEpoch<'a> {
    /// Receiver time tag (GPST).
    pub time: Epoch,
    /// The satellites' measurements.
    pub meas: &'a [SatMeas],
    /// The satellites at their transmission times, aligned with `meas`.
    pub views: &'a [Option<SatView>],
    /// For a base epoch interpolated to this time (`ppk::interp`), the seconds to the nearer
    /// real one (0 otherwise).
    pub age: f64,
}

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
        let t = t0 - Duration::from_seconds(first.clock);
        let s = orbits.sat(m.sv, t, b'1')?;
        Some(SatView {
            pos: s.pos.0,
            clock: s.clock,
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

/// Slant troposphere (m) at a receiver for an elevation on day of year `doy`: Saastamoinen
/// zenith delays of a standard atmosphere, each with its Niell mapping function; 0 outside
/// −500 m … 20 km of height or below the horizon.
pub fn tropo(g: &Geodetic, el: f64, doy: f64) -> f64 {
    if g.h < -500.0 || g.h > 2.0e4 || el <= 0.0 {
        return 0.0;
    }
    let (zhd, zwd) = zenith_delays(g);
    let (mh, mw) = niell(g, el, doy);
    zhd * mh + zwd * mw
}

/// Niell wet mapping function (the partial derivative of a slant delay by the zenith wet
/// delay) at a receiver.
pub fn wet_mapping(g: &Geodetic, el: f64, doy: f64) -> f64 {
    niell(g, el, doy).1
}

/// Day of year (1 on 1 January, fractional) of an epoch, for the mapping functions.
pub fn day_of_year(t: Epoch) -> f64 {
    let (y, _, _, _, _, _, _) = t.to_gregorian_utc();
    let start = Epoch::from_gregorian_utc_at_midnight(y, 1, 1);
    1.0 + (t - start).to_unit(hifitime::Unit::Day)
}
