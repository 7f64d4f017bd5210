//! The motion of `simulate --builtin ins`: a survey flight. The aircraft stands still, speeds
//! up east smoothly to its cruising speed and flies strips joined by 180° procedure turns
//! at 3 °/s, alternately left and right (a lawn-mower pattern), banked as a coordinated turn
//! asks. Every quantity is smooth: the speed and the turn rate rise and fall along raised
//! cosines, so the IMU sees no jumps in rate or specific force that its sampling would blur.
//!
//! The heading and speed are closed forms; the position is their integral, by Gauss–Legendre
//! quadrature from a table kept every second, exact to far below a millimetre.

use common::frame::{enu_rotation, Ecef, Geodetic};
use ins::attitude::{ned_to_ecef, Euler};
use ins::inverse::{Kinematics, Motion};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;

/// Standing still until, s.
const STILL: f64 = 30.0;
/// Speeding up for, s.
const SPEED_UP: f64 = 20.0;
/// Cruising speed, m/s.
const SPEED: f64 = 60.0;
/// The turn rate's rise and fall, s.
const RAMP: f64 = 5.0;
/// Turn rate between rise and fall, rad/s (3 °/s).
const RATE: f64 = PI / 60.0;
/// A turn's constant-rate part: rise and fall contribute half a ramp each to the 180°, s.
const PLATEAU: f64 = PI / RATE - RAMP;
/// Gauss–Legendre nodes and weights on [-1, 1] (five points).
const GL: [(f64, f64); 5] = [
    (0.0, 0.568_888_888_888_888_9),
    (-0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (-0.906_179_845_938_664, 0.236_926_885_056_189_1),
    (0.906_179_845_938_664, 0.236_926_885_056_189_1),
];
/// Gauss–Legendre panels per second of integration.
const PANELS: usize = 8;

/// A survey flight: still, speeding up east, then strips and turns (see the module's text).
pub struct Survey {
    origin: Geodetic,
    /// When each turn starts (s) and its sense (+1 right, −1 left).
    turns: Vec<(f64, f64)>,
    /// East and north displacement at each whole second.
    table: Vec<[f64; 2]>,
}

impl Survey {
    /// A flight of `span` seconds from `origin`, its turns starting at `turn_starts` (seconds),
    /// the first to the left.
    pub fn new(origin: Geodetic, span: f64, turn_starts: &[f64]) -> Survey {
        let mut s = Survey {
            origin,
            turns: turn_starts
                .iter()
                .enumerate()
                .map(|(k, &t)| (t, if k % 2 == 0 { -1.0 } else { 1.0 }))
                .collect(),
            table: vec![[0.0; 2]],
        };
        for k in 0..span.ceil() as usize + 1 {
            let d = s.integral(k as f64, k as f64 + 1.0);
            let last = s.table[k];
            s.table.push([last[0] + d[0], last[1] + d[1]]);
        }
        s
    }

    /// How long one turn lasts, s.
    pub fn turn_length() -> f64 {
        2.0 * RAMP + PLATEAU
    }

    /// Speed and its rate at `t`.
    fn speed(t: f64) -> (f64, f64) {
        let u = t - STILL;
        if u <= 0.0 {
            (0.0, 0.0)
        } else if u < SPEED_UP {
            let w = 2.0 * PI / SPEED_UP;
            (
                SPEED * (u / SPEED_UP - (w * u).sin() / (2.0 * PI)),
                SPEED / SPEED_UP * (1.0 - (w * u).cos()),
            )
        } else {
            (SPEED, 0.0)
        }
    }

    /// Heading (clockwise from north) and its rate at `t`.
    fn heading(&self, t: f64) -> (f64, f64) {
        let mut h = PI / 2.0;
        let mut rate = 0.0;
        for &(start, sense) in &self.turns {
            let (a, r) = turned(t - start);
            h += sense * a;
            rate += sense * r;
        }
        (h, rate)
    }

    /// Horizontal velocity (east, north) at `t`.
    fn velocity_en(&self, t: f64) -> [f64; 2] {
        let v = Self::speed(t).0;
        let (s, c) = self.heading(t).0.sin_cos();
        [v * s, v * c]
    }

    /// ∫ velocity from `a` to `b` (b − a ≤ 1 s).
    fn integral(&self, a: f64, b: f64) -> [f64; 2] {
        let mut sum = [0.0; 2];
        let h = (b - a) / PANELS as f64;
        for p in 0..PANELS {
            let mid = a + (p as f64 + 0.5) * h;
            for (x, w) in GL {
                let v = self.velocity_en(mid + 0.5 * h * x);
                sum[0] += w * 0.5 * h * v[0];
                sum[1] += w * 0.5 * h * v[1];
            }
        }
        sum
    }
}

/// Angle turned and turn rate `u` seconds after a turn's start, for a unit sense.
fn turned(u: f64) -> (f64, f64) {
    if u <= 0.0 {
        (0.0, 0.0)
    } else if u < RAMP {
        let x = PI * u / RAMP;
        (
            0.5 * RATE * (u - RAMP / PI * x.sin()),
            0.5 * RATE * (1.0 - x.cos()),
        )
    } else if u < RAMP + PLATEAU {
        (RATE * (0.5 * RAMP + u - RAMP), RATE)
    } else if u < 2.0 * RAMP + PLATEAU {
        let w = u - RAMP - PLATEAU;
        let x = PI * w / RAMP;
        (
            RATE * (0.5 * RAMP + PLATEAU) + 0.5 * RATE * (w + RAMP / PI * x.sin()),
            0.5 * RATE * (1.0 + x.cos()),
        )
    } else {
        (PI, 0.0)
    }
}

impl Motion for Survey {
    fn at(&self, t: f64) -> Kinematics {
        let k = (t.max(0.0).floor() as usize).min(self.table.len() - 1);
        let d = self.integral(k as f64, t);
        let e = self.table[k][0] + d[0];
        let n = self.table[k][1] + d[1];
        let (v, dv) = Self::speed(t);
        let (h, dh) = self.heading(t);
        let (s, c) = h.sin_cos();
        let to_ecef: Matrix3<f64> = enu_rotation(&self.origin).transpose();
        let position = Ecef(self.origin.to_ecef().0 + to_ecef * Vector3::new(e, n, 0.0));
        let acc = Vector3::new(dv * s + v * dh * c, dv * c - v * dh * s, 0.0);
        let att = Euler {
            roll: (v * dh / 9.81).atan(),
            pitch: 0.0,
            heading: h,
        };
        Kinematics {
            position,
            velocity: to_ecef * Vector3::new(v * s, v * c, 0.0),
            acceleration: to_ecef * acc,
            attitude: ned_to_ecef(&position.to_geodetic()) * att.to_matrix(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flight() -> Survey {
        Survey::new(
            Geodetic::from_degrees(47.3, 8.5, 800.0),
            600.0,
            &[170.0, 350.0],
        )
    }

    #[test]
    fn a_turn_is_half_a_circle_and_the_next_turns_back() {
        let m = flight();
        let len = Survey::turn_length();
        assert!((m.heading(170.0 + len).0 - (PI / 2.0 - PI)).abs() < 1e-12);
        assert!((m.heading(350.0 + len).0 - PI / 2.0).abs() < 1e-12);
        // Mid-turn the rate is 3 °/s and the bank that of a coordinated turn (17.76° left).
        let k = m.at(200.0);
        let e =
            Euler::from_matrix(&(ned_to_ecef(&k.position.to_geodetic()).transpose() * k.attitude));
        assert!(
            (e.roll.to_degrees() + 17.757).abs() < 0.001,
            "{}",
            e.roll.to_degrees()
        );
    }

    #[test]
    fn position_velocity_and_acceleration_agree() {
        let m = flight();
        for t in [10.0, 35.3, 49.9, 172.4, 176.0, 200.5, 236.0, 420.0] {
            let h = 1e-3;
            let (a, b, k) = (m.at(t - h), m.at(t + h), m.at(t));
            let v = (b.position.0 - a.position.0) / (2.0 * h);
            let acc = (b.velocity - a.velocity) / (2.0 * h);
            assert!(
                (v - k.velocity).norm() < 1e-5,
                "{t}: {}",
                (v - k.velocity).norm()
            );
            assert!((acc - k.acceleration).norm() < 1e-5, "{t}");
        }
        // The integral is continuous across the table's seconds.
        let (a, b) = (m.at(300.0 - 1e-9), m.at(300.0));
        assert!((a.position.0 - b.position.0).norm() < 1e-6);
    }
}
