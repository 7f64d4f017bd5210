//! A surveyor staking out points near the base with a pole-mounted low-cost rover, as the
//! real walk of the fingerprint moved: standing most of the time (70 % of it slower than
//! 0.2 m/s), walking a few metres to tens of metres between points 3–30 m from the base
//! (median 6 m), the pole swaying by millimetres in the hand, some points under trees.
//!
//! Enters: a random stream and the length of time (seconds). Leaves: a [`Stakeout`] whose
//! [`Stakeout::at`] gives the antenna's position and velocity in the base's east-north-up
//! frame at any time since the start (metres, m/s; analytic, so the truth is exact at any
//! instant), [`Stakeout::canopy`] the canopy over it (0 open sky … 1 dense) and
//! [`Stakeout::still_share`] the share of time it stands.

use super::super::rng::Rng;
use nalgebra::Vector3;
use std::f64::consts::PI;

/// Seconds standing at a point (uniform range).
const STAND_S: (f64, f64) = (15.0, 70.0);
/// Mean walking speed between points, m/s (uniform range).
const WALK_SPEED: (f64, f64) = (0.4, 0.7);
/// Points lie this far from the base, metres: `near·(far/near)^(u^1.6)`, median about 6 m.
const RADIUS: (f64, f64) = (3.0, 30.0);
/// Seconds standing at the first point (setting up).
const FIRST_STAND_S: f64 = 60.0;

/// One stretch of the stake-out.
#[derive(Clone, Debug)]
enum Leg {
    /// Standing at a point from `t0` to `t1` (s) under canopy `canopy`.
    Stand {
        t0: f64,
        t1: f64,
        at: Vector3<f64>,
        canopy: f64,
    },
    /// Walking from one point to the next, the speed a raised cosine (still at both ends).
    Walk {
        t0: f64,
        t1: f64,
        from: (Vector3<f64>, f64),
        to: (Vector3<f64>, f64),
    },
}

impl Leg {
    fn span(&self) -> (f64, f64) {
        match *self {
            Leg::Stand { t0, t1, .. } | Leg::Walk { t0, t1, .. } => (t0, t1),
        }
    }
}

/// The stake-out: its legs and the pole's sway (per axis: amplitude m, angular rate rad/s,
/// phase rad, three each).
#[derive(Clone, Debug)]
pub struct Stakeout {
    legs: Vec<Leg>,
    sway: [[(f64, f64, f64); 3]; 3],
}

/// A point of the stake-out, within 60° of azimuth `from` (seen from the base: the walk to it
/// does not pass by the base), and the canopy over it.
fn point(rng: &mut Rng, from: f64) -> (Vector3<f64>, f64) {
    let r = RADIUS.0 * (RADIUS.1 / RADIUS.0).powf(rng.uniform().powf(1.6));
    let az = from + rng.range(-PI / 3.0, PI / 3.0);
    let up = rng.range(-0.5, 0.5);
    // Half the points in the open (canopy 0–0.3), half under trees (0.5–1).
    let canopy = if rng.uniform() < 0.5 {
        rng.range(0.0, 0.3)
    } else {
        rng.range(0.5, 1.0)
    };
    (Vector3::new(r * az.sin(), r * az.cos(), up), canopy)
}

impl Stakeout {
    /// A stake-out of at least `span` seconds drawn from `rng`.
    pub fn draw(rng: &mut Rng, span: f64) -> Stakeout {
        let mut legs = Vec::new();
        let first = rng.range(0.0, 2.0 * PI);
        let mut here = point(rng, first);
        let mut t = 0.0;
        let mut stand = FIRST_STAND_S;
        while t <= span {
            legs.push(Leg::Stand {
                t0: t,
                t1: t + stand,
                at: here.0,
                canopy: here.1,
            });
            t += stand;
            let next = point(rng, here.0.x.atan2(here.0.y));
            let d = (next.0 - here.0).norm();
            let walk = (d / rng.range(WALK_SPEED.0, WALK_SPEED.1)).max(3.0);
            legs.push(Leg::Walk {
                t0: t,
                t1: t + walk,
                from: here,
                to: next,
            });
            t += walk;
            here = next;
            stand = rng.range(STAND_S.0, STAND_S.1);
        }
        let mut sway = [[(0.0, 0.0, 0.0); 3]; 3];
        for (axis, s) in sway.iter_mut().enumerate() {
            let amp = if axis == 2 { 0.001 } else { 0.003 };
            for w in s.iter_mut() {
                *w = (
                    amp * rng.range(0.5, 1.5),
                    2.0 * PI / rng.range(2.0, 12.0),
                    rng.range(0.0, 2.0 * PI),
                );
            }
        }
        Stakeout { legs, sway }
    }

