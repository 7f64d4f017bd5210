//! Precise point positioning of one receiver with precise orbits and clocks: float
//! ionosphere-free code and carrier phase in a Kalman filter (position, receiver clock,
//! zenith wet delay, one ambiguity per arc), static or kinematic.
//!
//! Enters: a RINEX observation file, [`Orbits`] with precise orbits (and clocks), ANTEX
//! files and [`PppOptions`]. Leaves: per epoch the position (marker or ARP) with its
//! covariance, the zenith total delay and the receiver clock, and counts of everything
//! rejected ([`PppResult`]). The per-satellite corrections are in `corr`, the epoch's
//! observation model in `epoch`, the filter in `filter`, the settings and reasons for
//! leaving a satellite out in `options`.

mod corr;
mod epoch;
mod filter;
mod honest;
mod options;

pub use corr::SatAntennas;
pub use options::{PppOptions, Reject};

use crate::error::{Error, Result};
use crate::frame::Ecef;
use crate::orbit::Orbits;
use crate::ppk::obs::{extract, SatMeas, SignalPlan};
use crate::ppk::slip::arc_breaks;
use crate::ppk::{Motion, Reference};
use crate::rinex::{ObsCode, ObsFile};
use crate::sv::{Constellation, Sv};
use epoch::{code_minus_geometry, prepare, rows, Ctx, Memory, Prepared, Station};
use filter::{Row, State, CLK, ZWD};
use hifitime::Epoch;
use nalgebra::{Matrix3, Vector3};
use std::collections::BTreeMap;

/// One epoch's solution.
#[derive(Clone, Debug)]
pub struct PppEpoch {
    /// Receiver time (GPST).
    pub time: Epoch,
    /// Position of the point asked for (ECEF m): in static mode the solution so far.
    pub pos: Ecef,
    /// Its covariance, m².
    pub cov: Matrix3<f64>,
    /// Satellites used.
    pub nsat: usize,
    /// Zenith total delay (m) and its σ.
    pub ztd: (f64, f64),
    /// Receiver clock, metres.
    pub clock: f64,
}

/// The result of a run.
#[derive(Clone, Debug, Default)]
pub struct PppResult {
    /// Solved epochs, in time order.
    pub epochs: Vec<PppEpoch>,
    /// Epochs of the file.
    pub input_epochs: usize,
    /// Epochs without a solution (fewer than 4 satellites usable).
    pub unsolved: usize,
    /// Satellite-epochs rejected, by reason.
    pub rejected: BTreeMap<Reject, usize>,
    /// Arc breaks (cycle slips and gaps) that restarted an ambiguity.
    pub slips: usize,
    /// Post-fit phase and code residuals: count, sum of squares (m²).
    pub residuals: [(usize, f64); 2],
    /// Warnings for the report.
    pub warnings: Vec<String>,
    /// How far the residuals are from the filter's assumptions (see `honest`).
    pub consistency: honest::Consistency,
    /// The factor applied to the filter's covariances, and the lag-one correlation of the
    /// normalised phase residuals it rests on.
    pub inflation: (f64, f64),
    /// The σ floor (horizontal, up, m) added: larger when an antenna was not modelled.
    pub floor: (f64, f64),
}

impl PppResult {
    /// RMS of the post-fit phase (`0`) or code (`1`) residuals, metres.
    pub fn residual_rms(&self, k: usize) -> f64 {
        let (n, s) = self.residuals[k];
        if n == 0 {
            0.0
        } else {
            (s / n as f64).sqrt()
        }
    }
}

