//! Transverse Mercator by the Krüger series to sixth order in n (Karney 2011): UTM and
//! Gauss–Krüger with any central meridian. Sub-millimetre within several degrees of the
//! central meridian.

use crate::frame::{Geodetic, WGS84_A, WGS84_F};

/// A projected position: easting and northing in metres, in the named projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projected {
    /// Easting, metres.
    pub easting: f64,
    /// Northing, metres.
    pub northing: f64,
}

/// A transverse Mercator projection of the WGS84 ellipsoid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransverseMercator {
    /// Central meridian, radians.
    pub lon0: f64,
    /// Scale on the central meridian.
    pub k0: f64,
    /// False easting, metres.
    pub false_easting: f64,
    /// False northing, metres.
    pub false_northing: f64,
}

struct Series {
    a_rect: f64,
    e: f64,
    alpha: [f64; 6],
    beta: [f64; 6],
}

fn series() -> Series {
    let n = WGS84_F / (2.0 - WGS84_F);
    let (n2, n3) = (n * n, n * n * n);
    let (n4, n5, n6) = (n3 * n, n3 * n2, n3 * n3);
    Series {
        a_rect: WGS84_A / (1.0 + n) * (1.0 + n2 / 4.0 + n4 / 64.0 + n6 / 256.0),
        e: (WGS84_F * (2.0 - WGS84_F)).sqrt(),
        alpha: [
            n / 2.0 - 2.0 * n2 / 3.0 + 5.0 * n3 / 16.0 + 41.0 * n4 / 180.0 - 127.0 * n5 / 288.0
                + 7891.0 * n6 / 37800.0,
            13.0 * n2 / 48.0 - 3.0 * n3 / 5.0 + 557.0 * n4 / 1440.0 + 281.0 * n5 / 630.0
                - 1983433.0 * n6 / 1935360.0,
            61.0 * n3 / 240.0 - 103.0 * n4 / 140.0
                + 15061.0 * n5 / 26880.0
                + 167603.0 * n6 / 181440.0,
            49561.0 * n4 / 161280.0 - 179.0 * n5 / 168.0 + 6601661.0 * n6 / 7257600.0,
            34729.0 * n5 / 80640.0 - 3418889.0 * n6 / 1995840.0,
            212378941.0 * n6 / 319334400.0,
        ],
        beta: [
            n / 2.0 - 2.0 * n2 / 3.0 + 37.0 * n3 / 96.0 - n4 / 360.0 - 81.0 * n5 / 512.0
                + 96199.0 * n6 / 604800.0,
            n2 / 48.0 + n3 / 15.0 - 437.0 * n4 / 1440.0 + 46.0 * n5 / 105.0
                - 1118711.0 * n6 / 3870720.0,
            17.0 * n3 / 480.0 - 37.0 * n4 / 840.0 - 209.0 * n5 / 4480.0 + 5569.0 * n6 / 90720.0,
            4397.0 * n4 / 161280.0 - 11.0 * n5 / 504.0 - 830251.0 * n6 / 7257600.0,
            4583.0 * n5 / 161280.0 - 108847.0 * n6 / 3991680.0,
            20648693.0 * n6 / 638668800.0,
        ],
    }
}

impl TransverseMercator {
    /// UTM zone `zone` (1–60), northern or southern hemisphere.
    pub fn utm(zone: u8, north: bool) -> Self {
        Self::utm_const(zone, north)
    }

    /// [`Self::utm`] usable in constants.
    pub const fn utm_const(zone: u8, north: bool) -> Self {
        TransverseMercator {
            lon0: ((zone as f64) * 6.0 - 183.0) * (std::f64::consts::PI / 180.0),
            k0: 0.9996,
            false_easting: 500_000.0,
            false_northing: if north { 0.0 } else { 10_000_000.0 },
        }
    }

    /// The UTM zone containing a longitude (radians), ignoring the Norway/Svalbard exceptions.
    pub fn utm_zone_of(lon: f64) -> u8 {
        let d = lon.to_degrees();
        let z = ((d + 180.0) / 6.0).floor() as i32 + 1;
        z.clamp(1, 60) as u8
    }

    /// Gauss–Krüger with the given central meridian (degrees), scale 1 and 500 km false easting.
    pub fn gauss_kruger(central_meridian_deg: f64) -> Self {
        Self::gauss_kruger_const(central_meridian_deg)
    }

    /// [`Self::gauss_kruger`] usable in constants.
    pub const fn gauss_kruger_const(central_meridian_deg: f64) -> Self {
        TransverseMercator {
            lon0: central_meridian_deg * (std::f64::consts::PI / 180.0),
            k0: 1.0,
            false_easting: 500_000.0,
            false_northing: 0.0,
        }
    }

    /// Geodetic → projected.
    pub fn forward(&self, g: &Geodetic) -> Projected {
        let s = series();
        let lam = wrap_pi(g.lon - self.lon0);
        let sphi = g.lat.sin();
        let t = ((sphi).atanh() - s.e * (s.e * sphi).atanh()).sinh();
        let xi_p = t.atan2(lam.cos());
        let eta_p = (lam.sin() / (1.0 + t * t).sqrt()).atanh();
        let (mut xi, mut eta) = (xi_p, eta_p);
        for (j, a) in s.alpha.iter().enumerate() {
            let k = 2.0 * (j as f64 + 1.0);
            xi += a * (k * xi_p).sin() * (k * eta_p).cosh();
            eta += a * (k * xi_p).cos() * (k * eta_p).sinh();
        }
        Projected {
            easting: self.false_easting + self.k0 * s.a_rect * eta,
            northing: self.false_northing + self.k0 * s.a_rect * xi,
        }
    }

