//! The mechanisation against motions known exactly: what an ideal IMU measures along them
//! (`ins::inverse`) mechanised from the true start must stay on the truth, and a known
//! sensor bias must grow the textbook error with the right sign.

use common::frame::{enu_rotation, Geodetic};
use hifitime::Epoch;
use ins::attitude::{ned_to_ecef, Euler};
use ins::imu::ImuSample;
use ins::inverse::{ideal_imu, Circling, Kinematics, Motion};
use ins::mech::{propagate, NavState};
use nalgebra::{Matrix3, Rotation3, Vector3};

fn start() -> Epoch {
    Epoch::from_gregorian_utc_at_midnight(2026, 6, 1)
}

fn origin() -> Geodetic {
    Geodetic {
        lat: 47.3f64.to_radians(),
        lon: 8.5f64.to_radians(),
        h: 500.0,
    }
}

/// A body standing still, level, its nose 30° east of north.
struct Still;

impl Motion for Still {
    fn at(&self, _t: f64) -> Kinematics {
        let g = origin();
        let e = Euler {
            roll: 0.0,
            pitch: 0.0,
            heading: 30f64.to_radians(),
        };
        Kinematics {
            position: g.to_ecef(),
            velocity: Vector3::zeros(),
            acceleration: Vector3::zeros(),
            attitude: ned_to_ecef(&g) * e.to_matrix(),
        }
    }
}

/// An aircraft circling left at 60 m/s on a 1.5 km radius, climbing 2 m/s, banked as a
/// coordinated turn asks.
fn circle() -> Circling {
    Circling {
        origin: origin(),
        radius: 1500.0,
        speed: 60.0,
        climb: 2.0,
    }
}

fn true_state(m: &dyn Motion) -> NavState {
    let k = m.at(0.0);
    NavState {
        time: start(),
        position: k.position,
        velocity: k.velocity,
        attitude: Rotation3::from_matrix_unchecked(k.attitude),
    }
}

/// Mechanise `samples` from the truth at 0; the worst position (m), velocity (m/s) and
/// attitude (rad) errors against `m` at every sample.
fn run(m: &dyn Motion, samples: &[ImuSample]) -> (f64, f64, f64, NavState) {
    let mut s = true_state(m);
    let (mut dp, mut dv, mut da) = (0.0f64, 0.0f64, 0.0f64);
    for x in samples {
        s = propagate(&s, x);
        let t = (x.time - start()).to_seconds();
        let k = m.at(t);
        dp = dp.max((s.position.0 - k.position.0).norm());
        dv = dv.max((s.velocity - k.velocity).norm());
        let d: Matrix3<f64> = k.attitude.transpose() * s.attitude.matrix();
        da = da.max(Rotation3::from_matrix_unchecked(d).angle());
    }
    (dp, dv, da, s)
}

/// Ten minutes standing still at 100 Hz: the ideal IMU's data keep the position within a
/// millimetre (the Earth's rotation and gravity are what the data carry; a sign or a
/// missing term in either would run off by metres: 1e-5 m/s² alone gives 1.8 m).
#[test]
fn a_perfect_imu_standing_still_stays_put() {
    let samples = ideal_imu(&Still, start(), 100.0, 60_000);
    let (dp, dv, da, s) = run(&Still, &samples);
    eprintln!("still 600 s: position {dp:.2e} m, velocity {dv:.2e} m/s, attitude {da:.2e} rad");
    assert!(dp < 1e-3 && dv < 1e-5 && da < 1e-7, "{dp} {dv} {da}");
    let e = s.euler();
    assert!((e.heading.to_degrees() - 30.0).abs() < 1e-5 && e.roll.abs() < 1e-7);
}

/// Five minutes of a banked, climbing turn at 200 Hz: within a millimetre after the whole
/// circle and a half (measured 0.13 mm, 0.8 µm/s, 3·10⁻⁸ rad: the coning and sculling left
/// at 200 Hz, and Simpson's rule on the data; without the ½·Δθ×Δv term it is 1.8 m).
#[test]
fn a_perfect_imu_circling_follows_the_truth() {
    let samples = ideal_imu(&circle(), start(), 200.0, 60_000);
    let (dp, dv, da, _) = run(&circle(), &samples);
    eprintln!("circle 300 s: position {dp:.2e} m, velocity {dv:.2e} m/s, attitude {da:.2e} rad");
    assert!(dp < 1e-3 && dv < 1e-5 && da < 1e-7, "{dp} {dv} {da}");
}

/// An accelerometer bias along the nose (heading 30°) of 1 mg moves the position ½·b·t²
/// forward in a minute (Schuler's 84 minutes barely bend it yet); a gyro bias about the
/// down axis of 10 °/h turns the heading by b·t to the right.
#[test]
fn sensor_biases_grow_the_textbook_errors_with_their_signs() {
    let ideal = ideal_imu(&Still, start(), 100.0, 6_000);
    let b = 1e-3 * 9.806_65;
    let biased: Vec<ImuSample> = ideal
        .iter()
        .map(|x| ImuSample {
            dv: x.dv + Vector3::new(b, 0.0, 0.0) * x.dt,
            ..*x
        })
        .collect();
    let (_, _, _, s) = run(&Still, &biased);
    let enu = enu_rotation(&origin()) * (s.position.0 - Still.at(0.0).position.0);
    let along = 0.5 * b * 60.0 * 60.0;
    let nose = Vector3::new(30f64.to_radians().sin(), 30f64.to_radians().cos(), 0.0);
    assert!(
        (enu.dot(&nose) - along).abs() < 0.01 * along,
        "{enu} vs {along}"
    );
    let g = 10.0 * std::f64::consts::PI / 180.0 / 3600.0;
    let turning: Vec<ImuSample> = ideal
        .iter()
        .map(|x| ImuSample {
            dtheta: x.dtheta + Vector3::new(0.0, 0.0, g) * x.dt,
            ..*x
        })
        .collect();
    let (_, _, _, s) = run(&Still, &turning);
    let turned = s.euler().heading.to_degrees() - 30.0;
    assert!((turned - 10.0 / 60.0).abs() < 1e-3, "{turned}");
}
