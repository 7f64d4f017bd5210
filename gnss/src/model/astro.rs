//! Where the Sun and the Moon are (low-precision analytical series, good to about 0.01° for
//! the Sun and a few arc minutes for the Moon, ample for satellite attitude and tides), the
//! Earth's rotation angle, and the displacement of a station by the solid-Earth tide
//! (IERS Conventions 2010, section 7.1.1, step 1: degree-2 and degree-3 in-phase terms with
//! the latitude dependence of the Love numbers; conventional tide-free, as ITRF positions).

use crate::frame::Ecef;
use hifitime::Epoch;
use nalgebra::Vector3;

/// Mean obliquity of the ecliptic at J2000, radians.
const OBLIQUITY: f64 = 23.439_291_11 * std::f64::consts::PI / 180.0;
/// Earth's equatorial radius (IERS), metres.
const EARTH_RADIUS: f64 = 6_378_136.6;
/// Moon-to-Earth and Sun-to-Earth gravitational parameter ratios.
const MOON_EARTH: f64 = 0.012_300_037_1;
const SUN_EARTH: f64 = 332_946.048_2;

/// Arc seconds to radians.
fn arcsec(v: f64) -> f64 {
    (v / 3600.0).to_radians()
}

/// Greenwich mean sidereal angle (radians) at `t` (UT1 taken as UTC: < 1 s, 0.004°).
pub fn gmst(t: Epoch) -> f64 {
    let d = t.to_jde_utc_days() - 2_451_545.0;
    (280.460_618_37 + 360.985_647_366_29 * d)
        .rem_euclid(360.0)
        .to_radians()
}

/// Rotate an equatorial vector of date into the Earth-fixed frame at `t`.
fn to_earth_fixed(v: Vector3<f64>, t: Epoch) -> Ecef {
    let (s, c) = gmst(t).sin_cos();
    Ecef(Vector3::new(c * v.x + s * v.y, -s * v.x + c * v.y, v.z))
}

/// An ecliptic position (longitude, latitude, distance) as an equatorial vector.
fn from_ecliptic(lon: f64, lat: f64, r: f64) -> Vector3<f64> {
    let v = Vector3::new(
        r * lat.cos() * lon.cos(),
        r * lat.cos() * lon.sin(),
        r * lat.sin(),
    );
    let (s, c) = OBLIQUITY.sin_cos();
    Vector3::new(v.x, c * v.y - s * v.z, s * v.y + c * v.z)
}

/// The Sun, Earth-fixed (metres), at `t`.
pub fn sun(t: Epoch) -> Ecef {
    let tc = t.to_tt_centuries_j2k();
    let m = (357.5256 + 35_999.049 * tc).to_radians();
    // Longitude referred to the equinox of date (the 1.3972°/century of precession added).
    let lon = (282.94 + 1.3972 * tc).to_radians()
        + m
        + arcsec(6892.0) * m.sin()
        + arcsec(72.0) * (2.0 * m).sin();
    let r = (149.619 - 2.499 * m.cos() - 0.021 * (2.0 * m).cos()) * 1.0e9;
    to_earth_fixed(from_ecliptic(lon, 0.0, r), t)
}

/// The Moon, Earth-fixed (metres), at `t`.
pub fn moon(t: Epoch) -> Ecef {
    let tc = t.to_tt_centuries_j2k();
    let deg = |a: f64, b: f64| (a + b * tc).to_radians();
    let l0 = deg(218.316_17, 481_267.880_88);
    let l = deg(134.962_92, 477_198.867_53);
    let lp = deg(357.525_43, 35_999.049_44);
    let f = deg(93.272_83, 483_202.018_73);
    let d = deg(297.850_27, 445_267.111_35);
    let terms_lon = [
        (22640.0, l),
        (769.0, 2.0 * l),
        (-4586.0, l - 2.0 * d),
        (2370.0, 2.0 * d),
        (-668.0, lp),
        (-412.0, 2.0 * f),
        (-212.0, 2.0 * l - 2.0 * d),
        (-206.0, l + lp - 2.0 * d),
        (192.0, l + 2.0 * d),
        (-165.0, lp - 2.0 * d),
        (148.0, l - lp),
        (-125.0, d),
        (-110.0, l + lp),
        (-55.0, 2.0 * f - 2.0 * d),
    ];
    let lon = l0
        + terms_lon
            .iter()
            .map(|(a, x)| arcsec(*a) * x.sin())
            .sum::<f64>();
    let terms_lat = [
        (-526.0, f - 2.0 * d),
        (44.0, l + f - 2.0 * d),
        (-31.0, -l + f - 2.0 * d),
        (-25.0, -2.0 * l + f),
        (-23.0, lp + f - 2.0 * d),
        (21.0, -l + f),
        (11.0, -lp + f - 2.0 * d),
    ];
    let main = f + lon - l0 + arcsec(412.0) * (2.0 * f).sin() + arcsec(541.0) * lp.sin();
    let lat = arcsec(18520.0) * main.sin()
        + terms_lat
            .iter()
            .map(|(a, x)| arcsec(*a) * x.sin())
            .sum::<f64>();
    let terms_r = [
        (-20905.0, l),
        (-3699.0, 2.0 * d - l),
        (-2956.0, 2.0 * d),
        (-570.0, 2.0 * l),
        (246.0, 2.0 * l - 2.0 * d),
        (-205.0, lp - 2.0 * d),
        (-171.0, l + 2.0 * d),
        (-152.0, l + lp - 2.0 * d),
    ];
    let r = (385_000.0 + terms_r.iter().map(|(a, x)| a * x.cos()).sum::<f64>()) * 1.0e3;
    to_earth_fixed(from_ecliptic(lon, lat, r), t)
}

