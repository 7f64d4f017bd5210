//! Strapdown mechanisation in ECEF: the body's attitude, velocity and position carried from
//! one IMU output to the next with the Earth's rotation and normal gravity
//! (Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*,
//! 2nd ed., §5.2, with the first-order refinements of §5.5 that matter at 100–200 Hz).
//!
//! Per interval of length τ with increments Δθ, Δv:
//! - attitude: C(k+1) = Rz(−ω_e·τ) · C(k) · exp([Δθ×]) (the body's rotation, then the
//!   frame's);
//! - specific force in ECEF: Rz(−ω_e·τ/2) · C(k) · (Δv + ½·Δθ×Δv) (the body turning during
//!   the interval, and the frame turning under it);
//! - velocity: + gravity and Coriolis (−2·ω_ie×v) at mid-interval, times τ;
//! - position: the trapezoid of the two velocities.
//!
//! What enters: a [`NavState`] and an [`ImuSample`]. What leaves: the next [`NavState`].

use crate::attitude::{ned_to_ecef, Euler};
use crate::earth::{earth_rate, gravity_ecef};
use crate::imu::ImuSample;
use common::frame::{Ecef, Geodetic, OMEGA_E};
use hifitime::Epoch;
use nalgebra::{Rotation3, Vector3};

/// Position, velocity and attitude of the body at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavState {
    /// GPST.
    pub time: Epoch,
    /// Position of the IMU's centre, ECEF.
    pub position: Ecef,
    /// Velocity relative to the Earth, expressed in ECEF, m/s.
    pub velocity: Vector3<f64>,
    /// Body → ECEF rotation.
    pub attitude: Rotation3<f64>,
}

impl NavState {
    /// A state from local quantities: velocity north, east, down (m/s) and roll, pitch,
    /// heading against the NED frame at `position`.
    pub fn from_local(time: Epoch, position: Ecef, velocity_ned: Vector3<f64>, e: &Euler) -> Self {
        let cne = ned_to_ecef(&position.to_geodetic());
        NavState {
            time,
            position,
            velocity: cne * velocity_ned,
            attitude: Rotation3::from_matrix_unchecked(cne * e.to_matrix()),
        }
    }

    /// Geodetic coordinates of the position.
    pub fn geodetic(&self) -> Geodetic {
        self.position.to_geodetic()
    }

    /// Velocity north, east, down, m/s.
    pub fn velocity_ned(&self) -> Vector3<f64> {
        ned_to_ecef(&self.geodetic()).transpose() * self.velocity
    }

    /// Roll, pitch and heading against the NED frame at the position.
    pub fn euler(&self) -> Euler {
        let cne = ned_to_ecef(&self.geodetic());
        Euler::from_matrix(&(cne.transpose() * self.attitude.matrix()))
    }
}

/// The state one IMU interval later.
pub fn propagate(s: &NavState, m: &ImuSample) -> NavState {
    let tau = m.dt;
    let z = Vector3::z_axis();
    let frame_half = Rotation3::from_axis_angle(&z, -0.5 * OMEGA_E * tau);
    let attitude = frame_half * frame_half * s.attitude * Rotation3::new(m.dtheta);
    let dv_body = m.dv + 0.5 * m.dtheta.cross(&m.dv);
    let dv_force = frame_half * (s.attitude * dv_body);
    let w = earth_rate();
    let mid = Ecef(s.position.0 + 0.5 * tau * s.velocity);
    let g = gravity_ecef(&mid);
    let v_mid = s.velocity + 0.5 * (dv_force + (g - 2.0 * w.cross(&s.velocity)) * tau);
    let velocity = s.velocity + dv_force + (g - 2.0 * w.cross(&v_mid)) * tau;
    let position = Ecef(s.position.0 + 0.5 * tau * (s.velocity + velocity));
    NavState {
        time: m.time,
        position,
        velocity,
        attitude: renormalised(attitude),
    }
}

/// The nearest rotation to `r` (rounding would otherwise let it drift from orthonormal over
/// hundreds of thousands of steps).
fn renormalised(r: Rotation3<f64>) -> Rotation3<f64> {
    let m = r.matrix();
    let x = m.column(0).into_owned();
    let y = m.column(1).into_owned();
    let err = 0.5 * x.dot(&y);
    let xo = x - err * y;
    let yo = y - err * x;
    let zo = xo.cross(&yo);
    Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[
        xo.normalize(),
        yo.normalize(),
        zo.normalize(),
    ]))
}