/// Run PPP over an observation file. `start` is a position within some metres (a code
/// solution or the header's); `progress` counts the epochs done.
pub fn process(
    obs: &ObsFile,
    orbits: &Orbits,
    opts: &PppOptions,
    start: Ecef,
    progress: &dyn crate::progress::Progress,
) -> Result<PppResult> {
    if orbits.precise.is_none() {
        return Err(Error::input(
            &obs.path,
            "PPP needs precise orbits and clocks (--sp3, and --clk where there are clock files)",
        ));
    }
    let h = &obs.header;
    let plan = SignalPlan::new(h);
    let w1 = h
        .types_of(Constellation::Gps)
        .iter()
        .position(|c| *c == ObsCode(*b"C1W"));
    let meas: Vec<Vec<SatMeas>> = obs
        .epochs
        .iter()
        .map(|e| {
            let mut m = extract(e, h, &plan, &opts.systems, 2, &orbits.broadcast);
            prefer_p1(&mut m, e, w1);
            m
        })
        .collect();
    let times: Vec<Epoch> = obs.epochs.iter().map(|e| e.time).collect();
    let interval = h.interval.unwrap_or(30.0).max(1.0);
    let breaks = arc_breaks(&times, &meas, None, (3.0 * interval).max(10.0), true);
    let (rx_ant, mut warnings) = receiver_antenna(opts, &h.antenna);
    let d = h.antenna_delta;
    let ctx = Ctx {
        orbits,
        sat_ant: SatAntennas { files: &opts.antex },
        rx_ant,
        delta_enu: Vector3::new(d.east, d.north, d.up),
        opts,
    };
    let mut out = PppResult {
        input_epochs: times.len(),
        ..PppResult::default()
    };
    let mut mem = Memory::default();
    let mut state = State::new(start.0, 30.0, 0.0, 0.3);
    let mut last_t: Option<Epoch> = None;
    progress.set_len("PPP epochs", times.len() as u64);
    for (i, t) in times.iter().enumerate() {
        let dt = last_t.map(|l| (*t - l).to_seconds().abs()).unwrap_or(0.0);
        match epoch_step(
            *t, &meas[i], &breaks[i], dt, &ctx, &mut state, &mut mem, &mut out,
        ) {
            Some(sol) => {
                out.epochs.push(sol);
                last_t = Some(*t);
            }
            None => out.unsolved += 1,
        }
        if i % 100 == 99 || i + 1 == times.len() {
            progress.inc((i % 100 + 1) as u64);
        }
    }
    progress.finish();
    if !mem.no_antenna.is_empty() && !opts.antex.is_empty() {
        let list: Vec<String> = mem.no_antenna.iter().map(|s| s.to_string()).collect();
        warnings.push(format!(
            "no satellite antenna model for {} (no offset applied): give an ANTEX file naming them, or one assigning them to blocks",
            list.join(" ")
        ));
    }
    out.warnings.extend(warnings);
    // A static coordinate is a mean over correlated errors. A kinematic epoch rests on the
    // arcs' ambiguities, which are such means, and on its own epoch: the square root of the
    // correlation factor (calibrated on ONSA: normalised errors then have an RMS near 1).
    let k = match opts.motion {
        Motion::Static => out.consistency.inflation(),
        Motion::Kinematic => {
            out.consistency.variance_factor() * out.consistency.correlation_factor().sqrt()
        }
    };
    out.inflation = (k, out.consistency.correlation());
    out.floor = if rx_ant.is_none() || !mem.no_antenna.is_empty() {
        honest::FLOOR_UNMODELLED
    } else {
        honest::FLOOR
    };
    for e in &mut out.epochs {
        e.cov = honest::honest_cov(&e.pos, &e.cov, k, out.floor);
    }
    Ok(out)
}

/// Use the P(Y) code on L1 (C1W) when the file has it: precise clocks refer to it.
fn prefer_p1(m: &mut [SatMeas], e: &crate::rinex::ObsEpoch, w1: Option<usize>) {
    let Some(k) = w1 else { return };
    for sm in m.iter_mut().filter(|s| s.sv.sys == Constellation::Gps) {
        if let Some(s) = e.sats.iter().find(|s| s.sv == sm.sv) {
            let v = s.obs.get(k).map(|o| o.value).unwrap_or(f64::NAN);
            if v.is_finite() && v > 1.0e7 {
                sm.p[0] = v;
            }
        }
    }
}

/// The receiver antenna calibration of the header's antenna, with warnings.
fn receiver_antenna<'a>(
    opts: &'a PppOptions,
    name: &str,
) -> (Option<&'a crate::model::antex::AntennaPcv>, Vec<String>) {
    let Some(model) = opts.antex.first() else {
        return (
            None,
            vec!["no ANTEX file: no satellite or receiver antenna offsets applied (decimetres of error)".into()],
        );
    };
    let mut warnings = Vec::new();
    let cal = model.calibration(name, "receiver", &mut warnings);
    (cal, warnings)
}

