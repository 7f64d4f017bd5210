#![deny(missing_docs)]
//! GNSS/INS (issue 68): an IMU's angle and velocity increments carried forward into position,
//! velocity and attitude, and — in the steps that follow — combined with ppkat's own GNSS.
//!
//! - [`earth`]: normal gravity and the Earth's rotation, the models the mechanisation and
//!   the simulator share.
//! - [`attitude`]: roll, pitch and heading of the body (x forward, y right, z down) against
//!   the local north-east-down frame, and that frame in ECEF.
//! - [`imu`]: one IMU output interval ([`imu::ImuSample`]: Δθ and Δv in the body frame).
//! - [`spec`]: what an IMU's data sheet says (random walks, bias instability) as presets per
//!   grade or a file of one's own.
//! - [`inverse`]: what an ideal IMU measures along a known motion (simulator and tests).
//! - [`mech`]: strapdown mechanisation in ECEF ([`mech::NavState`], [`mech::propagate`]).
//! - [`errstate`]: the 15 error states (position, velocity, attitude, gyro and accelerometer
//!   biases) and their transition over an interval.
//! - [`filter`]: the error-state Kalman filter forward, with GNSS position updates through
//!   the lever arm, a land vehicle's no-side-slip constraint, the IMU's noise raised from
//!   the innovations, and checkpoints for the smoother.
//! - [`smoother`]: Rauch–Tung–Striebel over the checkpoints.
//! - [`loose`]: loosely coupled runs: IMU forward with GNSS positions, then smoothed.
//! - [`crossval`]: the smoothed σ inside GNSS gaps checked in trial gaps cut where the GNSS
//!   is continuous.
//! - [`align`]: roll, pitch and gyro biases from a still stretch; heading from the course.
//! - [`rtklib_imu`]: the RTKLIB-style raw IMU CSV and its time-tag file.
//! - [`job`]: a whole loosely coupled run from files, as `ppkat ins` makes it.
//! - [`gnss_pos`]: GNSS positions and velocities from a `.pos`, and the velocities' latency.
//!
//! Units inside: metres, seconds, radians; GPST epochs. Degrees and data-sheet units only at
//! the edges, named in every field that holds them.

pub mod align;
pub mod attitude;
pub mod crossval;
pub mod earth;
mod error;
pub mod errstate;
pub mod filter;
pub mod gnss_pos;
pub mod imu;
pub mod inverse;
pub mod job;
pub mod loose;
pub mod mech;
pub mod output;
pub mod plain_imu;
pub mod report;
pub mod rtklib_imu;
pub mod smoother;
pub mod spec;
pub mod tight;

pub use error::{Error, Result};
