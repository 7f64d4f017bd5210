//! What an IMU's data sheet says, in SI units inside: angle and velocity random walk (white
//! noise on the rates), bias instability (the standard deviation of a first-order
//! Gauss–Markov bias with the given correlation time) and the turn-on bias (a constant drawn
//! once per run). Presets per grade, or a TOML file whose keys name their units:
//!
//! ```toml
//! name = "my IMU"
//! arw_deg_per_sqrt_h = 0.05
//! vrw_mps_per_sqrt_h = 0.03
//! gyro_bias_instability_deg_per_h = 1.0
//! accel_bias_instability_mg = 0.1
//! bias_correlation_s = 3600
//! gyro_turn_on_deg_per_h = 3.0
//! accel_turn_on_mg = 1.0
//! ```

use crate::error::{Error, Result};
use serde::Deserialize;
use std::path::Path;

/// Standard gravity, m/s² per g (data sheets' mg).
pub const G0: f64 = 9.806_65;
const DEG_PER_H: f64 = std::f64::consts::PI / 180.0 / 3600.0;
const PER_SQRT_H: f64 = 1.0 / 60.0;

/// An IMU grade with a preset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grade {
    /// Navigation grade (ring-laser or fibre-optic gyros of 0.01 °/h class).
    Navigation,
    /// Tactical grade (the airborne survey systems' 1 °/h class).
    Tactical,
    /// MEMS (consumer and industrial chips, 10 °/h class).
    Mems,
}

impl Grade {
    /// The grade of a name: `navigation`, `tactical` or `mems`.
    pub fn parse(s: &str) -> Option<Grade> {
        match s.to_ascii_lowercase().as_str() {
            "navigation" | "nav" => Some(Grade::Navigation),
            "tactical" => Some(Grade::Tactical),
            "mems" => Some(Grade::Mems),
            _ => None,
        }
    }
}

/// An IMU's noise and bias figures, SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuSpec {
    /// What the figures describe.
    pub name: String,
    /// Angle random walk, rad/√s.
    pub arw: f64,
    /// Velocity random walk, m/s/√s.
    pub vrw: f64,
    /// Gyro bias instability (σ of the Gauss–Markov bias), rad/s.
    pub gyro_bias: f64,
    /// Accelerometer bias instability, m/s².
    pub accel_bias: f64,
    /// Correlation time of both biases, s.
    pub bias_correlation: f64,
    /// Gyro turn-on bias σ, rad/s.
    pub gyro_turn_on: f64,
    /// Accelerometer turn-on bias σ, m/s².
    pub accel_turn_on: f64,
}

impl ImuSpec {
    /// The figures with the angle and velocity random walks multiplied by `k` (the biases'
    /// figures kept: raising them too let the biases wander and bridged the car's outages
    /// worse), named so.
    pub fn scaled(&self, k: f64) -> ImuSpec {
        ImuSpec {
            name: format!("{} (noise ×{k:.1})", self.name),
            arw: self.arw * k,
            vrw: self.vrw * k,
            ..self.clone()
        }
    }
}

/// The file's form: every key with its unit in its name, all required.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    name: String,
    arw_deg_per_sqrt_h: f64,
    vrw_mps_per_sqrt_h: f64,
    gyro_bias_instability_deg_per_h: f64,
    accel_bias_instability_mg: f64,
    bias_correlation_s: f64,
    gyro_turn_on_deg_per_h: f64,
    accel_turn_on_mg: f64,
}

impl ImuSpec {
    /// The figures of a grade: typical data-sheet values of its class.
    pub fn preset(g: Grade) -> ImuSpec {
        let (name, file) = match g {
            Grade::Navigation => (
                "navigation grade",
                [0.002, 0.002, 0.005, 0.025, 3600.0, 0.01, 0.05],
            ),
            Grade::Tactical => ("tactical grade", [0.05, 0.03, 1.0, 0.1, 3600.0, 3.0, 1.0]),
            Grade::Mems => ("MEMS grade", [0.3, 0.1, 10.0, 0.2, 300.0, 360.0, 20.0]),
        };
        ImuSpec::from_file_units(&SpecFile {
            name: name.to_string(),
            arw_deg_per_sqrt_h: file[0],
            vrw_mps_per_sqrt_h: file[1],
            gyro_bias_instability_deg_per_h: file[2],
            accel_bias_instability_mg: file[3],
            bias_correlation_s: file[4],
            gyro_turn_on_deg_per_h: file[5],
            accel_turn_on_mg: file[6],
        })
    }