/// One epoch: time update, observation model, outlier screening, measurement update.
#[allow(clippy::too_many_arguments)]
fn epoch_step(
    t: Epoch,
    meas: &[SatMeas],
    slips: &crate::ppk::slip::Slips,
    dt: f64,
    ctx: &Ctx,
    s: &mut State,
    mem: &mut Memory,
    out: &mut PppResult,
) -> Option<PppEpoch> {
    let o = ctx.opts;
    let pos = s.pos();
    let st = Station::at(&pos, t, &ctx.delta_enu);
    let sun = crate::model::astro::sun(t).0;
    let mut prep: Vec<Prepared> = Vec::new();
    for m in meas {
        match prepare(m, t, &pos, &st, &sun, ctx, mem) {
            Ok(p) => prep.push(p),
            Err(r) => *out.rejected.entry(r).or_default() += 1,
        }
    }
    // Time update.
    let zvar = s.p[(ZWD, ZWD)] + o.zwd_walk * o.zwd_walk * dt;
    s.p[(ZWD, ZWD)] = zvar;
    if o.motion == Motion::Kinematic && dt > 0.0 {
        for i in 0..3 {
            s.reset(i, pos[i], 100.0 * 100.0);
        }
    }
    // Code outliers against the median receiver clock.
    let clocks: Vec<f64> = prep
        .iter()
        .map(|p| code_minus_geometry(p, &pos, &st, s.x[ZWD]))
        .collect();
    if prep.len() < 4 {
        return None;
    }
    let mut sorted = clocks.clone();
    sorted.sort_by(f64::total_cmp);
    let clk = sorted[sorted.len() / 2];
    let tol = 30.0 + 3.0 * s.pos_cov().trace().sqrt();
    let keep: Vec<bool> = clocks.iter().map(|c| (c - clk).abs() < tol).collect();
    let mut kept = Vec::with_capacity(prep.len());
    for (p, k) in prep.into_iter().zip(&keep) {
        if *k {
            kept.push(p);
        } else {
            *out.rejected.entry(Reject::CodeOutlier).or_default() += 1;
        }
    }
    let prep = kept;
    if prep.len() < 4 {
        return None;
    }
    s.reset(CLK, clk, 100.0 * 100.0);
    // Ambiguities: drop those of satellites not used now; start new arcs.
    let used: Vec<Sv> = prep.iter().map(|p| p.sv).collect();
    for sv in s.amb.clone() {
        if !used.contains(&sv) {
            s.drop_amb(sv);
        }
    }
    for p in &prep {
        let slipped = slips
            .get(&p.sv)
            .is_some_and(|c| c[0].is_some() || c[1].is_some());
        if slipped || s.amb_index(p.sv).is_none() {
            if slipped && s.amb_index(p.sv).is_some() {
                out.slips += 1;
            }
            start_arc(s, p, &st);
            out.consistency.restart(p.sv);
        }
    }
    update(s, &prep, &st, out)?;
    let nsat = prep.len();
    Some(solution(t, s, &st, nsat, ctx))
}

/// Start a new ambiguity for `p` from its phase minus the code-based model.
fn start_arc(s: &mut State, p: &Prepared, st: &Station) {
    let model = p.model(&s.pos(), st, s.x[ZWD]).0 + s.x[CLK] + p.windup_m;
    s.add_amb(p.sv, p.l_if - model, 10.0 * 10.0);
}

/// Measurement update with screening: a phase row whose innovation exceeds 5σ restarts its
/// ambiguity; after the update, the worst post-fit phase residual beyond 4σ (and 3 cm)
/// restarts its ambiguity and the update is redone, at most five times.
fn update(s: &mut State, prep: &[Prepared], st: &Station, out: &mut PppResult) -> Option<()> {
    let r = rows(prep, s, st, true);
    let var = s.innovation_var(&r);
    for (row, v) in r.iter().zip(&var) {
        if row.phase && row.v.abs() > 5.0 * v.sqrt() {
            if let Some(p) = prep.iter().find(|p| p.sv == row.sv) {
                start_arc(s, p, st);
                out.consistency.restart(p.sv);
                *out.rejected.entry(Reject::PhaseOutlier).or_default() += 1;
            }
        }
    }
    for _ in 0..6 {
        let before = s.clone();
        let r = rows(prep, s, st, true);
        let dx = s.update(&r)?;
        let worst = worst_phase(s, &r, &dx);
        match worst {
            Some(sv) => {
                *s = before;
                out.consistency.restart(sv);
                if let Some(p) = prep.iter().find(|p| p.sv == sv) {
                    start_arc(s, p, st);
                }
                *out.rejected.entry(Reject::PhaseOutlier).or_default() += 1;
            }
            None => {
                let solved = out.epochs.len();
                for row in &r {
                    let e = s.after(row, &dx);
                    if row.phase {
                        out.consistency.add(row.sv, solved, e / row.var.sqrt());
                    }
                    let k = usize::from(!row.phase);
                    out.residuals[k].0 += 1;
                    out.residuals[k].1 += e * e;
                }
                return Some(());
            }
        }
    }
    None
}

/// The satellite of the worst post-fit phase residual beyond 4σ and 3 cm, if any.
fn worst_phase(s: &State, r: &[Row], dx: &nalgebra::DVector<f64>) -> Option<Sv> {
    r.iter()
        .filter(|row| row.phase)
        .map(|row| (row.sv, s.after(row, dx), row.var.sqrt()))
        .filter(|(_, e, sd)| e.abs() > 4.0 * sd && e.abs() > 0.03)
        .max_by(|a, b| (a.1.abs() / a.2).total_cmp(&(b.1.abs() / b.2)))
        .map(|(sv, _, _)| sv)
}

/// The epoch's solution at the point asked for.
fn solution(t: Epoch, s: &State, st: &Station, nsat: usize, ctx: &Ctx) -> PppEpoch {
    let mut pos = s.pos();
    if ctx.opts.refer == Reference::Arp {
        pos += st.enu.transpose() * ctx.delta_enu;
    }
    let (zhd, zwd0) = crate::model::zenith_delays(&st.geo);
    PppEpoch {
        time: t,
        pos: Ecef(pos),
        cov: s.pos_cov(),
        nsat,
        ztd: (zhd + zwd0 + s.x[ZWD], s.p[(ZWD, ZWD)].max(0.0).sqrt()),
        clock: s.x[CLK],
    }
}