    /// Projected → geodetic (height passed through).
    pub fn inverse(&self, p: &Projected, h: f64) -> Geodetic {
        let s = series();
        let xi = (p.northing - self.false_northing) / (self.k0 * s.a_rect);
        let eta = (p.easting - self.false_easting) / (self.k0 * s.a_rect);
        let (mut xi_p, mut eta_p) = (xi, eta);
        for (j, b) in s.beta.iter().enumerate() {
            let k = 2.0 * (j as f64 + 1.0);
            xi_p -= b * (k * xi).sin() * (k * eta).cosh();
            eta_p -= b * (k * xi).cos() * (k * eta).sinh();
        }
        let tau_p = xi_p.sin() / (eta_p.sinh().powi(2) + xi_p.cos().powi(2)).sqrt();
        let lam = eta_p.sinh().atan2(xi_p.cos());
        // Conformal → geodetic latitude by Newton's method on tan φ.
        let e2 = s.e * s.e;
        let mut tau = tau_p;
        for _ in 0..6 {
            let sigma = (s.e * (s.e * tau / (1.0 + tau * tau).sqrt()).atanh()).sinh();
            let tau_i = tau * (1.0 + sigma * sigma).sqrt() - sigma * (1.0 + tau * tau).sqrt();
            let dtau = (tau_p - tau_i) / (1.0 + tau_i * tau_i).sqrt()
                * (1.0 + (1.0 - e2) * tau * tau)
                / ((1.0 - e2) * (1.0 + tau * tau).sqrt());
            tau += dtau;
            if dtau.abs() < 1e-14 {
                break;
            }
        }
        Geodetic {
            lat: tau.atan(),
            lon: wrap_pi(self.lon0 + lam),
            h,
        }
    }
}

/// `a` in [−π, π], by whole turns, without a loop (a huge or infinite angle cannot hang).
fn wrap_pi(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if (-PI..=PI).contains(&a) {
        a
    } else {
        (a + PI).rem_euclid(TAU) - PI
    }
}

#[cfg(test)]
mod tests {
    use super::TransverseMercator as TM;
    use crate::frame::Geodetic;

    /// Reference values computed independently with PROJ 9 (pyproj 3.7, `+proj=utm` and
    /// `+proj=tmerc`, Poder/Engsager algorithm), printed to 0.1 mm.
    const REFERENCE: [(TM, f64, f64, f64, f64); 15] = [
        (
            TM::utm_const(32, true),
            55.49356277,
            8.45682139,
            465681.6649,
            6149850.8851,
        ),
        (TM::utm_const(32, true), 0.0, 9.0, 500000.0000, 0.0000),
        (
            TM::utm_const(32, true),
            10.0,
            3.5,
            -103652.8838,
            1110455.2103,
        ),
        (
            TM::utm_const(32, true),
            45.0,
            14.9,
            965010.3065,
            4999910.1601,
        ),
        (
            TM::utm_const(32, true),
            60.0,
            12.0,
            667294.8211,
            6655205.4836,
        ),
        (
            TM::utm_const(32, true),
            80.0,
            5.0,
            422516.2711,
            8884250.5657,
        ),
        (
            TM::utm_const(32, true),
            30.0,
            9.0001,
            500009.6448,
            3318785.3526,
        ),
        (TM::utm_const(32, true), -0.0001, 8.0, 388719.3491, -11.0547),
        (
            TM::utm_const(60, false),
            -36.41144502,
            174.63075195,
            287561.9708,
            5967806.6795,
        ),
        (
            TM::utm_const(60, false),
            -45.0,
            171.5,
            66515.6820,
            5002314.9477,
        ),
        (
            TM::utm_const(60, false),
            -10.0,
            179.9,
            817955.4277,
            8893189.3429,
        ),
        (
            TM::gauss_kruger_const(117.0),
            30.5,
            114.3,
            240756.0382,
            3378643.3668,
        ),
        (
            TM::gauss_kruger_const(117.0),
            39.9,
            116.4,
            448688.8557,
            4418598.0014,
        ),
        (
            TM::gauss_kruger_const(117.0),
            23.1,
            113.2,
            110502.9466,
            2560684.6288,
        ),
        (
            TM::gauss_kruger_const(117.0),
            45.75,
            123.0,
            966846.1437,
            5085839.8159,
        ),
    ];

    #[test]
    fn matches_proj_to_a_millimetre_within_six_degrees() {
        for (tm, lat, lon, e, n) in REFERENCE {
            let g = Geodetic::from_degrees(lat, lon, 0.0);
            let p = tm.forward(&g);
            assert!(
                (p.easting - e).abs() < 1e-3 && (p.northing - n).abs() < 1e-3,
                "{lat} {lon}: {} {} vs {e} {n}",
                p.easting,
                p.northing
            );
            let back = tm.inverse(&p, 0.0);
            assert!((back.lat.to_degrees() - lat).abs() < 1e-10, "{lat}");
            assert!((back.lon.to_degrees() - lon).abs() < 1e-10, "{lon}");
        }
        assert_eq!(TM::utm_zone_of(8.45f64.to_radians()), 32);
        assert_eq!(TM::utm(32, true), TM::utm_const(32, true));
    }
}
