//! IMU data as the mechanisation reads it: per output interval, the angle increment Δθ
//! (rad) and the velocity increment Δv (m/s) integrated by the sensor in its body frame
//! (x forward, y right, z down) over (time − dt, time]. Rates (ω, f) convert by dt.

use hifitime::Epoch;
use nalgebra::Vector3;

/// One IMU output interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// End of the interval, GPST.
    pub time: Epoch,
    /// Length of the interval, s.
    pub dt: f64,
    /// Angle increment (integral of the angular rate against inertial space), body, rad.
    pub dtheta: Vector3<f64>,
    /// Velocity increment (integral of the specific force), body, m/s.
    pub dv: Vector3<f64>,
}

impl ImuSample {
    /// A sample from mean rates over the interval: ω (rad/s) and specific force f (m/s²).
    pub fn from_rates(time: Epoch, dt: f64, omega: Vector3<f64>, force: Vector3<f64>) -> Self {
        ImuSample {
            time,
            dt,
            dtheta: omega * dt,
            dv: force * dt,
        }
    }
}

/// Samples in the IMU's own axes turned into the body frame by the mounting rotation `c`
/// (IMU axes → body axes).
pub fn to_body(samples: &mut [ImuSample], c: &nalgebra::Matrix3<f64>) {
    for s in samples {
        s.dtheta = c * s.dtheta;
        s.dv = c * s.dv;
    }
}
