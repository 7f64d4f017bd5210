//! IMU errors as a data sheet describes them, put on ideal increments (`ins::inverse`): per
//! sample white noise (angle and velocity random walk: σ = ARW·√dt on Δθ, VRW·√dt on Δv), and
//! per axis a bias that is a turn-on constant plus a first-order Gauss–Markov process with
//! the bias instability as its σ and the spec's correlation time. The true biases are
//! returned beside the data, for the filters' tests (`ins::inverse::Circling` is a motion
//! to make them along).

use crate::rng::Rng;
use ins::imu::ImuSample;
use ins::spec::ImuSpec;
use nalgebra::Vector3;

/// The true sensor biases during one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrueBiases {
    /// Gyro bias, rad/s.
    pub gyro: Vector3<f64>,
    /// Accelerometer bias, m/s².
    pub accel: Vector3<f64>,
}

/// Three independent normal draws.
fn normal3(r: &mut Rng) -> Vector3<f64> {
    Vector3::new(r.normal(), r.normal(), r.normal())
}

/// A Gauss–Markov process per axis: its state, σ and correlation time.
struct Markov {
    x: Vector3<f64>,
    sigma: f64,
    tau: f64,
}

impl Markov {
    fn new(sigma: f64, tau: f64, r: &mut Rng) -> Markov {
        Markov {
            x: sigma * normal3(r),
            sigma,
            tau,
        }
    }
    /// One step of `dt`: the stationary process stays at σ.
    fn step(&mut self, dt: f64, r: &mut Rng) {
        let phi = (-dt / self.tau).exp();
        self.x = phi * self.x + self.sigma * (1.0 - phi * phi).sqrt() * normal3(r);
    }
}

/// `ideal` with the errors of `spec` drawn from `seed`: the data, and the true biases in
/// force during each sample.
pub fn corrupt(
    ideal: &[ImuSample],
    spec: &ImuSpec,
    seed: u64,
) -> (Vec<ImuSample>, Vec<TrueBiases>) {
    let root = Rng::new(seed);
    let (mut noise, mut drift) = (root.fork(1), root.fork(2));
    let mut turn_on = root.fork(3);
    let gyro_on = spec.gyro_turn_on * normal3(&mut turn_on);
    let accel_on = spec.accel_turn_on * normal3(&mut turn_on);
    let mut gyro = Markov::new(spec.gyro_bias, spec.bias_correlation, &mut drift);
    let mut accel = Markov::new(spec.accel_bias, spec.bias_correlation, &mut drift);
    let mut out = Vec::with_capacity(ideal.len());
    let mut truth = Vec::with_capacity(ideal.len());
    for s in ideal {
        gyro.step(s.dt, &mut drift);
        accel.step(s.dt, &mut drift);
        let b = TrueBiases {
            gyro: gyro_on + gyro.x,
            accel: accel_on + accel.x,
        };
        let sq = s.dt.sqrt();
        out.push(ImuSample {
            dtheta: s.dtheta + b.gyro * s.dt + spec.arw * sq * normal3(&mut noise),
            dv: s.dv + b.accel * s.dt + spec.vrw * sq * normal3(&mut noise),
            ..*s
        });
        truth.push(b);
    }
    (out, truth)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ins::spec::Grade;

    /// The noise per sample has the σ the random walks give; the biases stay at their σ and
    /// decorrelate over their correlation time; the same seed gives the same data.
    #[test]
    fn errors_have_the_figures_of_the_spec() {
        let spec = ImuSpec::preset(Grade::Mems);
        let t0 = hifitime::Epoch::from_gregorian_utc_at_midnight(2026, 1, 1);
        let dt = 0.01;
        let ideal: Vec<ImuSample> = (0..200_000)
            .map(|k| ImuSample {
                time: t0 + hifitime::Duration::from_seconds((k + 1) as f64 * dt),
                dt,
                dtheta: Vector3::zeros(),
                dv: Vector3::zeros(),
            })
            .collect();
        let (data, truth) = corrupt(&ideal, &spec, 5);
        let (again, _) = corrupt(&ideal, &spec, 5);
        assert_eq!(data, again);
        // White part: the data less the biases.
        let resid: Vec<f64> = data
            .iter()
            .zip(&truth)
            .map(|(d, b)| d.dtheta.x - b.gyro.x * dt)
            .collect();
        let sd = (resid.iter().map(|x| x * x).sum::<f64>() / resid.len() as f64).sqrt();
        let want = spec.arw * dt.sqrt();
        assert!((sd / want - 1.0).abs() < 0.02, "{sd} vs {want}");
        // The Gauss–Markov part (no turn-on bias here): each step's innovation has the σ
        // that keeps the process stationary at the bias instability.
        let gm_spec = ImuSpec {
            gyro_turn_on: 0.0,
            ..spec.clone()
        };
        let (_, truth) = corrupt(&ideal, &gm_spec, 6);
        let phi = (-dt / spec.bias_correlation).exp();
        let innov: Vec<f64> = truth
            .windows(2)
            .flat_map(|w| {
                let d = w[1].gyro - phi * w[0].gyro;
                [d.x, d.y, d.z]
            })
            .collect();
        let sd = (innov.iter().map(|x| x * x).sum::<f64>() / innov.len() as f64).sqrt();
        let want = spec.gyro_bias * (1.0 - phi * phi).sqrt();
        assert!((sd / want - 1.0).abs() < 0.02, "{sd} vs {want}");
        let level: f64 = truth.iter().map(|b| b.gyro.norm_squared()).sum::<f64>();
        let level = (level / (3 * truth.len()) as f64).sqrt();
        assert!(
            (level / spec.gyro_bias - 1.0).abs() < 0.5,
            "{level} vs {}",
            spec.gyro_bias
        );
    }
}
