//! The error-state Kalman filter forward: the IMU's increments, less the estimated biases,
//! carry the nominal state ([`crate::mech`]) and the error covariance ([`crate::errstate`]);
//! an update estimates the error, which is put into the nominal state at once (the error
//! state is zero again after every update). At each checkpoint the filter keeps what the
//! smoother ([`crate::smoother`]) needs: the state before and after the update, both
//! covariances, and the transition since the previous checkpoint.

use crate::errstate::{idx, skew, transition, Interval, Mat, Vec15, N};
use crate::imu::ImuSample;
use crate::mech::{propagate, NavState};
use crate::spec::ImuSpec;
use common::frame::Ecef;
use nalgebra::{Matrix3, Rotation3, SMatrix, Vector3};

/// The nominal state: navigation and the sensor biases estimated so far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Position, velocity and attitude.
    pub nav: NavState,
    /// Gyro bias, rad/s.
    pub gyro_bias: Vector3<f64>,
    /// Accelerometer bias, m/s².
    pub accel_bias: Vector3<f64>,
}

impl Estimate {
    /// This estimate corrected by an error state.
    pub fn corrected(&self, d: &Vec15) -> Estimate {
        let part = |i: usize| Vector3::new(d[i], d[i + 1], d[i + 2]);
        let mut e = *self;
        e.nav.position = Ecef(e.nav.position.0 + part(idx::POS));
        e.nav.velocity += part(idx::VEL);
        e.nav.attitude = Rotation3::new(part(idx::ATT)) * e.nav.attitude;
        e.gyro_bias += part(idx::BG);
        e.accel_bias += part(idx::BA);
        e
    }

    /// The error state that takes `base` to this estimate (this ⊖ base).
    pub fn minus(&self, base: &Estimate) -> Vec15 {
        let mut d = Vec15::zeros();
        let mut put = |i: usize, v: Vector3<f64>| d.fixed_rows_mut::<3>(i).copy_from(&v);
        put(idx::POS, self.nav.position.0 - base.nav.position.0);
        put(idx::VEL, self.nav.velocity - base.nav.velocity);
        put(
            idx::ATT,
            (self.nav.attitude * base.nav.attitude.inverse()).scaled_axis(),
        );
        put(idx::BG, self.gyro_bias - base.gyro_bias);
        put(idx::BA, self.accel_bias - base.accel_bias);
        d
    }
}

/// What the filter kept at one checkpoint.
#[derive(Clone, Debug)]
pub struct Checkpoint {
    /// Before this checkpoint's update (as propagated).
    pub prior: Estimate,
    /// Its covariance.
    pub prior_cov: Mat,
    /// After the update (the prior again when there was none).
    pub post: Estimate,
    /// Its covariance.
    pub post_cov: Mat,
    /// Transition of the error state from the previous checkpoint's posterior to this prior.
    pub phi: Mat,
    /// Whether a measurement updated the state here.
    pub updated: bool,
}

/// One GNSS antenna position, ECEF, with its covariance (m²).
#[derive(Clone, Copy, Debug)]
pub struct PositionFix {
    /// Antenna position.
    pub position: Ecef,
    /// Covariance, m².
    pub cov: Matrix3<f64>,
}

/// The forward filter.
pub struct Forward<'a> {
    spec: &'a ImuSpec,
    est: Estimate,
    p: Mat,
    phi: Mat,
    prior: Option<(Estimate, Mat)>,
}

impl<'a> Forward<'a> {
    /// A filter from an initial estimate and its error covariance.
    pub fn new(est: Estimate, p0: Mat, spec: &'a ImuSpec) -> Self {
        Forward {
            spec,
            est,
            p: p0,
            phi: Mat::identity(),
            prior: None,
        }
    }

    /// The current estimate.
    pub fn estimate(&self) -> &Estimate {
        &self.est
    }

    /// The current error covariance.
    pub fn covariance(&self) -> &Mat {
        &self.p
    }

    /// Carry the state over one IMU interval.
    pub fn predict(&mut self, s: &ImuSample) {
        let corrected = ImuSample {
            dtheta: s.dtheta - self.est.gyro_bias * s.dt,
            dv: s.dv - self.est.accel_bias * s.dt,
            ..*s
        };
        let c = *self.est.nav.attitude.matrix();
        let force = c * corrected.dv / s.dt.max(1e-9);
        let geo = self.est.nav.position.to_geodetic();
        let iv = Interval {
            attitude: c,
            force,
            position: self.est.nav.position.0,
            gravity: crate::earth::normal_gravity(&geo),
            dt: s.dt,
        };
        let (phi, q) = transition(&iv, self.spec);
        self.est.nav = propagate(&self.est.nav, &corrected);
        self.p = phi * self.p * phi.transpose() + q;
        self.phi = phi * self.phi;
    }

    /// Update with the GNSS antenna at `lever` (body frame, m) from the IMU; returns the
    /// normalised innovation squared (χ²(3) when the σ are right).
    pub fn update_position(&mut self, fix: &PositionFix, lever: &Vector3<f64>) -> f64 {
        self.prior.get_or_insert((self.est, self.p));
        let c = *self.est.nav.attitude.matrix();
        let arm = c * lever;
        let predicted = self.est.nav.position.0 + arm;
        let z = fix.position.0 - predicted;
        let mut h = SMatrix::<f64, 3, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, idx::POS)
            .copy_from(&Matrix3::identity());
        h.fixed_view_mut::<3, 3>(0, idx::ATT)
            .copy_from(&(-skew(&arm)));
        let s = h * self.p * h.transpose() + fix.cov;
        let Some(si) = s.try_inverse() else {
            return f64::NAN;
        };
        let k = self.p * h.transpose() * si;
        let dx = k * z;
        let ikh = Mat::identity() - k * h;
        self.p = ikh * self.p * ikh.transpose() + k * fix.cov * k.transpose();
        self.est = self.est.corrected(&dx);
        (z.transpose() * si * z)[(0, 0)]
    }

    /// Keep a checkpoint here (for the smoother) and start the next transition.
    pub fn checkpoint(&mut self) -> Checkpoint {
        let (prior, prior_cov) = self.prior.take().unwrap_or((self.est, self.p));
        let cp = Checkpoint {
            updated: prior != self.est,
            prior,
            prior_cov,
            post: self.est,
            post_cov: self.p,
            phi: self.phi,
        };
        self.phi = Mat::identity();
        cp
    }
}
