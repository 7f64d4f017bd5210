//! Keplerian broadcast ephemerides: GPS LNAV, Galileo I/NAV and F/NAV, BeiDou D1/D2 (MEO, IGSO
//! and GEO), QZSS — following each system's interface document.

use crate::frame::Ecef;
use crate::rinex::nav::NavRecord;
use crate::sv::Constellation;
use crate::time::WEEK_SECONDS;
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;

/// Speed of light in vacuum, m/s.
pub const C: f64 = 299_792_458.0;
const MU_GPS: f64 = 3.986_005e14;
const MU_GAL: f64 = 3.986_004_418e14;
const MU_BDS: f64 = 3.986_004_418e14;
const OMEGA_GPS: f64 = 7.292_115_146_7e-5;
const OMEGA_BDS: f64 = 7.292_115e-5;

/// Which Galileo navigation message an ephemeris came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GalMessage {
    /// Galileo I/NAV (E1-B/E5b).
    INav,
    /// Galileo F/NAV (E5a).
    FNav,
}

/// A Keplerian broadcast ephemeris.
#[derive(Clone, Debug)]
pub struct KeplerEph {
    /// System.
    pub sys: Constellation,
    /// PRN.
    pub prn: u8,
    /// Time of clock, GPST.
    pub toc: Epoch,
    /// Time of ephemeris, GPST.
    pub toe: Epoch,
    /// Clock bias (s), drift (s/s) and drift rate (s/s²) at toc.
    pub af: [f64; 3],
    /// Issue of data (IODE / IODnav / AODE).
    pub iode: f64,
    /// Radius sine correction, metres.
    pub crs: f64,
    /// Mean motion difference, rad/s.
    pub dn: f64,
    /// Mean anomaly at toe, radians.
    pub m0: f64,
    /// Argument of latitude cosine correction, radians.
    pub cuc: f64,
    /// Eccentricity.
    pub e: f64,
    /// Argument of latitude sine correction, radians.
    pub cus: f64,
    /// Square root of the semi-major axis, √m.
    pub sqrt_a: f64,
    /// Inclination cosine correction, radians.
    pub cic: f64,
    /// Longitude of the ascending node at the week start, radians.
    pub omega0: f64,
    /// Inclination sine correction, radians.
    pub cis: f64,
    /// Inclination at toe, radians.
    pub i0: f64,
    /// Radius cosine correction, metres.
    pub crc: f64,
    /// Argument of perigee, radians.
    pub omega: f64,
    /// Rate of right ascension, rad/s.
    pub omega_dot: f64,
    /// Rate of inclination, rad/s.
    pub idot: f64,
    /// Health word as broadcast (0 healthy).
    pub health: u32,
    /// GPS/QZS TGD; Galileo BGD E5a/E1; BeiDou TGD1 (B1I/B3I).
    pub tgd1: f64,
    /// Galileo BGD E5b/E1; BeiDou TGD2 (B2I/B3I); unused for GPS.
    pub tgd2: f64,
    /// Galileo message (None for other systems).
    pub gal: Option<GalMessage>,
    /// Validity window around toe, seconds: used only for toe − before ≤ t ≤ toe + after.
    pub valid_before: f64,
    /// See `valid_before`.
    pub valid_after: f64,
    /// Line of the record in its file.
    pub line: usize,
    /// When the message was transmitted (GPST), if the record says so plausibly (from a day
    /// before toe to the end of the validity window): the later of two sets valid at a time
    /// is the fresher prediction (see [`super::Ephemerides::select`]).
    pub transmitted: Option<Epoch>,
}

/// Position, velocity and clock of a satellite at a transmission time.
#[derive(Clone, Copy, Debug)]
pub struct SatPosClock {
    /// Position, ECEF at transmission time, metres.
    pub pos: Ecef,
    /// Velocity, m/s.
    pub vel: Vector3<f64>,
    /// Clock offset in seconds, relativistic correction included, group delay not applied.
    pub clock: f64,
    /// Clock drift, s/s.
    pub clock_rate: f64,
}

/// Seconds of the system week of an epoch.
fn system_tow(sys: Constellation, t: Epoch) -> f64 {
    let t = if sys == Constellation::BeiDou {
        t - Duration::from_seconds(14.0)
    } else {
        t
    };
    crate::time::week_tow(t).1
}

