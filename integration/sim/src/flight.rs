//! The survey flight: a static start beside the base, a climb to the block, parallel strips
//! joined by half-circle turns at constant speed. Positions and velocities are analytic in a
//! local east-north-up frame at the site; attitude follows the path (banked in turns) with a
//! small smooth wobble.
//!
//! Enters: a [`FlightPlan`] (metres, m/s, radians, seconds) and a random stream (the wobble).
//! Leaves: a [`Flight`] that gives the [`FlightState`] at any time since the start (seconds)
//! and the time spans of the strips. Used by the simulator's GNSS observations, exposures and
//! truth files.

use super::rng::Rng;
use nalgebra::Vector3;
use std::f64::consts::PI;

const G: f64 = 9.80665;

#[derive(Clone, Debug)]
enum Seg {
    Static {
        p: Vector3<f64>,
    },
    Line {
        p0: Vector3<f64>,
        p1: Vector3<f64>,
    },
    /// Half circle: centre, radius, start angle (from east, counter-clockwise), direction (+1 ccw).
    Arc {
        c: Vector3<f64>,
        r: f64,
        a0: f64,
        dir: f64,
    },
}

/// One piece of the path with its time span (seconds from the start).
#[derive(Clone, Debug)]
struct Piece {
    seg: Seg,
    t0: f64,
    dur: f64,
    /// Photogrammetric strip number, if this piece is a strip.
    strip: Option<usize>,
}

/// State of the aircraft at a time: ENU position and velocity, attitude (radians).
#[derive(Clone, Copy, Debug)]
pub struct FlightState {
    /// Antenna position, ENU metres.
    pub pos: Vector3<f64>,
    /// Velocity, ENU m/s.
    pub vel: Vector3<f64>,
    /// Yaw from north clockwise, radians (NED body convention).
    pub yaw: f64,
    /// Pitch, nose up, radians.
    pub pitch: f64,
    /// Roll, right wing down, radians.
    pub roll: f64,
}

/// Parameters of the path.
#[derive(Clone, Debug)]
pub struct FlightPlan {
    /// Height of the strips above the site origin, metres.
    pub altitude: f64,
    /// Speed, m/s.
    pub speed: f64,
    /// Number of strips.
    pub strips: usize,
    /// Length of each strip, metres (centred on the site).
    pub strip_length: f64,
    /// Distance between strips, metres.
    pub strip_spacing: f64,
    /// Direction of the first strip, radians clockwise from north.
    pub heading: f64,
    /// Seconds on the ground before take-off.
    pub static_start: f64,
    /// Where the aircraft waits on the ground (ENU).
    pub start: Vector3<f64>,
}

/// The whole path.
#[derive(Clone, Debug)]
pub struct Flight {
    pieces: Vec<Piece>,
    speed: f64,
    wobble: [(f64, f64, f64); 6],
}

impl Flight {
    /// The path of a plan; the attitude wobble is drawn from `rng`.
    pub fn new(p: &FlightPlan, rng: &mut Rng) -> Flight {
        let (sh, ch) = p.heading.sin_cos();
        let along = Vector3::new(sh, ch, 0.0); // heading from north, clockwise
        let across = Vector3::new(ch, -sh, 0.0); // to the right of the heading
        let half = p.strip_length / 2.0;
        let width = (p.strips.max(1) - 1) as f64 * p.strip_spacing;
        let mut pieces = Vec::new();
        let mut t = 0.0;
        let mut push = |seg: Seg, dur: f64, strip: Option<usize>, t: &mut f64| {
            pieces.push(Piece {
                seg,
                t0: *t,
                dur,
                strip,
            });
            *t += dur;
        };
        push(Seg::Static { p: p.start }, p.static_start, None, &mut t);
        let strip_start = |k: usize| -> (Vector3<f64>, Vector3<f64>) {
            let off = across * (k as f64 * p.strip_spacing - width / 2.0)
                + Vector3::new(0.0, 0.0, p.altitude);
            let dir = if k.is_multiple_of(2) { 1.0 } else { -1.0 };
            (off - along * half * dir, off + along * half * dir)
        };
        let (s0, _) = strip_start(0);
        // Climb along a straight line to a point one turn radius before the first strip.
        let lead_in = s0 - along * (p.strip_spacing.max(200.0));
        let d = (lead_in - p.start).norm();
        push(
            Seg::Line {
                p0: p.start,
                p1: lead_in,
            },
            d / p.speed,
            None,
            &mut t,
        );
        push(
            Seg::Line {
                p0: lead_in,
                p1: s0,
            },
            (s0 - lead_in).norm() / p.speed,
            None,
            &mut t,
        );
        for k in 0..p.strips {
            let (a, b) = strip_start(k);
            push(
                Seg::Line { p0: a, p1: b },
                p.strip_length / p.speed,
                Some(k),
                &mut t,
            );
            if k + 1 < p.strips {
                let (n0, _) = strip_start(k + 1);
                let c = (b + n0) / 2.0;
                let r = (n0 - b).norm() / 2.0;
                let rel = b - c;
                let a0 = rel.y.atan2(rel.x);
                // Turn towards the next strip: the direction that starts along the current heading.
                let dir_vec = if k.is_multiple_of(2) { along } else { -along };
                let tangent_ccw = Vector3::new(-a0.sin(), a0.cos(), 0.0);
                let dir = if tangent_ccw.dot(&dir_vec) > 0.0 {
                    1.0
                } else {
                    -1.0
                };
                push(Seg::Arc { c, r, a0, dir }, PI * r / p.speed, None, &mut t);
            }
        }
        let mut wobble = [(0.0, 0.0, 0.0); 6];
        for w in wobble.iter_mut() {
            *w = (
                rng.range(0.002, 0.008),
                rng.range(0.02, 0.2),
                rng.range(0.0, 2.0 * PI),
            );
        }
        Flight {
            pieces,
            speed: p.speed,
            wobble,
        }
    }

