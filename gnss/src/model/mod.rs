//! Propagation models: Saastamoinen troposphere with a mapping function, its zenith delays
//! alone and the Niell (1996) hydrostatic and wet mapping functions; Klobuchar ionosphere for
//! GPS/QZSS/Galileo users and the BeiDou variant.

pub mod antex;
pub mod astro;

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
    let (zhd, zwd) = zenith_delays(pos);
    (zhd + zwd) * mapping(el)
}

/// Saastamoinen zenith hydrostatic and wet delays (m) in a standard atmosphere (1013.25 hPa,
/// 15 °C at sea level, lapse rate 6.5 K/km, relative humidity 70 %) at the height of `pos`
/// (clamped to 0–10 km).
pub fn zenith_delays(pos: &Geodetic) -> (f64, f64) {
    let h = pos.h.clamp(0.0, 1.0e4);
    let pres = 1013.25 * (1.0 - 2.2557e-5 * h).powf(5.2568);
    let temp = 15.0 - 6.5e-3 * h + 273.16;
    let e = 6.108 * 0.7 * ((17.15 * temp - 4684.0) / (temp - 38.45)).exp();
    let zhd = 0.0022768 * pres / (1.0 - 0.00266 * (2.0 * pos.lat).cos() - 0.00028 * h / 1e3);
    let zwd = 0.002277 * (1255.0 / temp + 0.05) * e;
    (zhd, zwd)
}

/// Niell's normalised continued fraction with coefficients a, b, c at sin(elevation) `s`.
fn continued_fraction(s: f64, a: f64, b: f64, c: f64) -> f64 {
    (1.0 + a / (1.0 + b / (1.0 + c))) / (s + a / (s + b / (s + c)))
}

/// Linear interpolation of a Niell coefficient tabulated at latitudes 15°, 30°, …, 75°.
fn by_latitude(table: &[f64; 5], lat_deg: f64) -> f64 {
    let x = (lat_deg.abs() / 15.0 - 1.0).clamp(0.0, 4.0);
    let i = (x.floor() as usize).min(3);
    table[i] + (table[i + 1] - table[i]) * (x - i as f64)
}

/// Niell (1996) hydrostatic and wet mapping functions at elevation `el` (radians) for a
/// receiver at `pos` on day of year `doy` (the seasonal term of the hydrostatic function is
/// shifted by half a year in the southern hemisphere; its height correction uses the
/// ellipsoidal height). Elevations below 3° are evaluated at 3°.
pub fn niell(pos: &Geodetic, el: f64, doy: f64) -> (f64, f64) {
    const H_AVG: [[f64; 5]; 3] = [
        [
            1.2769934e-3,
            1.2683230e-3,
            1.2465397e-3,
            1.2196049e-3,
            1.2045996e-3,
        ],
        [
            2.9153695e-3,
            2.9152299e-3,
            2.9288445e-3,
            2.9022565e-3,
            2.9024912e-3,
        ],
        [
            62.610505e-3,
            62.837393e-3,
            63.721774e-3,
            63.824265e-3,
            64.258455e-3,
        ],
    ];
    const H_AMP: [[f64; 5]; 3] = [
        [0.0, 1.2709626e-5, 2.6523662e-5, 3.4000452e-5, 4.1202191e-5],
        [0.0, 2.1414979e-5, 3.0160779e-5, 7.2562722e-5, 11.723375e-5],
        [0.0, 9.0128400e-5, 4.3497037e-5, 84.795348e-5, 170.37206e-5],
    ];
    const H_HEIGHT: [f64; 3] = [2.53e-5, 5.49e-3, 1.14e-3];
    const WET: [[f64; 5]; 3] = [
        [
            5.8021897e-4,
            5.6794847e-4,
            5.8118019e-4,
            5.9727542e-4,
            6.1641693e-4,
        ],
        [
            1.4275268e-3,
            1.5138625e-3,
            1.4572752e-3,
            1.5007428e-3,
            1.7599082e-3,
        ],
        [
            4.3472961e-2,
            4.6729510e-2,
            4.3908931e-2,
            4.4626982e-2,
            5.4736038e-2,
        ],
    ];
    let s = el.max(3f64.to_radians()).sin();
    let lat = pos.lat.to_degrees();
    let season = if lat < 0.0 { 365.25 / 2.0 } else { 0.0 };
    let cosy = (2.0 * PI * (doy - 28.0 + season) / 365.25).cos();
    let h: [f64; 3] =
        std::array::from_fn(|k| by_latitude(&H_AVG[k], lat) - by_latitude(&H_AMP[k], lat) * cosy);
    let w: [f64; 3] = std::array::from_fn(|k| by_latitude(&WET[k], lat));
    let height = (1.0 / s - continued_fraction(s, H_HEIGHT[0], H_HEIGHT[1], H_HEIGHT[2]))
        * pos.h.clamp(0.0, 1.0e4)
        / 1000.0;
    (
        continued_fraction(s, h[0], h[1], h[2]) + height,
        continued_fraction(s, w[0], w[1], w[2]),
    )
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

    /// Niell at the tabulated latitude 45° on its reference day: the continued fraction of the
    /// table's coefficients; 1 at zenith; a 1 km height raises the hydrostatic function at 10°
    /// by 0.004 (Niell's height correction); southern winter is northern summer.
    #[test]
    fn niell_mapping_functions() {
        let g = Geodetic::from_degrees(45.0, 10.0, 0.0);
        let (mh, mw) = niell(&g, PI / 2.0, 28.0);
        assert!((mh - 1.0).abs() < 1e-12 && (mw - 1.0).abs() < 1e-12);
        let el = 10f64.to_radians();
        let (mh, mw) = niell(&g, el, 28.0);
        let s = el.sin();
        let want_h = continued_fraction(
            s,
            1.2465397e-3 - 2.6523662e-5,
            2.9288445e-3 - 3.0160779e-5,
            63.721774e-3 - 4.3497037e-5,
        );
        assert!((mh - want_h).abs() < 1e-12, "{mh} {want_h}");
        assert!(
            (5.5..5.7).contains(&mh) && (5.5..5.8).contains(&mw),
            "{mh} {mw}"
        );
        let (mh_high, _) = niell(&Geodetic::from_degrees(45.0, 10.0, 1000.0), el, 28.0);
        assert!(((mh_high - mh) - 0.0040).abs() < 0.0002, "{}", mh_high - mh);
        let north = niell(&g, el, 200.0);
        let south = niell(
            &Geodetic::from_degrees(-45.0, 10.0, 0.0),
            el,
            200.0 - 365.25 / 2.0,
        );
        assert!((north.0 - south.0).abs() < 1e-12);
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
