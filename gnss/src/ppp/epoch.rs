//! The observation model of one epoch: ionosphere-free code and phase of every satellite
//! with both frequencies, with the satellite at its transmission time (precise orbit and
//! clock), the receiver displaced by the solid-Earth tide, both antennas' phase centres,
//! wind-up, the troposphere (Saastamoinen hydrostatic and wet a priori with Niell mapping,
//! plus the estimated zenith wet delay) and the Shapiro delay.

use super::corr::{in_shadow, sat_antenna_range, shapiro, windup, Body, SatAntennas};
use super::filter::{Row, State, ZWD};
use super::options::{PppOptions, Reject};
use crate::frame::{enu_rotation, Ecef};
use crate::model::antex::AntennaPcv;
use crate::model::{niell, zenith_delays};
use crate::orbit::{Orbits, C};
use crate::ppk::geometry::SatView;
use crate::ppk::obs::{slot_band, SatMeas};
use crate::sv::Sv;
use hifitime::Epoch;
use nalgebra::{Matrix3, Vector3};
use std::collections::BTreeMap;

/// What stays the same for the whole run.
pub(super) struct Ctx<'a> {
    /// Orbits and clocks.
    pub orbits: &'a Orbits,
    /// Satellite antenna models.
    pub sat_ant: SatAntennas<'a>,
    /// Receiver antenna calibration, when known.
    pub rx_ant: Option<&'a AntennaPcv>,
    /// ARP minus marker: ANTENNA: DELTA east, north, up (m).
    pub delta_enu: Vector3<f64>,
    /// The options.
    pub opts: &'a PppOptions,
}

/// What changes per satellite between epochs: wind-up continuity and the end of the last
/// shadow crossing.
#[derive(Default)]
pub(super) struct Memory {
    /// Last wind-up (cycles) per satellite.
    pub windup: BTreeMap<Sv, f64>,
    /// When each satellite last left the Earth's shadow (or is in it).
    pub shadow: BTreeMap<Sv, Epoch>,
    /// Satellites without a satellite antenna model (warned once).
    pub no_antenna: std::collections::BTreeSet<Sv>,
}

/// One satellite ready for the filter: its observations and the parts of the model that do
/// not depend on the state.
#[derive(Clone, Debug)]
pub(super) struct Prepared {
    /// The satellite.
    pub sv: Sv,
    /// Ionosphere-free code and phase, metres.
    pub p_if: f64,
    pub l_if: f64,
    /// Satellite at transmission.
    pub view: SatView,
    /// Everything added to range and receiver clock for both code and phase (satellite clock,
    /// antennas, hydrostatic and a-priori wet delay, Shapiro), metres.
    pub extra: f64,
    /// Wind-up in metres (phase only).
    pub windup_m: f64,
    /// Wet mapping function.
    pub wet_map: f64,
    /// Variances of the code and phase rows, m².
    pub var_p: f64,
    pub var_l: f64,
}

/// Per-epoch geometry of the receiver: the antenna reference point with tides, its
/// geodetic position, and its local axes.
pub(super) struct Station {
    /// Antenna reference point with the tide displacement (ECEF m) minus the estimated marker.
    pub offset: Vector3<f64>,
    /// Local east, north, up rotation (rows).
    pub enu: Matrix3<f64>,
    /// Geodetic position of the marker.
    pub geo: crate::frame::Geodetic,
}

impl Station {
    /// The station at marker `pos` at `t`.
    pub fn at(pos: &Vector3<f64>, t: Epoch, delta_enu: &Vector3<f64>) -> Station {
        let geo = Ecef(*pos).to_geodetic();
        let enu = enu_rotation(&geo);
        let tide = crate::model::astro::solid_tide(&Ecef(*pos), t);
        Station {
            offset: enu.transpose() * delta_enu + tide,
            enu,
            geo,
        }
    }
}

/// Ionosphere-free coefficients of two frequencies.
fn if_coeffs(f1: f64, f2: f64) -> (f64, f64) {
    let (a, b) = (f1 * f1, f2 * f2);
    (a / (a - b), -b / (a - b))
}