/// The transmission time of a record given in seconds of week `sow`, placed at the instant
/// nearest `toe` with those seconds of (system) week; `None` when the record has no such
/// field, says it is unknown (RINEX writes 0.9999E9) or the time is implausible (more than a
/// day before toe or after the validity window, when no receiver could have received it).
fn transmission_time(
    sys: Constellation,
    toe: Epoch,
    sow: Option<f64>,
    valid_after: f64,
) -> Option<Epoch> {
    let sow = sow.filter(|s| s.is_finite() && s.abs() < 9.0e8)?;
    let mut d = (sow - system_tow(sys, toe)).rem_euclid(WEEK_SECONDS);
    if d > WEEK_SECONDS / 2.0 {
        d -= WEEK_SECONDS;
    }
    (-86_400.0..=valid_after)
        .contains(&d)
        .then(|| toe + Duration::from_seconds(d))
}

impl KeplerEph {
    /// Build from a RINEX record; `None` when the record is incomplete.
    pub fn from_record(r: &NavRecord) -> Option<KeplerEph> {
        let o = &r.orbit;
        if o.len() < 24 {
            return None;
        }
        let sys = r.sv.sys;
        // toe as the instant nearest toc with the broadcast seconds of (system) week.
        let mut d = o[8] - system_tow(sys, r.toc);
        if d > WEEK_SECONDS / 2.0 {
            d -= WEEK_SECONDS;
        } else if d < -WEEK_SECONDS / 2.0 {
            d += WEEK_SECONDS;
        }
        let toe = r.toc + Duration::from_seconds(d);
        let gal = (sys == Constellation::Galileo).then(|| {
            let src = o[17] as u32;
            if src & (1 << 8) != 0 && src & (1 << 9) == 0 {
                GalMessage::FNav
            } else {
                GalMessage::INav
            }
        });
        let fit_hours = if o.len() > 25 && sys == Constellation::Gps && o[25] > 0.0 {
            o[25]
        } else {
            4.0
        };
        // GPS: toe sits in the middle of the fit interval. Galileo: the fit runs forward from
        // about toe (measured against precise orbits: 0.9 m RMS up to toe + 3 h, 6 m already at
        // toe − 1.5 h). BeiDou: hourly uploads, used within an hour.
        let (valid_before, valid_after) = match sys {
            Constellation::Gps => (fit_hours * 1800.0, fit_hours * 1800.0),
            Constellation::Qzss => (3600.0, 3600.0),
            Constellation::Galileo => (1800.0, 3.5 * 3600.0),
            Constellation::BeiDou => (3600.0, 3600.0),
            _ => (7200.0, 7200.0),
        };
        Some(KeplerEph {
            sys,
            prn: r.sv.prn,
            toc: r.toc,
            toe,
            af: r.clock,
            iode: o[0],
            crs: o[1],
            dn: o[2],
            m0: o[3],
            cuc: o[4],
            e: o[5],
            cus: o[6],
            sqrt_a: o[7],
            cic: o[9],
            omega0: o[10],
            cis: o[11],
            i0: o[12],
            crc: o[13],
            omega: o[14],
            omega_dot: o[15],
            idot: o[16],
            health: o[21].max(0.0) as u32,
            tgd1: o[22],
            tgd2: o[23],
            gal,
            valid_before,
            valid_after,
            line: r.line,
            transmitted: transmission_time(sys, toe, o.get(24).copied(), valid_after),
        })
    }

    /// Healthy for navigation on the signals ppkat uses.
    pub fn healthy(&self) -> bool {
        match self.sys {
            // I/NAV: E1-B and E5b signal health and data validity; F/NAV: E5a.
            Constellation::Galileo => match self.gal {
                Some(GalMessage::FNav) => self.health & 0x38 == 0,
                _ => self.health & 0x1C7 == 0,
            },
            // BeiDou SatH1, QZSS and GPS six-bit health: zero is healthy.
            Constellation::Qzss => self.health & 0x3E == 0,
            _ => self.health == 0,
        }
    }

    fn constants(&self) -> (f64, f64) {
        match self.sys {
            Constellation::Galileo => (MU_GAL, OMEGA_GPS),
            Constellation::BeiDou => (MU_BDS, OMEGA_BDS),
            _ => (MU_GPS, OMEGA_GPS),
        }
    }

    /// BeiDou geostationary satellites need the special rotation of the BDS ICD.
    fn is_bds_geo(&self) -> bool {
        self.sys == Constellation::BeiDou && (self.prn <= 5 || self.prn >= 59)
    }