    /// The leg under way at `t` (the last one after the end).
    fn leg(&self, t: f64) -> &Leg {
        let i = self.legs.partition_point(|l| l.span().1 <= t);
        &self.legs[i.min(self.legs.len() - 1)]
    }

    /// The antenna at `t` seconds since the start: ENU position and velocity from the base.
    pub fn at(&self, t: f64) -> (Vector3<f64>, Vector3<f64>) {
        let (mut p, mut v) = match *self.leg(t) {
            Leg::Stand { at, .. } => (at, Vector3::zeros()),
            Leg::Walk { t0, t1, from, to } => {
                let d = t1 - t0;
                let u = ((t - t0) / d).clamp(0.0, 1.0);
                let s = u - (2.0 * PI * u).sin() / (2.0 * PI);
                let ds = (1.0 - (2.0 * PI * u).cos()) / d;
                let step = to.0 - from.0;
                // Steps bob the pole by up to a centimetre at 1.9 Hz while walking.
                let w = 2.0 * PI * 1.9;
                let amp = 0.005 * (1.0 - (2.0 * PI * u).cos());
                let bob = Vector3::new(0.0, 0.0, amp * (w * t).sin());
                let dbob = Vector3::new(
                    0.0,
                    0.0,
                    amp * w * (w * t).cos()
                        + 0.005 * 2.0 * PI / d * (2.0 * PI * u).sin() * (w * t).sin(),
                );
                (from.0 + step * s + bob, step * ds + dbob)
            }
        };
        for (axis, waves) in self.sway.iter().enumerate() {
            for &(a, w, phi) in waves {
                p[axis] += a * (w * t + phi).sin();
                v[axis] += a * w * (w * t + phi).cos();
            }
        }
        (p, v)
    }

    /// The canopy over the antenna at `t` (0 open sky … 1 dense): the point's, or between two
    /// points while walking.
    pub fn canopy(&self, t: f64) -> f64 {
        match *self.leg(t) {
            Leg::Stand { canopy, .. } => canopy,
            Leg::Walk { t0, t1, from, to } => {
                let u = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
                from.1 + (to.1 - from.1) * u
            }
        }
    }

    /// The share of `[0, span]` spent standing.
    pub fn still_share(&self, span: f64) -> f64 {
        let still: f64 = self
            .legs
            .iter()
            .filter(|l| matches!(l, Leg::Stand { .. }))
            .map(|l| {
                let (a, b) = l.span();
                (b.min(span) - a.min(span)).max(0.0)
            })
            .sum();
        still / span
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Standing most of the time, 3–30 m from the base, the velocity the derivative of the
    /// position, the sway millimetres.
    #[test]
    fn the_stakeout_stands_mostly_near_the_base() {
        for seed in 1..=5 {
            let s = Stakeout::draw(&mut Rng::new(seed), 1200.0);
            let still = s.still_share(1200.0);
            assert!((0.55..=0.85).contains(&still), "seed {seed}: {still}");
            let mut radii: Vec<f64> = (0..1200)
                .map(|t| {
                    let p = s.at(t as f64).0;
                    (p.x * p.x + p.y * p.y).sqrt()
                })
                .collect();
            radii.sort_by(f64::total_cmp);
            assert!(radii[0] > 2.5 && radii[1199] < 31.0, "seed {seed}");
            for t in [10.3, 333.7, 801.2, 1100.9] {
                let h = 1e-5;
                let num = (s.at(t + h).0 - s.at(t - h).0) / (2.0 * h);
                let v = s.at(t).1;
                assert!((num - v).norm() < 1e-5, "seed {seed} {t}: {num} vs {v}");
            }
            let (a, b) = (s.at(20.0).0, s.at(40.0).0);
            assert!(
                (a - b).norm() < 0.02,
                "seed {seed}: sway {}",
                (a - b).norm()
            );
        }
    }
}