/// Prepare satellite `m` at receiver time `t` for a receiver at marker `pos`.
pub(super) fn prepare(
    m: &SatMeas,
    t: Epoch,
    pos: &Vector3<f64>,
    st: &Station,
    sun: &Vector3<f64>,
    ctx: &Ctx,
    mem: &mut Memory,
) -> Result<Prepared, Reject> {
    let o = ctx.opts;
    if !(m.p[0].is_finite() && m.p[1].is_finite() && m.l[0].is_finite() && m.l[1].is_finite()) {
        return Err(Reject::SingleFrequency);
    }
    let view = SatView::at(ctx.orbits, m, t).ok_or(Reject::NoOrbit)?;
    let rx = pos + st.offset;
    let (_, u) = view.range(&rx);
    let el = (st.enu * u).z.clamp(-1.0, 1.0).asin();
    if el < o.elev_mask {
        return Err(Reject::BelowMask);
    }
    if in_shadow(&view.pos, sun) {
        mem.shadow.insert(m.sv, t);
        return Err(Reject::Eclipse);
    }
    if let Some(&left) = mem.shadow.get(&m.sv) {
        if (t - left).to_seconds() < o.eclipse_wait {
            return Err(Reject::Eclipse);
        }
    }
    let body = Body::nominal(&view.pos, sun).ok_or(Reject::Eclipse)?;
    let k = -u;
    let bands = [slot_band(m.sv.sys, 0), slot_band(m.sv.sys, 1)];
    let sat_ant = match ctx.sat_ant.of(m.sv, t) {
        Some(a) => {
            sat_antenna_range(a, m.sv, bands, [m.freq[0], m.freq[1]], &body, &k).unwrap_or(0.0)
        }
        None => {
            mem.no_antenna.insert(m.sv);
            0.0
        }
    };
    let (a, b) = if_coeffs(m.freq[0], m.freq[1]);
    let az = {
        let e = st.enu * u;
        e.x.atan2(e.y)
    };
    let rx_ant = ctx
        .rx_ant
        .map(|r| {
            a * r.correction(m.sv.sys, bands[0], az, el)
                + b * r.correction(m.sv.sys, bands[1], az, el)
        })
        .unwrap_or(0.0);
    let north = st.enu.row(1).transpose();
    let west = -st.enu.row(0).transpose();
    let w = windup(&body, &k, &north, &west, mem.windup.get(&m.sv).copied());
    mem.windup.insert(m.sv, w);
    let doy = crate::ppk::geometry::day_of_year(t);
    let (zhd, zwd) = zenith_delays(&st.geo);
    let (mh, mw) = niell(&st.geo, el, doy);
    let l1 = C / m.freq[0];
    let l2 = C / m.freq[1];
    let sin2 = el.sin().powi(2).max(1e-4);
    let factor = a * a + b * b;
    let elev = 1.0 + 1.0 / sin2;
    Ok(Prepared {
        sv: m.sv,
        p_if: a * m.p[0] + b * m.p[1],
        l_if: a * l1 * m.l[0] + b * l2 * m.l[1],
        view,
        extra: -C * view.clock + sat_ant + rx_ant + shapiro(&view.pos, &rx) + zhd * mh + zwd * mw,
        windup_m: w * C / (m.freq[0] + m.freq[1]),
        wet_map: mw,
        var_p: o.sigma_code.powi(2) * factor * elev,
        var_l: o.sigma_phase.powi(2) * factor * elev + sat_var(ctx.orbits, m.sv, t, o),
    })
}

/// Variance (m²) of a satellite's orbit and interpolated clock at `t`: `sigma_sat²` plus a
/// Brownian bridge between clock records (zero at a record, largest half-way) of intensity
/// `clock_walk`.
fn sat_var(orbits: &Orbits, sv: Sv, t: Epoch, o: &PppOptions) -> f64 {
    let bridge = orbits
        .precise
        .as_ref()
        .and_then(|p| p.clock_node_distance(sv, t))
        .map(|(a, b)| {
            let span = a + b;
            if span <= 0.0 {
                0.0
            } else {
                o.clock_walk * a * b / span
            }
        })
        .unwrap_or(0.0);
    o.sigma_sat.powi(2) + bridge
}

/// Code minus model without the receiver clock, for a receiver at marker `pos`.
pub(super) fn code_minus_geometry(p: &Prepared, pos: &Vector3<f64>, st: &Station, zwd: f64) -> f64 {
    p.p_if - p.model(pos, st, zwd).0
}

impl Prepared {
    /// The modelled code range without the receiver clock, for a receiver at marker `pos`
    /// with zenith wet delay correction `zwd`, and the unit vector receiver→satellite.
    pub(super) fn model(&self, pos: &Vector3<f64>, st: &Station, zwd: f64) -> (f64, Vector3<f64>) {
        let (rho, u) = self.view.range(&(pos + st.offset));
        (rho + self.extra + self.wet_map * zwd, u)
    }
}

/// The code and phase rows of the prepared satellites against state `s`.
pub(super) fn rows(prep: &[Prepared], s: &State, st: &Station, phase: bool) -> Vec<Row> {
    let pos = s.pos();
    let mut out = Vec::with_capacity(2 * prep.len());
    for p in prep {
        let (geometry, u) = p.model(&pos, st, s.x[ZWD]);
        let model = geometry + s.x[super::filter::CLK];
        out.push(Row {
            sv: p.sv,
            phase: false,
            v: p.p_if - model,
            dpos: -u,
            dzwd: p.wet_map,
            var: p.var_p,
        });
        if let (true, Some(i)) = (phase, s.amb_index(p.sv)) {
            out.push(Row {
                sv: p.sv,
                phase: true,
                v: p.l_if - model - p.windup_m - s.x[i],
                dpos: -u,
                dzwd: p.wet_map,
                var: p.var_l,
            });
        }
    }
    out
}