    /// Satellite position (ECEF at the transmission time) and clock at GPST `t`.
    pub fn compute(&self, t: Epoch) -> SatPosClock {
        let (pos, clock) = self.position_clock(t);
        // Velocity by central difference: simple and exact to well below a mm/s.
        let h = 0.001;
        let (p1, _) = self.position(t + Duration::from_seconds(h));
        let (p0, _) = self.position(t - Duration::from_seconds(h));
        let vel = (p1 - p0) / (2.0 * h);
        let dt = (t - self.toc).to_seconds();
        SatPosClock {
            pos,
            vel,
            clock,
            clock_rate: self.af[1] + 2.0 * self.af[2] * dt,
        }
    }

    /// Position and clock (s, relativistic correction included, group delay not applied) at
    /// transmission time `t` (GPST), as [`Self::compute`] gives them, without the velocity
    /// (which costs two more orbit evaluations).
    pub fn position_clock(&self, t: Epoch) -> (Ecef, f64) {
        let (pos, clk_rel) = self.position(t);
        let dt = (t - self.toc).to_seconds();
        let clock = self.af[0] + self.af[1] * dt + self.af[2] * dt * dt + clk_rel;
        (Ecef(pos), clock)
    }

    fn position(&self, t: Epoch) -> (Vector3<f64>, f64) {
        let (mu, we) = self.constants();
        let tk = (t - self.toe).to_seconds();
        let a = self.sqrt_a * self.sqrt_a;
        let n = (mu / (a * a * a)).sqrt() + self.dn;
        let m = self.m0 + n * tk;
        let mut ek = m;
        for _ in 0..30 {
            let next = m + self.e * ek.sin();
            if (next - ek).abs() < 1e-14 {
                ek = next;
                break;
            }
            ek = next;
        }
        let (se, ce) = ek.sin_cos();
        let nu = ((1.0 - self.e * self.e).sqrt() * se).atan2(ce - self.e);
        let phi = nu + self.omega;
        let (s2, c2) = (2.0 * phi).sin_cos();
        let u = phi + self.cus * s2 + self.cuc * c2;
        let r = a * (1.0 - self.e * ce) + self.crs * s2 + self.crc * c2;
        let i = self.i0 + self.idot * tk + self.cis * s2 + self.cic * c2;
        let (x, y) = (r * u.cos(), r * u.sin());
        let toe_tow = system_tow(self.sys, self.toe);
        let pos = if self.is_bds_geo() {
            let om = self.omega0 + self.omega_dot * tk - we * toe_tow;
            let (so, co) = om.sin_cos();
            let (si, ci) = i.sin_cos();
            let xg = x * co - y * ci * so;
            let yg = x * so + y * ci * co;
            let zg = y * si;
            let (s5, c5) = (-5.0f64).to_radians().sin_cos();
            let (sz, cz) = (we * tk).sin_cos();
            // Rz(ωe·tk) · Rx(−5°)
            let y1 = yg * c5 + zg * s5;
            let z1 = -yg * s5 + zg * c5;
            Vector3::new(xg * cz + y1 * sz, -xg * sz + y1 * cz, z1)
        } else {
            let om = self.omega0 + (self.omega_dot - we) * tk - we * toe_tow;
            let (so, co) = om.sin_cos();
            let (si, ci) = i.sin_cos();
            Vector3::new(x * co - y * ci * so, x * so + y * ci * co, y * si)
        };
        let f = -2.0 * mu.sqrt() / (C * C);
        (pos, f * self.e * self.sqrt_a * se)
    }

    /// Group delay to subtract from the clock for a single-frequency code on `band`
    /// (the broadcast clock refers to the system's dual-frequency reference).
    pub fn group_delay(&self, band: u8) -> f64 {
        match self.sys {
            Constellation::Gps | Constellation::Qzss => match band {
                b'1' => self.tgd1,
                b'2' => self.tgd1 * (77.0f64 / 60.0).powi(2),
                _ => 0.0,
            },
            Constellation::Galileo => match band {
                b'1' => match self.gal {
                    Some(GalMessage::FNav) => self.tgd1,
                    _ => self.tgd2,
                },
                b'5' => self.tgd1 * (1575.42f64 / 1176.45).powi(2),
                b'7' => self.tgd2 * (1575.42f64 / 1207.14).powi(2),
                _ => 0.0,
            },
            Constellation::BeiDou => match band {
                b'2' => self.tgd1,
                b'7' => self.tgd2,
                _ => 0.0,
            },
            _ => 0.0,
        }
    }
}
