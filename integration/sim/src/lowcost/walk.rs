//! A walk along a river trail, as a surveyor carries a low-cost rover: a minute standing
//! still, then walking at about 1.3 m/s along a meandering path with a pause halfway, the
//! antenna bobbing with the steps; stretches of the trail run under trees.
//!
//! Enters: the walk's length of time (seconds). Leaves: the antenna's position and velocity
//! in the site's east-north-up frame at any time since the start (metres, m/s), and the
//! canopy over the trail there (0 open sky, 1 dense), which the receiver model turns into
//! signal loss. Analytic, so the truth is exact at any instant.

use nalgebra::Vector3;
use std::f64::consts::PI;

/// Seconds standing still at the start.
pub const STAND_S: f64 = 60.0;
/// Walking speed along the path parameter, m/s.
const SPEED: f64 = 1.3;
/// The pause: when it starts (s) and how long it lasts (s).
const PAUSE: (f64, f64) = (600.0, 40.0);
/// Seconds to speed up or slow down.
const RAMP: f64 = 4.0;
/// Stretches of the trail under trees (path parameter, metres).
const CANOPY: [(f64, f64); 3] = [(120.0, 420.0), (560.0, 760.0), (980.0, 1240.0)];

/// Distance walked along the path parameter after `t` seconds, with speed ramps at the
/// start and around the pause: (s, ds/dt).
fn along(t: f64) -> (f64, f64) {
    // Speed is SPEED·w(t) with w a product of smooth ramps; s integrates it in closed form
    // piece by piece (each ramp is a raised cosine).
    let ramp_up = |t0: f64, t: f64| -> (f64, f64) {
        // integral and value of a raised-cosine ramp from 0 to 1 over [t0, t0 + RAMP]
        if t <= t0 {
            (0.0, 0.0)
        } else if t >= t0 + RAMP {
            (t - t0 - RAMP / 2.0, 1.0)
        } else {
            let x = (t - t0) / RAMP;
            let w = 0.5 - 0.5 * (PI * x).cos();
            let integral = RAMP * (x / 2.0 - (PI * x).sin() / (2.0 * PI));
            (integral, w)
        }
    };
    let (p0, d) = PAUSE;
    // walking = up(STAND) − down(p0 − RAMP) + up(p0 + d)
    let (a, wa) = ramp_up(STAND_S, t);
    let (b, wb) = ramp_up(p0 - RAMP, t);
    let (c, wc) = ramp_up(p0 + d, t);
    (SPEED * (a - b + c), SPEED * (wa - wb + wc))
}

/// The trail at path parameter `s` (ENU, metres) and its derivative.
fn path(s: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (k1, k2, k3) = (1.0 / 150.0, 1.0 / 47.0, 1.0 / 300.0);
    let p = Vector3::new(
        s - 700.0,
        40.0 * (s * k1).sin() + 12.0 * (s * k2 + 1.0).sin() - 150.0,
        2.5 * (s * k3).sin() + 1.2,
    );
    let dp = Vector3::new(
        1.0,
        40.0 * k1 * (s * k1).cos() + 12.0 * k2 * (s * k2 + 1.0).cos(),
        2.5 * k3 * (s * k3).cos(),
    );
    (p, dp)
}

/// The antenna at `t` seconds since the start: ENU position and velocity.
pub fn at(t: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (s, ds) = along(t);
    let (p, dp) = path(s);
    // Steps bob the pole by a centimetre at 1.9 Hz while walking.
    let w = 2.0 * PI * 1.9;
    let amp = 0.01 * (ds / SPEED);
    let bob = Vector3::new(0.0, 0.0, amp * (w * t).sin());
    let dbob = Vector3::new(0.0, 0.0, amp * w * (w * t).cos());
    (p + bob, dp * ds + dbob)
}

/// The canopy over the trail at `t` (0 open sky … 1 dense), with edges some 15 m long.
pub fn canopy(t: f64) -> f64 {
    let s = along(t).0;
    CANOPY
        .iter()
        .map(|&(a, b)| {
            let edge = |x: f64| 0.5 + 0.5 * (x / 15.0).tanh();
            edge(s - a) * edge(b - s)
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Still at the start and in the pause, about 1.3 m/s otherwise; the velocity is the
    /// derivative of the position; trees over a good part of the walk.
    #[test]
    fn the_walk_moves_as_described() {
        let (p0, v0) = at(10.0);
        assert!(v0.norm() < 1e-9 && (at(50.0).0 - p0).norm() < 1e-9);
        let (_, vp) = at(PAUSE.0 + PAUSE.1 / 2.0);
        assert!(vp.norm() < 1e-9, "{vp}");
        for t in [100.0, 300.0, 900.0, 1150.0] {
            let (p, v) = at(t);
            let h = 1e-4;
            let num = (at(t + h).0 - at(t - h).0) / (2.0 * h);
            assert!((num - v).norm() < 1e-5, "{t}: {num} vs {v}");
            let horizontal = (v.x * v.x + v.y * v.y).sqrt();
            assert!((1.2..2.0).contains(&horizontal), "{t}: {horizontal}");
            assert!(p.norm() < 1000.0);
        }
        let under: usize = (0..1200).filter(|&t| canopy(t as f64) > 0.5).count();
        assert!((300..700).contains(&under), "{under} s under trees");
    }
}
