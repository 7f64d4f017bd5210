//! What precise point positioning adds to a range that double differences cancel: the
//! satellite's attitude (nominal yaw steering), its antenna phase centre (offset in the body
//! frame and variation by nadir angle), the carrier phase wind-up, the relativistic path
//! delay (Shapiro), and whether the satellite is in the Earth's shadow (where the yaw of
//! older blocks is not known).
//!
//! What enters: satellite and receiver positions (ECEF), the Sun, the ANTEX models. What
//! leaves: range corrections in metres and wind-up in cycles.

use crate::model::antex::{Antex, SatAntenna};
use crate::orbit::C;
use crate::sv::Sv;
use hifitime::Epoch;
use nalgebra::Vector3;

/// Earth's gravitational parameter, m³/s².
const GM: f64 = 3.986_004_418e14;
/// Radius of the Earth's shadow cylinder, metres.
const SHADOW_RADIUS: f64 = 6_378_137.0;

/// A satellite's body axes (ECEF unit vectors) under nominal yaw steering: z toward the
/// Earth's centre, y along z × (direction to the Sun), x completing the right-handed frame
/// (toward the Sun's side).
#[derive(Clone, Copy, Debug)]
pub struct Body {
    /// Body x axis.
    pub x: Vector3<f64>,
    /// Body y axis (solar panel axis).
    pub y: Vector3<f64>,
    /// Body z axis (toward the Earth).
    pub z: Vector3<f64>,
}

impl Body {
    /// The nominal attitude of a satellite at `sat` with the Sun at `sun` (both ECEF);
    /// None when the Sun is along the z axis (the yaw is undefined there).
    pub fn nominal(sat: &Vector3<f64>, sun: &Vector3<f64>) -> Option<Body> {
        let z = -sat.normalize();
        let to_sun = (sun - sat).normalize();
        let y = z.cross(&to_sun);
        if y.norm() < 1e-6 {
            return None;
        }
        let y = y.normalize();
        Some(Body {
            x: y.cross(&z),
            y,
            z,
        })
    }

    /// A body-frame vector in ECEF.
    pub fn to_ecef(self, v: [f64; 3]) -> Vector3<f64> {
        self.x * v[0] + self.y * v[1] + self.z * v[2]
    }
}

/// Whether a satellite at `sat` is in the Earth's (cylindrical) shadow with the Sun at `sun`.
pub fn in_shadow(sat: &Vector3<f64>, sun: &Vector3<f64>) -> bool {
    let s = sun.normalize();
    let along = sat.dot(&s);
    along < 0.0 && (sat - along * s).norm() < SHADOW_RADIUS
}

/// Relativistic path delay (m) between a satellite and a receiver (Shapiro).
pub fn shapiro(sat: &Vector3<f64>, rx: &Vector3<f64>) -> f64 {
    let (rs, rr) = (sat.norm(), rx.norm());
    let rho = (sat - rx).norm();
    2.0 * GM / (C * C) * ((rs + rr + rho) / (rs + rr - rho)).ln()
}

/// Phase wind-up (cycles) of a right-hand circularly polarised signal between a satellite
/// with attitude `body` and a receiver antenna whose x axis points north and y axis west,
/// along the unit vector `k` from satellite to receiver; made continuous with `prev`.
pub fn windup(
    body: &Body,
    k: &Vector3<f64>,
    north: &Vector3<f64>,
    west: &Vector3<f64>,
    prev: Option<f64>,
) -> f64 {
    let ds = body.x - k * k.dot(&body.x) - k.cross(&body.y);
    let dr = north - k * k.dot(north) + k.cross(west);
    let cosp = (ds.dot(&dr) / (ds.norm() * dr.norm())).clamp(-1.0, 1.0);
    let mut ph = cosp.acos() / (2.0 * std::f64::consts::PI);
    if k.dot(&ds.cross(&dr)) < 0.0 {
        ph = -ph;
    }
    match prev {
        Some(p) => ph + (p - ph + 0.5).floor(),
        None => ph,
    }
}

