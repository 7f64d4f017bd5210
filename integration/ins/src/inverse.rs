//! What an ideal IMU measures along a known motion: the inverse of the mechanisation, for the
//! simulator and the tests. At each instant the angular rate against inertial space
//! ω_ib = ω_eb + Cᵀ·ω_ie (ω_eb from the attitude's derivative, a central difference of 0.1 ms
//! between rotation matrices) and the specific force f = Cᵀ·(a + 2·ω_ie×v − g) in the body
//! frame; each interval's increments are their integrals by Simpson's rule on
//! [`SUBSTEPS`] sub-intervals.
//!
//! [`Circling`] is a motion for the simulator and the tests.
//!
//! What enters: a [`Motion`] (position, velocity, acceleration and attitude at any time), a
//! start, a rate and a count. What leaves: [`ImuSample`]s without any error.

use crate::attitude::{ned_to_ecef, Euler};
use crate::earth::{earth_rate, gravity_ecef};
use crate::imu::ImuSample;
use common::frame::{enu_rotation, Ecef, Geodetic};
use hifitime::{Duration, Epoch};
use nalgebra::{Matrix3, Vector3};

/// Sub-intervals of Simpson's rule per IMU interval (even).
pub const SUBSTEPS: usize = 4;
/// Half-width of the attitude's central difference, s.
const H: f64 = 1e-4;

/// Where a body is, how it moves and how it is turned at one instant.
#[derive(Clone, Copy, Debug)]
pub struct Kinematics {
    /// Position, ECEF.
    pub position: Ecef,
    /// Velocity relative to the Earth in ECEF, m/s.
    pub velocity: Vector3<f64>,
    /// Acceleration relative to the Earth in ECEF, m/s².
    pub acceleration: Vector3<f64>,
    /// Body → ECEF rotation.
    pub attitude: Matrix3<f64>,
}

/// A motion known at every instant, `t` seconds from its start.
pub trait Motion {
    /// The kinematics at `t`.
    fn at(&self, t: f64) -> Kinematics;
}

/// Angular rate against inertial space and specific force in the body frame at `t`.
fn rates(m: &dyn Motion, t: f64) -> (Vector3<f64>, Vector3<f64>) {
    let k = m.at(t);
    let c = k.attitude;
    let d = (m.at(t + H).attitude - m.at(t - H).attitude) / (2.0 * H);
    let s = c.transpose() * d;
    let omega_eb = Vector3::new(
        0.5 * (s[(2, 1)] - s[(1, 2)]),
        0.5 * (s[(0, 2)] - s[(2, 0)]),
        0.5 * (s[(1, 0)] - s[(0, 1)]),
    );
    let w = earth_rate();
    let omega_ib = omega_eb + c.transpose() * w;
    let f =
        c.transpose() * (k.acceleration + 2.0 * w.cross(&k.velocity) - gravity_ecef(&k.position));
    (omega_ib, f)
}

/// `n` ideal samples at `rate_hz` from `start` (the first interval ends 1/rate after it).
pub fn ideal_imu(m: &dyn Motion, start: Epoch, rate_hz: f64, n: usize) -> Vec<ImuSample> {
    let dt = 1.0 / rate_hz;
    let step = dt / SUBSTEPS as f64;
    let mut prev = rates(m, 0.0);
    (0..n)
        .map(|k| {
            let t0 = k as f64 * dt;
            let (mut th, mut dv) = (prev.0, prev.1);
            for j in 1..=SUBSTEPS {
                let r = rates(m, t0 + j as f64 * step);
                let w = if j == SUBSTEPS {
                    1.0
                } else if j % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                th += w * r.0;
                dv += w * r.1;
                if j == SUBSTEPS {
                    prev = r;
                }
            }
            ImuSample {
                time: start + Duration::from_seconds(t0 + dt),
                dt,
                dtheta: th * step / 3.0,
                dv: dv * step / 3.0,
            }
        })
        .collect()
}

/// An aircraft circling left at constant speed and climb rate from `origin` (where it is at
/// the start, flying east), banked as a coordinated turn asks: the motion an IMU's heading is
/// best seen on (the turn's acceleration never stops).
#[derive(Clone, Copy, Debug)]
pub struct Circling {
    /// Where the circle starts.
    pub origin: Geodetic,
    /// Radius, m.
    pub radius: f64,
    /// Speed along the circle, m/s.
    pub speed: f64,
    /// Climb rate, m/s.
    pub climb: f64,
}

impl Motion for Circling {
    fn at(&self, t: f64) -> Kinematics {
        let (r, v) = (self.radius, self.speed);
        let w = v / r;
        let (s, c) = (w * t).sin_cos();
        // East, north, up.
        let p = Vector3::new(r * s, r * (1.0 - c), self.climb * t);
        let vel = Vector3::new(v * c, v * s, self.climb);
        let acc = Vector3::new(-v * w * s, v * w * c, 0.0);
        let to_ecef = enu_rotation(&self.origin).transpose();
        let position = Ecef(self.origin.to_ecef().0 + to_ecef * p);
        let e = Euler {
            roll: -(v * w / 9.81).atan(),
            pitch: (self.climb / v).atan(),
            heading: vel.x.atan2(vel.y),
        };
        Kinematics {
            position,
            velocity: to_ecef * vel,
            acceleration: to_ecef * acc,
            attitude: ned_to_ecef(&position.to_geodetic()) * e.to_matrix(),
        }
    }
}