    fn from_file_units(f: &SpecFile) -> ImuSpec {
        ImuSpec {
            name: f.name.clone(),
            arw: f.arw_deg_per_sqrt_h * std::f64::consts::PI / 180.0 * PER_SQRT_H,
            vrw: f.vrw_mps_per_sqrt_h * PER_SQRT_H,
            gyro_bias: f.gyro_bias_instability_deg_per_h * DEG_PER_H,
            accel_bias: f.accel_bias_instability_mg * 1e-3 * G0,
            bias_correlation: f.bias_correlation_s,
            gyro_turn_on: f.gyro_turn_on_deg_per_h * DEG_PER_H,
            accel_turn_on: f.accel_turn_on_mg * 1e-3 * G0,
        }
    }

    /// The figures of a TOML file (see the module's text); every key required, none unknown,
    /// every value finite and not negative, the correlation time positive.
    pub fn from_file(path: &Path) -> Result<ImuSpec> {
        let text = std::fs::read_to_string(path).map_err(|cause| Error::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        let bad = |message: String| Error::Input {
            path: path.to_path_buf(),
            message,
        };
        let f: SpecFile = toml::from_str(&text).map_err(|e| {
            bad(format!(
                "not an IMU specification: {e}(the keys, with their units: name, arw_deg_per_sqrt_h, vrw_mps_per_sqrt_h, gyro_bias_instability_deg_per_h, accel_bias_instability_mg, bias_correlation_s, gyro_turn_on_deg_per_h, accel_turn_on_mg)"
            ))
        })?;
        let values = [
            ("arw_deg_per_sqrt_h", f.arw_deg_per_sqrt_h),
            ("vrw_mps_per_sqrt_h", f.vrw_mps_per_sqrt_h),
            (
                "gyro_bias_instability_deg_per_h",
                f.gyro_bias_instability_deg_per_h,
            ),
            ("accel_bias_instability_mg", f.accel_bias_instability_mg),
            ("bias_correlation_s", f.bias_correlation_s),
            ("gyro_turn_on_deg_per_h", f.gyro_turn_on_deg_per_h),
            ("accel_turn_on_mg", f.accel_turn_on_mg),
        ];
        for (key, v) in values {
            if !v.is_finite() || v < 0.0 || (key == "bias_correlation_s" && v == 0.0) {
                return Err(bad(format!(
                    "{key} = {v}: give a finite value, not negative (the correlation time positive)"
                )));
            }
        }
        Ok(ImuSpec::from_file_units(&f))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Units convert as named: 1 °/√h is 2.909e-4 rad/√s, 1 °/h 4.848e-6 rad/s, 1 mg
    /// 9.807e-3 m/s²; the grades order as their names say.
    #[test]
    fn presets_convert_and_order() {
        let t = ImuSpec::preset(Grade::Tactical);
        assert!((t.arw - 0.05 * 2.908_882e-4).abs() < 1e-10);
        assert!((t.gyro_bias - 4.848_137e-6).abs() < 1e-11);
        assert!((t.accel_bias - 0.1e-3 * G0).abs() < 1e-12);
        let n = ImuSpec::preset(Grade::Navigation);
        let m = ImuSpec::preset(Grade::Mems);
        assert!(n.gyro_bias < t.gyro_bias && t.gyro_bias < m.gyro_bias);
        assert!(n.arw < t.arw && t.arw < m.arw);
        assert_eq!(Grade::parse("MEMS"), Some(Grade::Mems));
        assert_eq!(Grade::parse("consumer"), None);
    }

    #[test]
    fn a_file_reads_and_a_bad_one_says_which_key() {
        let dir = testkit::scratch_path("ins_spec");
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("imu.toml");
        std::fs::write(
            &good,
            "name = \"x\"\narw_deg_per_sqrt_h = 0.05\nvrw_mps_per_sqrt_h = 0.03\ngyro_bias_instability_deg_per_h = 1.0\naccel_bias_instability_mg = 0.1\nbias_correlation_s = 3600\ngyro_turn_on_deg_per_h = 3.0\naccel_turn_on_mg = 1.0\n",
        )
        .unwrap();
        let s = ImuSpec::from_file(&good).unwrap();
        assert_eq!(
            s,
            ImuSpec {
                name: "x".into(),
                ..ImuSpec::preset(Grade::Tactical)
            }
        );
        let neg = dir.join("neg.toml");
        std::fs::write(
            &neg,
            std::fs::read_to_string(&good)
                .unwrap()
                .replace("= 0.1", "= -0.1"),
        )
        .unwrap();
        let e = ImuSpec::from_file(&neg).unwrap_err().to_string();
        assert!(
            e.contains("neg.toml") && e.contains("accel_bias_instability_mg"),
            "{e}"
        );
        let unit = dir.join("unit.toml");
        std::fs::write(
            &unit,
            std::fs::read_to_string(&good)
                .unwrap()
                .replace("arw_deg_per_sqrt_h", "arw"),
        )
        .unwrap();
        let e = ImuSpec::from_file(&unit).unwrap_err().to_string();
        assert!(
            e.contains("unit.toml") && e.contains("arw_deg_per_sqrt_h"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
