//! GLONASS broadcast ephemerides: the PZ-90 state vector integrated by fourth-order Runge–Kutta
//! with J2 and the broadcast luni-solar accelerations (GLONASS ICD, appendix A.3.1.2).

use super::kepler::SatPosClock;
use crate::frame::Ecef;
use crate::rinex::nav::NavRecord;
use hifitime::Epoch;
use nalgebra::Vector3;

const MU: f64 = 3.986_004_4e14;
const J2: f64 = 1.082_625_7e-3;
const AE: f64 = 6_378_136.0;
const OMEGA: f64 = 7.292_115e-5;
const STEP: f64 = 60.0;

/// A GLONASS ephemeris: state at toe (= toc, GPST) and clock terms.
#[derive(Clone, Debug)]
pub struct GlonassEph {
    /// Slot number.
    pub slot: u8,
    /// Reference time (= toc), GPST.
    pub toe: Epoch,
    /// −τn (s) and γn from the file.
    pub minus_tau: f64,
    /// Relative frequency offset γn.
    pub gamma: f64,
    /// Position at toe, PZ-90 ≈ ECEF, metres.
    pub pos: Vector3<f64>,
    /// Velocity at toe, m/s.
    pub vel: Vector3<f64>,
    /// Luni-solar acceleration at toe, m/s².
    pub acc: Vector3<f64>,
    /// Health word Bn as written in the file.
    pub health: u32,
    /// Frequency channel number.
    pub channel: i8,
    /// Line of the record in its file.
    pub line: usize,
}

impl GlonassEph {
    /// The ephemeris of a GLONASS navigation record (None when incomplete).
    pub fn from_record(r: &NavRecord) -> Option<GlonassEph> {
        let o = &r.orbit;
        if o.len() < 12 {
            return None;
        }
        Some(GlonassEph {
            slot: r.sv.prn,
            toe: r.toc,
            minus_tau: r.clock[0],
            gamma: r.clock[1],
            pos: Vector3::new(o[0], o[4], o[8]) * 1e3,
            vel: Vector3::new(o[1], o[5], o[9]) * 1e3,
            acc: Vector3::new(o[2], o[6], o[10]) * 1e3,
            health: o[3].max(0.0) as u32,
            channel: o[7] as i8,
            line: r.line,
        })
    }

    /// Whether the health field says OK: RINEX 2.11 writes Bn with 0 = OK, RINEX 3.x the
    /// MSB of Bn (0 = healthy, 1 = unhealthy), and RTCM 1020 is decoded to the same 0/1; any
    /// value other than 0 is unhealthy, as RTKLIB reads it. (Reading values below 4 as
    /// healthy took a RINEX 3 "1 = unhealthy" satellite for a healthy one.)
    pub fn healthy(&self) -> bool {
        self.health == 0
    }

    fn deriv(&self, x: &[f64; 6]) -> [f64; 6] {
        let r2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
        let r = r2.sqrt();
        let r3 = r2 * r;
        let a = 1.5 * J2 * MU * AE * AE / (r2 * r3);
        let z2 = 5.0 * x[2] * x[2] / r2;
        let w2 = OMEGA * OMEGA;
        [
            x[3],
            x[4],
            x[5],
            -MU * x[0] / r3 - a * x[0] * (1.0 - z2) + w2 * x[0] + 2.0 * OMEGA * x[4] + self.acc.x,
            -MU * x[1] / r3 - a * x[1] * (1.0 - z2) + w2 * x[1] - 2.0 * OMEGA * x[3] + self.acc.y,
            -MU * x[2] / r3 - a * x[2] * (3.0 - z2) + self.acc.z,
        ]
    }

    fn rk4(&self, x: &mut [f64; 6], h: f64) {
        let add = |x: &[f64; 6], k: &[f64; 6], s: f64| {
            let mut y = *x;
            for i in 0..6 {
                y[i] += k[i] * s;
            }
            y
        };
        let k1 = self.deriv(x);
        let k2 = self.deriv(&add(x, &k1, h / 2.0));
        let k3 = self.deriv(&add(x, &k2, h / 2.0));
        let k4 = self.deriv(&add(x, &k3, h));
        for i in 0..6 {
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }

    /// Position, velocity and clock at GPST `t`.
    pub fn compute(&self, t: Epoch) -> SatPosClock {
        let dt = (t - self.toe).to_seconds();
        let mut x = [
            self.pos.x, self.pos.y, self.pos.z, self.vel.x, self.vel.y, self.vel.z,
        ];
        let mut left = dt;
        while left.abs() > 1e-9 {
            let h = if left.abs() < STEP {
                left
            } else {
                STEP.copysign(left)
            };
            self.rk4(&mut x, h);
            left -= h;
        }
        SatPosClock {
            pos: Ecef(Vector3::new(x[0], x[1], x[2])),
            vel: Vector3::new(x[3], x[4], x[5]),
            clock: self.minus_tau + self.gamma * dt,
            clock_rate: self.gamma,
        }
    }
}

#[cfg(test)]
mod health_tests {
    use super::GlonassEph;
    use crate::rinex::nav::{NavKind, NavRecord};
    use crate::sv::{Constellation, Sv};

    /// A record with health field `h` (orbit[3]).
    fn eph(h: f64) -> GlonassEph {
        let mut orbit = vec![0.0; 12];
        orbit[3] = h;
        let r = NavRecord {
            sv: Sv {
                sys: Constellation::Glonass,
                prn: 3,
            },
            kind: NavKind::Glonass,
            toc: hifitime::Epoch::from_gpst_seconds(1.4e9),
            clock: [0.0; 3],
            orbit,
            line: 1,
        };
        GlonassEph::from_record(&r).expect("complete record")
    }

    #[test]
    fn only_a_zero_health_field_is_healthy() {
        assert!(eph(0.0).healthy());
        // RINEX 3: 1 is the MSB of Bn, a malfunction; RINEX 2.11 writes Bn, 0 = OK.
        for h in [1.0, 2.0, 3.0, 4.0, 5.0] {
            assert!(!eph(h).healthy(), "health {h}");
        }
    }
}