    /// Seconds from the start to the end of the last strip.
    pub fn duration(&self) -> f64 {
        self.pieces.last().map(|p| p.t0 + p.dur).unwrap_or(0.0)
    }

    /// Time spans of the photogrammetric strips: (strip, start, duration).
    pub fn strips(&self) -> Vec<(usize, f64, f64)> {
        self.pieces
            .iter()
            .filter_map(|p| p.strip.map(|s| (s, p.t0, p.dur)))
            .collect()
    }

    fn smooth(&self, k: usize, t: f64) -> f64 {
        let (a, f, ph) = self.wobble[k];
        let (a2, f2, ph2) = self.wobble[k + 3];
        a * (f * t + ph).sin() + a2 * (f2 * t + ph2).sin()
    }

    /// State at `t` seconds after the start.
    pub fn at(&self, t: f64) -> FlightState {
        let piece = self
            .pieces
            .iter()
            .find(|p| t < p.t0 + p.dur)
            .unwrap_or_else(|| self.pieces.last().expect("a flight has pieces"));
        let tau = (t - piece.t0).clamp(0.0, piece.dur);
        let (pos, vel, bank) = match &piece.seg {
            Seg::Static { p } => (*p, Vector3::zeros(), 0.0),
            Seg::Line { p0, p1 } => {
                let v = (p1 - p0) / piece.dur.max(1e-9);
                (p0 + v * tau, v, 0.0)
            }
            Seg::Arc { c, r, a0, dir } => {
                let w = dir * self.speed / r;
                let a = a0 + w * tau;
                let pos = c + Vector3::new(r * a.cos(), r * a.sin(), 0.0);
                let vel = Vector3::new(-r * w * a.sin(), r * w * a.cos(), 0.0);
                // Counter-clockwise (left) turns bank left (negative roll).
                (pos, vel, -dir * (self.speed * self.speed / (G * r)).atan())
            }
        };
        let moving = vel.norm() > 0.1;
        let yaw = if moving { vel.x.atan2(vel.y) } else { 0.0 };
        let climb = if moving {
            (vel.z / vel.xy().norm().max(1e-9)).atan()
        } else {
            0.0
        };
        let (dp, dr, dy) = if moving {
            (self.smooth(0, t), self.smooth(1, t), self.smooth(2, t))
        } else {
            (0.0, 0.0, 0.0)
        };
        FlightState {
            pos,
            vel,
            yaw: yaw + dy,
            pitch: climb + dp,
            roll: bank + dr,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_is_continuous_at_the_requested_speed() {
        let plan = FlightPlan {
            altitude: 300.0,
            speed: 60.0,
            strips: 3,
            strip_length: 2000.0,
            strip_spacing: 300.0,
            heading: 0.3,
            static_start: 30.0,
            start: Vector3::new(0.0, -1500.0, 2.0),
        };
        let f = Flight::new(&plan, &mut Rng::new(1));
        let dt = 0.1;
        let mut t = 0.0;
        let mut prev = f.at(0.0);
        while t < f.duration() - dt {
            t += dt;
            let s = f.at(t);
            let step = (s.pos - prev.pos).norm();
            assert!(step <= 60.0 * dt + 1e-6, "jump of {step} m at {t}");
            if t > 31.0 {
                assert!((s.vel.norm() - 60.0).abs() < 1e-6);
            }
            prev = s;
        }
        assert_eq!(f.strips().len(), 3);
        // Banked in turns: 60 m/s on a 150 m radius is about 68°.
        let (_, t0, d) = f.strips()[0];
        let turn = f.at(t0 + d + 1.0);
        assert!(turn.roll.abs() > 1.0, "{}", turn.roll);
    }
}