/// Displacement (ECEF metres) of a station at `pos` by the solid-Earth tide at `t`.
pub fn solid_tide(pos: &Ecef, t: Epoch) -> Vector3<f64> {
    let r = pos.0.norm();
    if r < 1.0e6 {
        return Vector3::zeros();
    }
    let up = pos.0 / r;
    let p2 = (3.0 * up.z * up.z - 1.0) / 2.0; // (3 sin²φ − 1)/2 with sin φ ≈ z/r
    let h2 = 0.6078 - 0.0006 * p2;
    let l2 = 0.0847 + 0.0002 * p2;
    let (h3, l3) = (0.292, 0.015);
    let mut out = Vector3::zeros();
    for (body, ratio) in [(moon(t), MOON_EARTH), (sun(t), SUN_EARTH)] {
        let dist = body.0.norm();
        let b = body.0 / dist;
        let c = b.dot(&up);
        let across = b - c * up;
        let f2 = ratio * EARTH_RADIUS.powi(4) / dist.powi(3);
        out += f2 * (h2 * up * (1.5 * c * c - 0.5) + 3.0 * l2 * c * across);
        let f3 = ratio * EARTH_RADIUS.powi(5) / dist.powi(4);
        out += f3 * (h3 * up * (2.5 * c.powi(3) - 1.5 * c) + l3 * (7.5 * c * c - 1.5) * across);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::gpst;

    #[test]
    fn sun_and_moon_where_almanacs_put_them() {
        // 2005-08-12 12:00 GPST: the Sun at declination +15.0°, 1.0135 AU; near local noon
        // at longitude ~0° (equation of time −5 min: 1.25° east); the Moon 6 days after new moon.
        let t = gpst(2005, 8, 12, 12, 0, 0, 0);
        let s = sun(t).0;
        let dec = (s.z / s.norm()).asin().to_degrees();
        assert!((dec - 15.0).abs() < 0.2, "Sun declination {dec}");
        assert!((s.norm() / 1.495_978_707e11 - 1.0135).abs() < 0.001);
        let lon = s.y.atan2(s.x).to_degrees();
        assert!((lon - 1.25).abs() < 0.3, "Sun over longitude {lon}");
        let m = moon(t).0;
        assert!((3.5e8..4.1e8).contains(&m.norm()));
        let elong = (m.normalize().dot(&s.normalize())).acos().to_degrees();
        assert!(
            (60.0..100.0).contains(&elong),
            "Moon–Sun elongation {elong}"
        );
    }

    #[test]
    fn solid_tide_has_the_textbook_size() {
        // Up to a few decimetres up and a few centimetres sideways over a day, about a mean
        // that is the permanent tide: −(0.1206 m)·P2(sin φ) = −6.8 cm at 57.4° (IERS 7.14a).
        let pos = crate::frame::Geodetic::from_degrees(57.4, 11.9, 45.0).to_ecef();
        let mut max_up = f64::MIN;
        let mut min_up = f64::MAX;
        let mut sum = 0.0;
        for h in 0..48 {
            let t =
                gpst(2005, 8, 12, 0, 0, 0, 0) + hifitime::Duration::from_seconds(h as f64 * 1800.0);
            let d = solid_tide(&pos, t);
            let u = d.dot(&pos.0.normalize());
            max_up = max_up.max(u);
            min_up = min_up.min(u);
            sum += u;
            assert!((d - u * pos.0.normalize()).norm() < 0.1);
        }
        let mean = sum / 48.0;
        assert!((mean + 0.068).abs() < 0.03, "mean {mean}");
        assert!((0.1..0.5).contains(&(max_up - min_up)), "{min_up}…{max_up}");
    }
}
