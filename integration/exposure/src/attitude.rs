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
    /// σ of each sample about the camera's x, y, z axes (radians), when the source gives them
    /// (a GNSS/INS trajectory: its roll, pitch and heading σ).
    pub sigmas: Option<Vec<[f64; 3]>>,
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
            sigmas: None,
        })
    }

    /// The attitude of a `ppkat ins` trajectory CSV: `gpst_week, gpst_tow, roll_deg,
    /// pitch_deg, heading_deg` and their `sd_roll_deg, sd_pitch_deg, sd_heading_deg` (the
    /// body's, x forward, y right, z down, camera mounted looking down with image x forward:
    /// σ about the camera's x, y, z are those of roll, pitch and heading).
    pub fn read_ins_csv(path: &Path) -> Result<AttitudeTable> {
        let text = std::fs::read_to_string(path).map_err(Error::io(path))?;
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
        let (_, header) = lines
            .next()
            .ok_or_else(|| Error::input(path, "empty: no header line"))?;
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        const COLS: [&str; 8] = [
            "gpst_week",
            "gpst_tow",
            "heading_deg",
            "pitch_deg",
            "roll_deg",
            "sd_roll_deg",
            "sd_pitch_deg",
            "sd_heading_deg",
        ];
        let mut at = [0usize; 8];
        for (k, c) in COLS.iter().enumerate() {
            at[k] = names.iter().position(|n| n == c).ok_or_else(|| {
                Error::input(
                    path,
                    format!("no {c} column: not a ppkat ins trajectory (write it with ppkat ins -o FILE.csv)"),
                )
            })?;
        }
        let (mut times, mut angles, mut sigmas) = (Vec::new(), Vec::new(), Vec::new());
        for (i, line) in lines {
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            let mut v = [0.0; 8];
            for (k, &c) in at.iter().enumerate() {
                v[k] = f
                    .get(c)
                    .and_then(|x| x.parse::<f64>().ok())
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        Error::parse(path, i + 1, format!("{}: not a number", COLS[k]))
                    })?;
            }
            let time = checked_week_tow(v[0], v[1])
                .map_err(|e| Error::parse(path, i + 1, format!("time: {e}")))?;
            if times.last().is_some_and(|l| time <= *l) {
                return Err(Error::parse(
                    path,
                    i + 1,
                    "time does not follow the row before",
                ));
            }
            if v[5..].iter().any(|s| *s <= 0.0) {
                return Err(Error::parse(path, i + 1, "a σ column is not positive"));
            }
            times.push(time);
            angles.push([v[2].to_radians(), v[3].to_radians(), v[4].to_radians()]);
            sigmas.push([v[5].to_radians(), v[6].to_radians(), v[7].to_radians()]);
        }
        if times.len() < 2 {
            return Err(Error::input(path, "fewer than two attitude samples"));
        }
        Ok(AttitudeTable {
            conv: AngleConvention::YawPitchRoll,
            times,
            angles,
            sigmas: Some(sigmas),
        })
    }

    /// The interval of `t` (index of its later sample) and the fraction into it; `None`
    /// outside the table.
    fn bracket(&self, t: Epoch) -> Option<(usize, f64)> {
        let (t0, t1) = (*self.times.first()?, *self.times.last()?);
        if t < t0 || t > t1 {
            return None;
        }
        let j = self
            .times
            .partition_point(|x| *x <= t)
            .clamp(1, self.times.len() - 1);
        let f = (t - self.times[j - 1]).to_seconds()
            / (self.times[j] - self.times[j - 1]).to_seconds().max(1e-9);
        Some((j, f))
    }

    /// σ at `t` about the camera's x, y, z (radians, interpolated linearly), when the table
    /// has them; `None` outside it.
    pub fn sigma_at(&self, t: Epoch) -> Option<[f64; 3]> {
        let s = self.sigmas.as_ref()?;
        let (j, f) = self.bracket(t)?;
        Some(std::array::from_fn(|k| {
            s[j - 1][k] + (s[j][k] - s[j - 1][k]) * f
        }))
    }

    /// R at `t` (angles interpolated linearly, wrap-aware); `None` outside the table.
    pub fn at(&self, t: Epoch) -> Option<Matrix3<f64>> {
        let (j, f) = self.bracket(t)?;
        let (a, b) = (&self.angles[j - 1], &self.angles[j]);
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

    /// A `ppkat ins` CSV: heading, pitch, roll as yaw-pitch-roll with their σ about the
    /// camera's x (roll), y (pitch), z (heading), interpolated; a file without a σ column is
    /// refused naming it.
    #[test]
    fn an_ins_trajectory_gives_attitude_and_sigma() {
        let head = "gpst_week,gpst_tow,lat_deg,lon_deg,h_m,vn_mps,ve_mps,vu_mps,roll_deg,pitch_deg,heading_deg,sd_n_m,sd_e_m,sd_u_m,sd_vn_mps,sd_ve_mps,sd_vu_mps,sd_roll_deg,sd_pitch_deg,sd_heading_deg";
        let row = |tow: f64, h: f64, sd: f64| {
            format!(
                "2421,{tow},47,8,800,0,60,0,1,2,{h},0.01,0.01,0.02,0.01,0.01,0.01,{sd},{sd},{}",
                2.0 * sd
            )
        };
        let text = format!(
            "# ppkat ins\n{head}\n{}\n{}\n",
            row(100.0, 90.0, 0.01),
            row(101.0, 92.0, 0.03)
        );
        let p = testkit::scratch_file("ins_attitude.csv", &text);
        let t = AttitudeTable::read_ins_csv(&p).unwrap();
        let at = gnss::time::from_week_tow(2421, 100.5);
        let r = t.at(at).unwrap();
        let expect = from_yaw_pitch_roll(91f64.to_radians(), 2f64.to_radians(), 1f64.to_radians());
        assert!((r - expect).norm() < 1e-12);
        let s = t.sigma_at(at).unwrap().map(f64::to_degrees);
        assert!(
            (s[0] - 0.02).abs() < 1e-12 && (s[2] - 0.04).abs() < 1e-12,
            "{s:?}"
        );
        let bad = testkit::scratch_file("ins_attitude_bad.csv", text.replace("sd_pitch_deg", "x"));
        let e = AttitudeTable::read_ins_csv(&bad).unwrap_err().to_string();
        assert!(e.contains("no sd_pitch_deg column"), "{e}");
    }
}
