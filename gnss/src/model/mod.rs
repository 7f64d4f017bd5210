//! Propagation models: Saastamoinen troposphere with a mapping function; Klobuchar ionosphere
//! for GPS/QZSS/Galileo users and the BeiDou variant.

pub mod antex;

use crate::frame::Geodetic;
use crate::orbit::C;
use crate::rinex::nav::Klobuchar;
use std::f64::consts::PI;

/// Slant tropospheric delay (m): Saastamoinen zenith delays in a standard atmosphere (relative
/// humidity 70 %) mapped to the elevation with a continued-fraction-like mapping function.
pub fn troposphere(pos: &Geodetic, el: f64) -> f64 {
    if pos.h < -100.0 || pos.h > 1.0e4 || el <= 0.0 {
        return 0.0;
    }
    let h = pos.h.max(0.0);
    let pres = 1013.25 * (1.0 - 2.2557e-5 * h).powf(5.2568);
    let temp = 15.0 - 6.5e-3 * h + 273.16;
    let e = 6.108 * 0.7 * ((17.15 * temp - 4684.0) / (temp - 38.45)).exp();
    let zhd = 0.0022768 * pres / (1.0 - 0.00266 * (2.0 * pos.lat).cos() - 0.00028 * h / 1e3);
    let zwd = 0.002277 * (1255.0 / temp + 0.05) * e;
    (zhd + zwd) * mapping(el)
}

/// Elevation mapping function (Black and Eisner 1984): close to 1/sin(el) above 15°, finite at
/// the horizon.
pub fn mapping(el: f64) -> f64 {
    let s = el.sin();
    1.001 / (0.002001 + s * s).sqrt()
}

/// GPS Klobuchar slant delay on L1 (m) at GPS seconds of week `tow`.
pub fn klobuchar_gps(k: &Klobuchar, pos: &Geodetic, az: f64, el: f64, tow: f64) -> f64 {
    if el <= 0.0 {
        return 0.0;
    }
    let el_sc = el / PI;
    let psi = 0.0137 / (el_sc + 0.11) - 0.022;
    let phi_i = (pos.lat / PI + psi * az.cos()).clamp(-0.416, 0.416);
    let lam_i = pos.lon / PI + psi * az.sin() / (phi_i * PI).cos();
    let phi_m = phi_i + 0.064 * ((lam_i - 1.617) * PI).cos();
    let t = (43200.0 * lam_i + tow).rem_euclid(86400.0);
    let f = 1.0 + 16.0 * (0.53 - el_sc).powi(3);
    let poly = |c: &[f64; 4]| c[0] + phi_m * (c[1] + phi_m * (c[2] + phi_m * c[3]));
    let amp = poly(&k.alpha).max(0.0);
    let per = poly(&k.beta).max(72000.0);
    let x = 2.0 * PI * (t - 50400.0) / per;
    let delay = if x.abs() < 1.57 {
        f * (5e-9 + amp * (1.0 - x * x / 2.0 + x.powi(4) / 24.0))
    } else {
        f * 5e-9
    };
    C * delay
}

/// BeiDou Klobuchar slant delay on B1I (m) at BDT seconds of week `tow_bdt`.
pub fn klobuchar_bds(k: &Klobuchar, pos: &Geodetic, az: f64, el: f64, tow_bdt: f64) -> f64 {
    if el <= 0.0 {
        return 0.0;
    }
    const R: f64 = 6378.0;
    const H: f64 = 375.0;
    let ratio = R / (R + H) * el.cos();
    let psi = PI / 2.0 - el - ratio.asin();
    let lat_i = (pos.lat.sin() * psi.cos() + pos.lat.cos() * psi.sin() * az.cos()).asin();
    let lon_i = pos.lon + (psi.sin() * az.sin() / lat_i.cos()).asin();
    let phi_m = (lat_i / PI).abs();
    let poly = |c: &[f64; 4]| c[0] + phi_m * (c[1] + phi_m * (c[2] + phi_m * c[3]));
    let a2 = poly(&k.alpha).max(0.0);
    let a4 = poly(&k.beta).clamp(72000.0, 172800.0);
    let t = (tow_bdt + lon_i * 43200.0 / PI).rem_euclid(86400.0);
    let iz = if (t - 50400.0).abs() < a4 / 4.0 {
        5e-9 + a2 * (2.0 * PI * (t - 50400.0) / a4).cos()
    } else {
        5e-9
    };
    C * iz / (1.0 - ratio * ratio).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn troposphere_is_about_2_4_m_at_zenith_at_sea_level() {
        let g = Geodetic::from_degrees(45.0, 0.0, 0.0);
        let z = troposphere(&g, PI / 2.0);
        assert!((2.3..2.6).contains(&z), "{z}");
        let low = troposphere(&g, 15f64.to_radians());
        // Curvature makes a real mapping function fall short of 1/sin(15°) = 3.86 (Niell ≈ 3.80).
        assert!((3.75..3.86).contains(&(low / z)), "{}", low / z);
    }

    #[test]
    fn klobuchar_matches_the_icd_example_magnitude() {
        // Night-time floor: 5 ns × obliquity at zenith = 1.499 m.
        let k = Klobuchar {
            alpha: [0.0; 4],
            beta: [0.0; 4],
        };
        let g = Geodetic::from_degrees(40.0, -100.0, 0.0);
        let d = klobuchar_gps(&k, &g, 0.0, PI / 2.0, 0.0);
        assert!((d - C * 5e-9 * (1.0 + 16.0 * (0.53f64 - 0.5).powi(3))).abs() < 1e-9);
        let kb = klobuchar_bds(&k, &g, 0.0, PI / 2.0, 0.0);
        assert!((kb - C * 5e-9).abs() < 1e-6);
    }
}
