//! Camera attitude at an exposure: from an IMU/gimbal (yaw, pitch, roll; NED body, fixed
//! body→camera mounting with the camera looking down, image x forward), from photogrammetric
//! angles (ω-φ-κ with R = Rω·Rφ·Rκ, or φ-ω-κ with R = Rφ·Rω·Rκ and the Chinese-text Rφ),
//! or — when nothing else exists — from the trajectory heading with zero pitch and roll.
//! R maps the camera frame into the local ENU frame at the exposure.
//!
//! Enters: an attitude CSV (`week,tow,a1,a2,a3`, GPST, degrees) or angles in radians. Leaves:
//! rotation matrices (camera → ENU) and ω-φ-κ of a matrix. Uses `photo::rotation::Angles`.

use gnss::error::{Error, Result};
use gnss::time::checked_week_tow;
use hifitime::Epoch;
use nalgebra::Matrix3;
use photo::rotation::Angles;
use std::path::Path;

/// Convention of the three angles of an attitude file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AngleConvention {
    /// Yaw (from north, clockwise), pitch (nose up), roll (right wing down): IMU, gimbal or
    /// compass heading/pitch/roll.
    YawPitchRoll,
    /// ω-φ-κ, R = Rω·Rφ·Rκ.
    OmegaPhiKappa,
    /// φ-ω-κ, R = Rφ·Rω·Rκ, Rφ = `[[cφ,0,−sφ],[0,1,0],[sφ,0,cφ]]`.
    PhiOmegaKappa,
}

/// Camera → ENU from yaw, pitch, roll (radians) with the standard downward mounting.
pub fn from_yaw_pitch_roll(yaw: f64, pitch: f64, roll: f64) -> Matrix3<f64> {
    Angles::YawPitchRoll { yaw, pitch, roll }.matrix()
}

/// R from three angles (radians) in a convention.
pub fn rotation(conv: AngleConvention, a: [f64; 3]) -> Matrix3<f64> {
    match conv {
        AngleConvention::YawPitchRoll => Angles::YawPitchRoll {
            yaw: a[0],
            pitch: a[1],
            roll: a[2],
        },
        AngleConvention::OmegaPhiKappa => Angles::OmegaPhiKappa {
            omega: a[0],
            phi: a[1],
            kappa: a[2],
        },
        AngleConvention::PhiOmegaKappa => Angles::PhiOmegaKappa {
            phi: a[0],
            omega: a[1],
            kappa: a[2],
        },
    }
    .matrix()
}

/// ω-φ-κ of R (R = Rω·Rφ·Rκ), radians.
pub fn omega_phi_kappa(r: &Matrix3<f64>) -> [f64; 3] {
    match Angles::omega_phi_kappa(r) {
        Angles::OmegaPhiKappa { omega, phi, kappa } => [omega, phi, kappa],
        _ => unreachable!("omega_phi_kappa returns that convention"),
    }
}

/// Attitude samples over time.
#[derive(Clone, Debug)]
pub struct AttitudeTable {
    /// Convention of the angles.
    pub conv: AngleConvention,
    /// Sample times, GPST, increasing.
    pub times: Vec<Epoch>,
    /// The three angles of each sample, radians.
    pub angles: Vec<[f64; 3]>,
}

/// `a` moved by whole turns to within half a turn of `reference` (both finite).
fn unwrap_to(a: f64, reference: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    reference + (a - reference + PI).rem_euclid(TAU) - PI
}

/// Largest attitude angle accepted from a file, degrees (two turns either way).
const MAX_ANGLE_DEG: f64 = 720.0;

impl AttitudeTable {
    /// CSV with header `week,tow,a1,a2,a3` (degrees), GPST.
    pub fn read_csv(path: &Path, conv: AngleConvention) -> Result<AttitudeTable> {
        let text = std::fs::read_to_string(path).map_err(Error::io(path))?;
        let mut times = Vec::new();
        let mut angles = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let l = line.trim();
            if l.is_empty()
                || l.starts_with('#')
                || l.starts_with(|c: char| c.is_ascii_alphabetic())
            {
                continue;
            }
            let f: Vec<f64> = l
                .split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| {
                    Error::parse(
                        path,
                        i + 1,
                        "numbers expected: week,tow,angle1,angle2,angle3 (degrees)",
                    )
                })?;
            if f.len() < 5 {
                return Err(Error::parse(
                    path,
                    i + 1,
                    "five columns expected: week,tow,angle1,angle2,angle3",
                ));
            }
            let time = checked_week_tow(f[0], f[1])
                .map_err(|e| Error::parse(path, i + 1, format!("columns 1–2: {e}")))?;
            if let Some(k) = (2..5).find(|&k| !(-MAX_ANGLE_DEG..=MAX_ANGLE_DEG).contains(&f[k])) {
                return Err(Error::parse(
                    path,
                    i + 1,
                    format!(
                        "column {}: angle {} is not a number of degrees within ±{MAX_ANGLE_DEG}",
                        k + 1,
                        f[k]
                    ),
                ));
            }
            times.push(time);
            angles.push([f[2].to_radians(), f[3].to_radians(), f[4].to_radians()]);
        }
        if times.len() < 2 {
            return Err(Error::input(path, "fewer than two attitude samples"));
        }
        Ok(AttitudeTable {
            conv,
            times,
            angles,
        })
    }

    /// R at `t` (angles interpolated linearly, wrap-aware); `None` outside the table.
    pub fn at(&self, t: Epoch) -> Option<Matrix3<f64>> {
        let (t0, t1) = (*self.times.first()?, *self.times.last()?);
        if t < t0 || t > t1 {
            return None;
        }
        let j = self
            .times
            .partition_point(|x| *x <= t)
            .clamp(1, self.times.len() - 1);
        let (a, b) = (&self.angles[j - 1], &self.angles[j]);
        let f = (t - self.times[j - 1]).to_seconds()
            / (self.times[j] - self.times[j - 1]).to_seconds().max(1e-9);
        let mut x = [0.0; 3];
        for k in 0..3 {
            let bk = unwrap_to(b[k], a[k]);
            x[k] = a[k] + (bk - a[k]) * f;
        }
        Some(rotation(self.conv, x))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conventions_agree_on_the_same_rotation() {
        let r = from_yaw_pitch_roll(0.7, 0.03, -0.05);
        let opk = omega_phi_kappa(&r);
        assert!((rotation(AngleConvention::OmegaPhiKappa, opk) - r).norm() < 1e-12);
        // Level, heading north: camera x north, z up.
        let r0 = from_yaw_pitch_roll(0.0, 0.0, 0.0);
        assert!((r0 * nalgebra::Vector3::x() - nalgebra::Vector3::y()).norm() < 1e-12);
        assert!((r0 * nalgebra::Vector3::z() - nalgebra::Vector3::z()).norm() < 1e-12);
        // φ-ω-κ with φ = −ω-φ-κ's φ for pure φ rotations.
        assert!(
            (rotation(AngleConvention::PhiOmegaKappa, [0.1, 0.0, 0.0])
                - rotation(AngleConvention::OmegaPhiKappa, [0.0, -0.1, 0.0]))
            .norm()
                < 1e-12
        );
        assert!((unwrap_to(3.1, -3.1) - (3.1 - 2.0 * std::f64::consts::PI)).abs() < 1e-12);
        assert!((unwrap_to(0.5 + 40.0 * std::f64::consts::PI, 0.4) - 0.5).abs() < 1e-9);
    }
}
