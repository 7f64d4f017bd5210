//! The error state of the INS and how it grows between updates (Groves, §14.2.3, in ECEF,
//! with the attitude error as a small rotation of the estimate into the truth):
//!
//! δx = [δr, δv, φ, δb_g, δb_a] (15): position and velocity errors (truth − estimate, ECEF),
//! the rotation φ with C_true = (I + [φ×])·C_est, and the gyro and accelerometer bias errors
//! (true bias − estimated). With f the specific force in ECEF and G the gravity gradient:
//!
//! - δṙ = δv
//! - δv̇ = −[f×]·φ − 2[ω_ie×]·δv + G·δr − C·δb_a − C·n_a
//! - φ̇ = −[ω_ie×]·φ − C·δb_g − C·n_g
//! - δḃ = w: a random walk with the strength q = 2σ²/τ of the sensor's Gauss–Markov
//!   instability. Not the Gauss–Markov's own −δb/τ: the bias is a turn-on constant plus that
//!   process, and a model whose error decays on its own forgets the constant part (a MEMS
//!   IMU's 360 °/h turn-on under a 300 s correlation time made the attitude NEES 7).
//!
//! discretised over an interval τ as Φ = I + F·τ + ½(F·τ)² and Q = ½(Φ·Qc·Φᵀ + Qc)·τ.

use crate::spec::ImuSpec;
use nalgebra::{Matrix3, SMatrix, Vector3};

/// Size of the error state.
pub const N: usize = 15;
/// A matrix over the error state.
pub type Mat = SMatrix<f64, N, N>;
/// A vector over the error state.
pub type Vec15 = SMatrix<f64, N, 1>;

/// Offsets of the blocks in the error state.
pub mod idx {
    /// Position.
    pub const POS: usize = 0;
    /// Velocity.
    pub const VEL: usize = 3;
    /// Attitude.
    pub const ATT: usize = 6;
    /// Gyro bias.
    pub const BG: usize = 9;
    /// Accelerometer bias.
    pub const BA: usize = 12;
}

/// The skew-symmetric matrix of a vector: [v×]·x = v × x.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// What the error model needs of one interval: the body → ECEF rotation, the specific force
/// in ECEF (m/s²), the position (m, ECEF) and gravity's magnitude there.
#[derive(Clone, Copy, Debug)]
pub struct Interval {
    /// Body → ECEF rotation at the interval.
    pub attitude: Matrix3<f64>,
    /// Specific force in ECEF, m/s².
    pub force: Vector3<f64>,
    /// Position, ECEF metres.
    pub position: Vector3<f64>,
    /// Gravity's magnitude, m/s².
    pub gravity: f64,
    /// Length, s.
    pub dt: f64,
}

/// The transition Φ and process noise Q of one interval.
pub fn transition(iv: &Interval, spec: &ImuSpec) -> (Mat, Mat) {
    use idx::*;
    let c = iv.attitude;
    let w = skew(&crate::earth::earth_rate());
    let r = iv.position.norm();
    let u = iv.position / r;
    let grad = 2.0 * iv.gravity / r * u * u.transpose();
    let mut f = Mat::zeros();
    f.fixed_view_mut::<3, 3>(POS, VEL)
        .copy_from(&Matrix3::identity());
    f.fixed_view_mut::<3, 3>(VEL, POS).copy_from(&grad);
    f.fixed_view_mut::<3, 3>(VEL, VEL).copy_from(&(-2.0 * w));
    f.fixed_view_mut::<3, 3>(VEL, ATT)
        .copy_from(&(-skew(&iv.force)));
    f.fixed_view_mut::<3, 3>(VEL, BA).copy_from(&(-c));
    f.fixed_view_mut::<3, 3>(ATT, ATT).copy_from(&(-w));
    f.fixed_view_mut::<3, 3>(ATT, BG).copy_from(&(-c));
    let tau = spec.bias_correlation;
    let ft = f * iv.dt;
    let phi = Mat::identity() + ft + 0.5 * ft * ft;
    let mut qc = Mat::zeros();
    for i in 0..3 {
        qc[(VEL + i, VEL + i)] = spec.vrw * spec.vrw;
        qc[(ATT + i, ATT + i)] = spec.arw * spec.arw;
        qc[(BG + i, BG + i)] = 2.0 * spec.gyro_bias * spec.gyro_bias / tau;
        qc[(BA + i, BA + i)] = 2.0 * spec.accel_bias * spec.accel_bias / tau;
    }
    let q = 0.5 * (phi * qc * phi.transpose() + qc) * iv.dt;
    (phi, q)
}
