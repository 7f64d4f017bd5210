//! The photogrammetric side of a simulated flight: exposure times at a forward overlap,
//! camera attitude and projection centres (lever arm X_A = X_S + R·(u, v, w)), ground points
//! and noisy image observations with optional blunders.
//!
//! Enters: the [`Flight`], a [`CameraSpec`] and a random stream. Leaves: [`Exposure`]s,
//! [`GroundPoint`]s and [`ImageObs`]. Everything is in the site's ENU frame (metres); the
//! camera rotation R maps the camera frame (x along track, z up, looking down −z) into ENU
//! and comes from yaw/pitch/roll through [`exposure::attitude::from_yaw_pitch_roll`].

use super::flight::{Flight, FlightState};
use super::rng::Rng;
use exposure::attitude::from_yaw_pitch_roll;
use nalgebra::{Matrix3, Vector3};

/// Camera of the simulation (pinhole, principal point at the image centre).
#[derive(Clone, Debug)]
pub struct CameraSpec {
    /// Principal distance, metres.
    pub focal: f64,
    /// Image size in pixels: x along the flight direction, y across it.
    pub width_px: usize,
    /// Image size across the flight direction, pixels.
    pub height_px: usize,
    /// Pixel size, metres.
    pub pixel: f64,
    /// Antenna phase centre in the camera frame.
    pub lever: photo::lever::LeverArm,
}

/// One simulated exposure (true values, local ENU frame of the site).
#[derive(Clone, Debug)]
pub struct Exposure {
    /// Number of the exposure, from 1 in flight order.
    pub id: usize,
    /// Strip, from 0.
    pub strip: usize,
    /// Seconds from the start of the flight (true GPST).
    pub t: f64,
    /// The aircraft at the exposure (its position is the antenna's).
    pub state: FlightState,
    /// Rotation camera → ENU.
    pub r: Matrix3<f64>,
    /// Projection centre, ENU metres.
    pub centre: Vector3<f64>,
}

/// Kind of a ground point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PointKind {
    /// Ground control point.
    Gcp,
    /// Check point (known, not used as control).
    Check,
    /// Tie point (unknown).
    Tie,
}

impl PointKind {
    /// The kind as the tables write it: `gcp`, `check`, `tie`.
    pub fn name(self) -> &'static str {
        match self {
            PointKind::Gcp => "gcp",
            PointKind::Check => "check",
            PointKind::Tie => "tie",
        }
    }
}

/// A simulated ground point.
#[derive(Clone, Debug)]
pub struct GroundPoint {
    /// Id: `G0001`, `C0001`, `T0001` …
    pub id: String,
    /// Control, check or tie.
    pub kind: PointKind,
    /// True position, ENU metres.
    pub enu: Vector3<f64>,
}

/// An image measurement (pixels, x right/along track, y down).
#[derive(Clone, Debug)]
pub struct ImageObs {
    /// The exposure's id.
    pub image: usize,
    /// The point's id.
    pub point: String,
    /// Column, pixels from the left edge.
    pub x: f64,
    /// Row, pixels from the top edge.
    pub y: f64,
    /// σ of the measurement, pixels.
    pub sigma: f64,
    /// Size of an injected blunder, pixels (0 for good observations).
    pub blunder: f64,
}

/// Exposures along the strips at the forward overlap.
pub fn exposures(
    flight: &Flight,
    cam: &CameraSpec,
    altitude: f64,
    speed: f64,
    overlap: f64,
) -> Vec<Exposure> {
    let footprint = altitude * cam.width_px as f64 * cam.pixel / cam.focal;
    let base = (1.0 - overlap) * footprint;
    let mut out = Vec::new();
    for (strip, t0, dur) in flight.strips() {
        // Straight run-in and run-out: no exposure within 3 s of a turn (the aircraft rolls
        // level before the first photograph of a strip).
        let margin = 3.0f64.min(dur / 10.0);
        let n = ((dur - 2.0 * margin) * speed / base).floor() as usize;
        for k in 0..=n {
            let t = t0 + margin + k as f64 * base / speed;
            let state = flight.at(t);
            let r = from_yaw_pitch_roll(state.yaw, state.pitch, state.roll);
            let centre = cam.lever.centre(&state.pos, &r);
            out.push(Exposure {
                id: out.len() + 1,
                strip,
                t,
                state,
                r,
                centre,
            });
        }
    }
    out
}

/// Ground control, check and tie points spread over the block.
pub fn ground_points(
    rng: &mut Rng,
    half_along: f64,
    half_across: f64,
    heading: f64,
    relief: f64,
    counts: [usize; 3],
) -> Vec<GroundPoint> {
    let (sh, ch) = heading.sin_cos();
    let along = Vector3::new(sh, ch, 0.0);
    let across = Vector3::new(ch, -sh, 0.0);
    let mut out = Vec::new();
    for (kind, n, prefix) in [
        (PointKind::Gcp, counts[0], "G"),
        (PointKind::Check, counts[1], "C"),
        (PointKind::Tie, counts[2], "T"),
    ] {
        for k in 0..n {
            // GCPs go to the block corners first, then anywhere; others anywhere.
            let (a, c) = if kind == PointKind::Gcp && k < 4 {
                let sa = if k.is_multiple_of(2) { -0.9 } else { 0.9 };
                let sc = if k < 2 { -0.9 } else { 0.9 };
                (sa, sc)
            } else {
                (rng.range(-0.95, 0.95), rng.range(-0.95, 0.95))
            };
            let h = relief * rng.range(-1.0, 1.0);
            out.push(GroundPoint {
                id: format!("{prefix}{:04}", k + 1),
                kind,
                enu: along * a * half_along + across * c * half_across + Vector3::new(0.0, 0.0, h),
            });
        }
    }
    out
}

/// Project `p` into an exposure; `None` when behind the camera or outside the image.
pub fn project(e: &Exposure, cam: &CameraSpec, p: &Vector3<f64>) -> Option<(f64, f64)> {
    let v = e.r.transpose() * (p - e.centre);
    if v.z >= 0.0 {
        return None;
    }
    let x = -cam.focal * v.x / v.z;
    let y = -cam.focal * v.y / v.z;
    let px = cam.width_px as f64 / 2.0 + x / cam.pixel;
    let py = cam.height_px as f64 / 2.0 - y / cam.pixel;
    (px >= 0.0 && py >= 0.0 && px < cam.width_px as f64 && py < cam.height_px as f64)
        .then_some((px, py))
}

/// Noisy image observations of every visible point, with `blunders` gross errors.
pub fn image_observations(
    exps: &[Exposure],
    points: &[GroundPoint],
    cam: &CameraSpec,
    sigma: f64,
    blunders: usize,
    rng: &mut Rng,
) -> Vec<ImageObs> {
    let mut out = Vec::new();
    for e in exps {
        for p in points {
            if let Some((x, y)) = project(e, cam, &p.enu) {
                out.push(ImageObs {
                    image: e.id,
                    point: p.id.clone(),
                    x: x + sigma * rng.normal(),
                    y: y + sigma * rng.normal(),
                    sigma,
                    blunder: 0.0,
                });
            }
        }
    }
    for _ in 0..blunders.min(out.len()) {
        let i = (rng.uniform() * out.len() as f64) as usize;
        if out[i].blunder != 0.0 {
            continue;
        }
        let b = rng.range(10.0, 30.0) * if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
        out[i].x += b;
        out[i].blunder = b;
    }
    out
}
