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
use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};

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
}

/// One GNSS antenna position, ECEF, with its covariance (m²).
#[derive(Clone, Copy, Debug)]
pub struct PositionFix {
    /// Antenna position.
    pub position: Ecef,
    /// Covariance, m².
    pub cov: Matrix3<f64>,
}

/// How many updates the innovations' variance factor averages over (exponentially).
pub const NIS_MEMORY: f64 = 20.0;
/// Largest factor on the IMU's white noise the innovations may ask for.
pub const MAX_NOISE_SCALE: f64 = 10.0;

/// The forward filter.
///
/// The IMU's noise is what its data sheet says until the innovations say otherwise: a car's
/// engine or a drone's rotors shake a MEMS chip far beyond its random walks (the real car
/// drive's innovations were 20 times their variance). The filter keeps an exponential mean
/// of the normalised innovations (over about [`NIS_MEMORY`] updates) and scales the random
/// walks up by 10 % at each update while that mean is above 1.5, back down by 1 % while it
/// is below 0.7, never below the data sheet nor above [`MAX_NOISE_SCALE`] times it: its σ
/// follow the data, not only the model.
pub struct Forward<'a> {
    spec: &'a ImuSpec,
    scaled: ImuSpec,
    noise_scale: f64,
    mean_nis: f64,
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
            scaled: spec.clone(),
            noise_scale: 1.0,
            mean_nis: 1.0,
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
        let (phi, q) = transition(&iv, &self.scaled);
        self.est.nav = propagate(&self.est.nav, &corrected);
        self.p = phi * self.p * phi.transpose() + q;
        self.phi = phi * self.phi;
    }

    /// Update with the GNSS antenna at `lever` (body frame, m) from the IMU, measured
    /// `offset` seconds after the state's time (at most half an IMU interval: the state is
    /// carried there along its velocity); returns the normalised innovation squared (χ²(3)
    /// when the σ are right).
    pub fn update_position(&mut self, fix: &PositionFix, lever: &Vector3<f64>, offset: f64) -> f64 {
        self.prior.get_or_insert((self.est, self.p));
        let c = *self.est.nav.attitude.matrix();
        let arm = c * lever;
        let predicted = self.est.nav.position.0 + offset * self.est.nav.velocity + arm;
        let z = fix.position.0 - predicted;
        let mut h = SMatrix::<f64, 3, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, idx::POS)
            .copy_from(&Matrix3::identity());
        h.fixed_view_mut::<3, 3>(0, idx::ATT)
            .copy_from(&(-skew(&arm)));
        let nis = self.update(&h, &z, &fix.cov);
        self.adapt(nis / 3.0);
        nis
    }

    /// An update of any number of rows (`h`: rows × 15, innovations `z`, their covariance
    /// `r`), for the double-differenced phases; the normalised innovation squared, None (and
    /// nothing changed) when the innovation's covariance cannot be inverted.
    pub fn update_rows(
        &mut self,
        h: &nalgebra::DMatrix<f64>,
        z: &nalgebra::DVector<f64>,
        r: &nalgebra::DMatrix<f64>,
    ) -> Option<f64> {
        let p = nalgebra::DMatrix::from_column_slice(N, N, self.p.as_slice());
        let s = h * &p * h.transpose() + r;
        let si = s.try_inverse()?;
        self.prior.get_or_insert((self.est, self.p));
        let k = &p * h.transpose() * &si;
        let ikh = nalgebra::DMatrix::identity(N, N) - &k * h;
        let pn = &ikh * &p * ikh.transpose() + &k * r * k.transpose();
        self.p = Mat::from_column_slice(pn.as_slice());
        let dx = &k * z;
        self.est = self
            .est
            .corrected(&crate::errstate::Vec15::from_column_slice(dx.as_slice()));
        let nis = (z.transpose() * &si * z)[(0, 0)];
        self.adapt(nis / z.len() as f64);
        Some(nis)
    }

    /// An update of `R` rows: the state corrected, the covariance in Joseph's form; the
    /// normalised innovation squared (NaN, and nothing changed, when the innovation's
    /// covariance cannot be inverted).
    fn update<const R: usize>(
        &mut self,
        h: &SMatrix<f64, R, N>,
        z: &SVector<f64, R>,
        r: &SMatrix<f64, R, R>,
    ) -> f64 {
        let s = h * self.p * h.transpose() + r;
        let Some(si) = s.try_inverse() else {
            return f64::NAN;
        };
        let k = self.p * h.transpose() * si;
        let ikh = Mat::identity() - k * h;
        self.p = ikh * self.p * ikh.transpose() + k * r * k.transpose();
        self.est = self.est.corrected(&(k * z));
        (z.transpose() * si * z)[(0, 0)]
    }

    /// A land vehicle's non-holonomic constraint: its velocity across and perpendicular to
    /// its nose (body y and z) is zero within `sigma` (m/s): it neither slides nor jumps.
    /// The body frame is taken as the vehicle's (the IMU near its rear axle, aligned).
    pub fn update_no_side_slip(&mut self, sigma: f64) {
        self.prior.get_or_insert((self.est, self.p));
        let ct = self.est.nav.attitude.matrix().transpose();
        let v = self.est.nav.velocity;
        let vb = ct * v;
        let z = nalgebra::Vector2::new(-vb.y, -vb.z);
        let mut h = SMatrix::<f64, 2, N>::zeros();
        let dv = ct;
        let da = ct * skew(&v);
        for r in 0..2 {
            for c in 0..3 {
                h[(r, idx::VEL + c)] = dv[(r + 1, c)];
                h[(r, idx::ATT + c)] = da[(r + 1, c)];
            }
        }
        self.update(&h, &z, &(nalgebra::Matrix2::identity() * sigma * sigma));
    }

    /// Standing still: the velocity is zero within `sigma_v` (m/s), and the mean measured
    /// angular rate `omega` over the last `dt` seconds is the Earth's rate in the body frame
    /// plus the gyro bias, within the angle random walk over `dt` (a zero-velocity and a
    /// zero-angular-rate update: the gyro biases, and with them the heading's drift, seen
    /// at every stop).
    pub fn update_still(&mut self, omega: &Vector3<f64>, dt: f64, sigma_v: f64) {
        if dt <= 0.0 {
            return;
        }
        self.prior.get_or_insert((self.est, self.p));
        let ct = self.est.nav.attitude.matrix().transpose();
        let earth = ct * crate::earth::earth_rate();
        let mut z = SVector::<f64, 6>::zeros();
        z.fixed_rows_mut::<3>(0)
            .copy_from(&(-self.est.nav.velocity));
        z.fixed_rows_mut::<3>(3)
            .copy_from(&(omega - earth - self.est.gyro_bias));
        let mut h = SMatrix::<f64, 6, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, idx::VEL)
            .copy_from(&Matrix3::identity());
        h.fixed_view_mut::<3, 3>(3, idx::BG)
            .copy_from(&Matrix3::identity());
        let mut r = SMatrix::<f64, 6, 6>::zeros();
        let sw = self.scaled.arw * self.scaled.arw / dt;
        for k in 0..3 {
            r[(k, k)] = sigma_v * sigma_v;
            r[(k + 3, k + 3)] = sw;
        }
        self.update(&h, &z, &r);
    }

    /// The factor on the IMU's random walks the innovations asked for so far.
    pub fn noise_scale(&self) -> f64 {
        self.noise_scale
    }

    /// Follow the innovations' variance factor `r` (see the type's text).
    fn adapt(&mut self, r: f64) {
        if !r.is_finite() {
            return;
        }
        self.mean_nis += (r.min(100.0) - self.mean_nis) / NIS_MEMORY;
        if self.mean_nis > 1.5 {
            self.noise_scale = (self.noise_scale * 1.1).min(MAX_NOISE_SCALE);
        } else if self.mean_nis < 0.7 {
            self.noise_scale = (self.noise_scale / 1.01).max(1.0);
        }
        self.scaled.arw = self.spec.arw * self.noise_scale;
        self.scaled.vrw = self.spec.vrw * self.noise_scale;
    }

    /// Keep a checkpoint here (for the smoother) and start the next transition.
    pub fn checkpoint(&mut self) -> Checkpoint {
        let (prior, prior_cov) = self.prior.take().unwrap_or((self.est, self.p));
        let cp = Checkpoint {
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