/// The satellite antenna models of a run: the first ANTEX file gives the model; when it
/// lists blocks and not satellites (relative-model files such as `igs_01.atx`), the
/// satellite-to-block assignment is taken from the satellite entries of the other files.
#[derive(Clone, Copy, Debug)]
pub struct SatAntennas<'a> {
    /// The ANTEX files, the model first.
    pub files: &'a [Antex],
}

impl<'a> SatAntennas<'a> {
    /// The antenna of `sv` at `t`, if any file describes it.
    pub fn of(&self, sv: Sv, t: Epoch) -> Option<&'a SatAntenna> {
        let model = self.files.first()?;
        if let Some(a) = model.satellite(sv, t) {
            return Some(a);
        }
        let block = self.files[1..]
            .iter()
            .find_map(|f| f.satellite(sv, t))?
            .block
            .as_str();
        model.block(block)
    }
}

/// Range correction (m) of the ionosphere-free combination of two frequencies (`bands` with
/// carrier frequencies `freqs`) for a satellite antenna: the offset moves the phase centre
/// from the centre of mass, the variation depends on the nadir angle of the receiver.
/// `k` is the unit vector from satellite to receiver. None when a band is missing.
pub fn sat_antenna_range(
    ant: &SatAntenna,
    sv: Sv,
    bands: [u8; 2],
    freqs: [f64; 2],
    body: &Body,
    k: &Vector3<f64>,
) -> Option<f64> {
    let nadir = k.dot(&body.z).clamp(-1.0, 1.0).acos().to_degrees();
    let one = |b: u8| -> Option<f64> {
        let (off, pcv) = ant.offset_pcv(sv.sys, b, nadir)?;
        Some(-body.to_ecef(off).dot(k) + pcv)
    };
    let (c1, c2) = (one(bands[0])?, one(bands[1])?);
    let (f1, f2) = (freqs[0] * freqs[0], freqs[1] * freqs[1]);
    Some((f1 * c1 - f2 * c2) / (f1 - f2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn body_frame_faces_the_earth_and_the_sun() {
        let sat = Vector3::new(2.6e7, 0.0, 0.0);
        let sun = Vector3::new(0.0, 1.5e11, 0.0);
        let b = Body::nominal(&sat, &sun).unwrap();
        assert!((b.z - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-12);
        assert!(b.x.dot(&(sun - sat).normalize()) > 0.99, "x toward the Sun");
        assert!((b.x.cross(&b.y) - b.z).norm() < 1e-12, "right-handed");
        assert!(in_shadow(&Vector3::new(0.0, -2.6e7, 0.0), &sun));
        assert!(!in_shadow(&Vector3::new(0.0, 2.6e7, 0.0), &sun));
        assert!(!in_shadow(&Vector3::new(2.6e7, -1.0e6, 0.0), &sun));
    }

    #[test]
    fn shapiro_delay_is_about_two_centimetres() {
        let sat = Vector3::new(2.66e7, 0.0, 0.0);
        let zenith = shapiro(&sat, &Vector3::new(6.371e6, 0.0, 0.0));
        assert!((0.012..0.02).contains(&zenith), "{zenith}");
    }

    #[test]
    fn windup_turns_with_the_receiver_antenna() {
        // A satellite straight overhead: turning the receiver antenna by 90° about the
        // line of sight changes the wind-up by a quarter cycle.
        let sat = Vector3::new(0.0, 0.0, 2.66e7);
        let sun = Vector3::new(1.5e11, 0.0, 0.0);
        let b = Body::nominal(&sat, &sun).unwrap();
        let k = Vector3::new(0.0, 0.0, -1.0);
        let (n, w) = (Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, 1.0, 0.0));
        let a = windup(&b, &k, &n, &w, None);
        let turned = windup(&b, &k, &w, &(-n), Some(a));
        assert!(((turned - a).abs() - 0.25).abs() < 1e-9, "{a} {turned}");
    }
}
