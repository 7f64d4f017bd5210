//! Alignment without an initial attitude from the user: while the body stands still, its
//! accelerometers give roll and pitch (the specific force is gravity's reaction, straight
//! up) and its gyros give their own biases (the Earth's rate, 15 °/h at most, is below what
//! a MEMS or tactical gyro's bias is known to); once it moves, the course over ground gives
//! the heading of a vehicle that goes where its nose points. The σ that go with each are
//! the caller's to carry into the filter.

use crate::imu::ImuSample;
use nalgebra::Vector3;

/// What a still stretch of IMU data says.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Levelled {
    /// Roll, rad.
    pub roll: f64,
    /// Pitch, rad.
    pub pitch: f64,
    /// Mean angular rate (the gyro biases plus the Earth's rate), rad/s.
    pub gyro_bias: Vector3<f64>,
}

/// Roll, pitch and gyro biases from samples (body frame) taken standing still; None without
/// samples.
pub fn level(still: &[ImuSample]) -> Option<Levelled> {
    let t: f64 = still.iter().map(|s| s.dt).sum();
    if still.is_empty() || t <= 0.0 {
        return None;
    }
    let f = still.iter().map(|s| s.dv).sum::<Vector3<f64>>() / t;
    let w = still.iter().map(|s| s.dtheta).sum::<Vector3<f64>>() / t;
    Some(Levelled {
        roll: (-f.y).atan2(-f.z),
        pitch: f.x.atan2((f.y * f.y + f.z * f.z).sqrt()),
        gyro_bias: w,
    })
}

/// Heading (rad, from north towards east) of a velocity north, east.
pub fn course(north: f64, east: f64) -> f64 {
    east.atan2(north).rem_euclid(std::f64::consts::TAU)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Euler;

    /// A body rolled 3° and pitched −5° standing still reads gravity's reaction in its axes:
    /// levelling gives the angles back.
    #[test]
    fn levelling_gives_roll_and_pitch_back() {
        let e = Euler {
            roll: 3f64.to_radians(),
            pitch: -5f64.to_radians(),
            heading: 1.0,
        };
        let f_body = e.to_matrix().transpose() * Vector3::new(0.0, 0.0, -9.8);
        let t0 = hifitime::Epoch::from_gregorian_utc_at_midnight(2026, 1, 1);
        let s: Vec<ImuSample> = (0..100)
            .map(|_| ImuSample::from_rates(t0, 0.01, Vector3::new(1e-3, 0.0, 0.0), f_body))
            .collect();
        let l = level(&s).unwrap();
        assert!((l.roll - e.roll).abs() < 1e-12 && (l.pitch - e.pitch).abs() < 1e-12);
        assert!((l.gyro_bias.x - 1e-3).abs() < 1e-15);
        assert!((course(1.0, 1.0).to_degrees() - 45.0).abs() < 1e-12);
        assert!((course(-1.0, -1e-9).to_degrees() - 180.0).abs() < 1e-6);
    }
}
