//! The double-difference Kalman filter of one pass (forward or backward).
//!
//! State ([`super::state`]): rover position (ECEF, m) plus one single-difference float
//! ambiguity (cycles) per satellite and frequency slot [+ one SD slant ionosphere per
//! satellite, m, in the ionosphere-weighted model] [+ the rover's zenith wet delay, m].
//! Which optional models run was settled by [`super::process`] (`Estimate::On`/`Off` only
//! reach the filter). Double differences are formed in the
//! measurement model ([`super::measure`]) against a pivot per system and slot, so a pivot
//! change needs no state surgery. Integer resolution ([`super::ar`]) by LAMBDA with partial
//! fixing and fix-and-hold.
//!
//! One epoch ([`Filter::step`]) runs these steps in order:
//! 1. slips: per-receiver detection (the base only when its epoch changes);
//! 2. pairs: satellites seen by both receivers above the mask, with their geometry;
//! 3. prediction: position re-initialised at the code solution with a 30 m sigma (no dynamics
//!    model); ambiguities keep their values;
//! 4. ambiguity bookkeeping: resets for slips, gaps, post-fit outliers of the previous epoch
//!    (all in instantaneous mode), process noise on the others;
//! 5. new states from phase minus code (and zero ionosphere, zero zenith wet delay);
//! 6. measurement update: residuals formed at the state, the innovation gate, an iterated
//!    update (two linearisations about the prior);
//! 7. post-fit check: phase residuals above `max_phase_residual` reset their ambiguity at the
//!    next epoch; lock counts of the states observed move on;
//! 8. resolution: the float solution, replaced by the fixed one when the integers pass;
//!    the epoch's ambiguity segment ([`super::segment`]).
//!
//! Steps 6–7's post-fit checks live in `outliers`, step 8 in `resolution`.

mod outliers;
mod resolution;
mod selfcheck;

use super::ar;
use super::geometry::{day_of_year, tropo, wet_mapping, ReceiverEpoch};
use super::measure;
use super::options::{ArMode, Estimate, Motion, PpkOptions};
use super::output::{EpochSol, PassStats};
use super::pair::{has_code, observes, Pair};
use super::segment::SegmentTracker;
use super::slip::{SlipCause, Slips};
use super::smooth::{self, Prior};
use super::state::{AmbKey, State, StateKey};
use super::update::Gain;
use crate::frame::{Ecef, Geodetic};
use crate::model::antex::AntennaPcv;
use hifitime::Epoch;

/// Position change (m) of a measurement update beyond which the rows are linearised again.
const RELINEARISE: f64 = 0.05;

/// Position change (m) of a measurement update up to which the second linearisation keeps
/// the first's gain and covariance (see [`Filter::measurement_update`]): the lines of sight
/// turn by under 5·10⁻⁷ rad over it, which changes the correction by micrometres.
const GAIN_REUSE: f64 = 10.0;

/// The arc breaks one step applies (see [`super::slip::arc_breaks`]): the rover's since the
/// previous step of the pass, and the base's since the base epoch of the previous step.
#[derive(Clone, Debug, Default)]
pub struct StepSlips {
    /// Rover breaks.
    pub rover: Slips,
    /// Base breaks.
    pub base: Slips,
}

/// The rows of a measurement update's last linearisation (all of them, before the
/// innovation gate) and the state they were formed at.
struct Linearisation {
    rows: measure::Residuals,
    at: nalgebra::DVector<f64>,
}

/// Sigma of the predicted position (the code solution), metres.
const POSITION_SIGMA: f64 = 30.0;

/// Ambiguities an epoch's update may exclude for their post-fit residual before it keeps its
/// solution (the rest are reset at the next epoch).
const EXCLUSIONS: usize = 3;

/// Post-fit phase residual, in its own post-fit sigmas, beyond which a phase is taken for an
/// undetected slip (also below it when the epoch's phase residuals fail their χ² test).
const STUDENTIZED: f64 = 4.0;

/// Smallest post-fit phase residual (m) taken for an undetected slip.
const SLIP_FLOOR: f64 = 0.03;

/// Post-fit code residual, in the code's white sigmas, beyond which a satellite's code is
/// left out of the epoch (an excursion of the code: multipath of metres for seconds).
const CODE_STUDENTIZED: f64 = 5.0;

/// The filter of one pass.
pub struct Filter<'a> {
    opts: &'a PpkOptions,
    base: Ecef,
    base_geo: Geodetic,
    state: State,
    /// Ambiguities whose post-fit residual betrayed a slip: reset at the next epoch.
    pending_reset: Vec<AmbKey>,
    last_time: Option<Epoch>,
    /// Counters of the pass.
    pub stats: PassStats,
    rover_ant: Option<AntennaPcv>,
    base_ant: Option<AntennaPcv>,
    segments: SegmentTracker,
    /// Keep the state before the measurements of each step.
    record: bool,
    /// That state, of the last step.
    recorded: Option<Prior>,
    /// The position state holds an estimate (static runs keep it from epoch to epoch).
    position_started: bool,
    /// The state vector and covariance before the last measurement update (to redo it).
    before_update: Option<(nalgebra::DVector<f64>, nalgebra::DMatrix<f64>)>,
    /// The base's view of the satellites of its last epoch used, with the day of year.
    base_terms: Option<(Epoch, f64, Vec<Option<BaseTerms>>)>,
    /// The running average of the shift the code would apply to the state's position (see
    /// `selfcheck`).
    code_shift_avg: selfcheck::CodeShift,
}

/// The base's view of one satellite at one base epoch.
#[derive(Clone, Copy, Debug)]
struct BaseTerms {
    /// Azimuth and elevation at the base, radians.
    az: f64,
    el: f64,
    /// Geometric range base → satellite, metres.
    rho: f64,
    /// Base troposphere, metres.
    tropo: f64,
}

/// Ionospheric constraint of the epoch (ionosphere-weighted model), from the baseline length.
struct IonoConstraint {
    /// Prior sigma of a new SD delay, metres.
    initial_sigma: f64,
    /// Random walk, m/√s.
    process_noise: f64,
}

impl IonoConstraint {
    fn at(rover: &Ecef, base: &Ecef, o: &PpkOptions) -> Self {
        let bl_km = (rover.0 - base.0).norm() / 1000.0;
        IonoConstraint {
            initial_sigma: (o.iono_sigma_per_km * bl_km).max(0.002),
            process_noise: (o.iono_process_noise_per_km * bl_km).max(1e-5),
        }
    }
}

impl<'a> Filter<'a> {
    /// A filter for rover data against a base antenna at `base` (antenna reference point,
    /// ECEF) (the direction of the pass is only in the order of its steps and the arc breaks
    /// given to them); `segment_gap`: the step between solved epochs (s) beyond which a new
    /// ambiguity segment starts.
    pub fn new(
        opts: &'a PpkOptions,
        base: Ecef,
        antennas: (Option<AntennaPcv>, Option<AntennaPcv>),
        segment_gap: f64,
    ) -> Self {
        Filter {
            opts,
            base,
            base_geo: base.to_geodetic(),
            state: State::new(1e4),
            pending_reset: Vec::new(),
            last_time: None,
            stats: PassStats::default(),
            rover_ant: antennas.0,
            base_ant: antennas.1,
            segments: SegmentTracker::new(segment_gap),
            record: false,
            recorded: None,
            position_started: false,
            before_update: None,
            base_terms: None,
            code_shift_avg: selfcheck::CodeShift::default(),
        }
    }

    /// Process one rover epoch against a base epoch. `start` is a position to linearise about
    /// (the single-point solution), with whether the rover stood still since the pass's
    /// previous epoch; `slips` the arc breaks to apply. With `prior` (the
    /// backward pass's estimate at this epoch, before its measurements), the solution is the
    /// two-filter smoother's and is resolved without holding. None when no double
    /// difference could be formed. The state before the measurements is kept for
    /// [`Self::take_prior`].
    pub fn step(
        &mut self,
        rover: ReceiverEpoch,
        base: ReceiverEpoch,
        (start, still): (Ecef, bool),
        slips: &StepSlips,
        prior: Option<&Prior>,
    ) -> Option<EpochSol> {
        let t = rover.time;
        // The base's age: rover − base time, or an interpolated base epoch's effective age.
        let age = match (t - base.time).to_seconds() {
            a if base.age > a.abs() => base.age.copysign(a),
            a => a,
        };
        let dt = self.elapsed(t);
        let pairs = self.form_pairs(rover, base, &start);
        self.predict(&start, still, dt);
        let iono = IonoConstraint::at(&start, &self.base, self.opts);
        self.update_ambiguity_bookkeeping(t, dt, slips, iono.process_noise);
        self.add_new_states(t, &pairs, iono.initial_sigma);
        if self.record {
            self.recorded = Some(Prior::of(&self.state));
        }
        let (used_sats, last, pairs) = self.update_excluding_outliers(&pairs)?;
        if self.opts.motion == Motion::Kinematic {
            self.check_against_code(&last, dt);
        }
        self.post_fit_check(last);
        self.count_locks(t, &pairs);
        let smoothed = prior.and_then(|p| smooth::fuse(&self.state, p)).zip(prior);
        Some(self.solve(t, age, used_sats, &pairs, smoothed))
    }

    /// Keep the state before each epoch's measurements (see [`Self::take_prior`]).
    pub fn record_priors(&mut self) {
        self.record = true;
    }

    /// The state of the last step before its measurements (when recording).
    pub fn take_prior(&mut self) -> Option<Prior> {
        self.recorded.take()
    }

    /// Seconds since the previous epoch of the pass (0 at the first).
    fn elapsed(&mut self, t: Epoch) -> f64 {
        let dt = self
            .last_time
            .map(|l| (t - l).to_seconds().abs())
            .unwrap_or(0.0);
        self.last_time = Some(t);
        dt
    }

    /// Satellites seen by both receivers with an orbit, above the mask (rover elevation: an
    /// aircraft sees more sky than its base), with their geometry and antenna corrections.
    fn form_pairs(&mut self, rover: ReceiverEpoch, base: ReceiverEpoch, start: &Ecef) -> Vec<Pair> {
        let (t, tb) = (rover.time, base.time);
        let mut pairs: Vec<Pair> = Vec::new();
        let start_geo = start.to_geodetic();
        let age = (t - tb).to_seconds().abs().max(base.age);
        let age_sigma =
            self.opts.age_error_rate * age * (1.0 + (start.0 - self.base.0).norm() / 10_000.0);
        self.refresh_base_terms(&base);
        let Some((_, doy, terms)) = self.base_terms.take() else {
            return pairs;
        };
        for (r, vr) in rover.meas.iter().zip(rover.views) {
            let Some(k) = base.meas.iter().position(|b| b.sv == r.sv) else {
                continue;
            };
            let b = &base.meas[k];
            let (Some(vr), Some(vb), Some(bt)) = (*vr, base.views[k], terms[k]) else {
                self.stats.no_orbit += 1;
                continue;
            };
            let (az, el) = vr.az_el(start, &start_geo);
            let (az_b, el_b) = (bt.az, bt.el);
            if el < self.opts.elev_mask {
                self.stats.below_mask += 1;
                continue;
            }
            pairs.push(Pair {
                r: r.clone(),
                b: b.clone(),
                vr,
                vb,
                rho_b: bt.rho,
                tropo_b: bt.tropo,
                el,
                map_wet: wet_mapping(&start_geo, el, doy),
                doy,
                age_var: age_sigma * age_sigma,
                ant: std::array::from_fn(|f| {
                    let band = super::obs::slot_band(r.sv.sys, f);
                    let c = |a: &Option<AntennaPcv>, az, el| {
                        a.as_ref()
                            .map_or(0.0, |a| a.correction(r.sv.sys, band, az, el))
                    };
                    c(&self.rover_ant, az, el) - c(&self.base_ant, az_b, el_b)
                }),
            });
        }
        self.base_terms = Some((tb, doy, terms));
        pairs
    }

    /// The base's view of each satellite of base epoch `base` (azimuth, elevation, range,
    /// troposphere), computed once per base epoch: a 1 Hz base serves ten 10 Hz rover
    /// epochs. The day of year (for the mapping functions) is the base epoch's.
    fn refresh_base_terms(&mut self, base: &ReceiverEpoch) {
        if self.base_terms.as_ref().is_some_and(|c| c.0 == base.time) {
            return;
        }
        let doy = day_of_year(base.time);
        let terms = base
            .views
            .iter()
            .map(|v| {
                v.map(|vb| {
                    let (az, el) = vb.az_el(&self.base, &self.base_geo);
                    BaseTerms {
                        az,
                        el,
                        rho: vb.range(&self.base.0).0,
                        tropo: tropo(&self.base_geo, el, doy),
                    }
                })
            })
            .collect();
        self.base_terms = Some((base.time, doy, terms));
    }

    /// Prediction: kinematic, the position from the start value with a wide variance (no
    /// dynamics model), or, where the rover stood still since the epoch before (`still`),
    /// the position held with the sway's random walk over `dt` seconds; static, the position
    /// carries over once started; the other states carry over.
    fn predict(&mut self, start: &Ecef, still: bool, dt: f64) {
        if self.opts.motion == Motion::Static && self.position_started {
            return;
        }
        if still && self.position_started && self.opts.use_stillness {
            let q = self.opts.still_sigma.powi(2) * dt.max(1e-3);
            self.state.add_position_variance(q);
            return;
        }
        self.state.reset_position(&start.0, POSITION_SIGMA.powi(2));
        self.position_started = true;
    }

    /// Reset the per-satellite states touched by a slip (either receiver), a gap longer than
    /// `max_gap`, a post-fit outlier of the previous epoch, or every epoch in instantaneous
    /// mode; add process noise to the others.
    fn update_ambiguity_bookkeeping(&mut self, t: Epoch, dt: f64, slips: &StepSlips, iono_q: f64) {
        let o = self.opts;
        let slip_of = |slips: &Slips, key: StateKey| match key {
            StateKey::Ambiguity(a) => slips.get(&a.sv).and_then(|s| s[a.slot]),
            _ => None,
        };
        let mut reset = Vec::new();
        let mut noise = Vec::new();
        for (_, s) in self.state.sats() {
            if s.key == StateKey::Tropo {
                noise.push((s.key, o.tropo_process_noise.powi(2) * dt));
                continue;
            }
            if s.key == StateKey::GlonassCodeBias {
                // a receiver's code biases drift with temperature, slowly
                noise.push((s.key, 1e-8 * dt));
                continue;
            }
            let gap = (t - s.track.last).to_seconds().abs() > o.max_gap;
            if let StateKey::CodeBias(_) = s.key {
                // a satellite's bias between two codes: slips do not touch it; a satellite
                // gone for longer than a gap starts again from the prior
                if gap {
                    reset.push(s.key);
                } else {
                    noise.push((s.key, 1e-8 * dt));
                }
                continue;
            }
            let rs = slip_of(&slips.rover, s.key);
            let bs = slip_of(&slips.base, s.key);
            let pending =
                matches!(s.key, StateKey::Ambiguity(a) if self.pending_reset.contains(&a));
            if o.ar == ArMode::Instantaneous || rs.is_some() || bs.is_some() || gap || pending {
                if let Some(c) = rs.or(bs) {
                    *self.stats.slips.entry(c).or_default() += 1;
                } else if gap {
                    *self.stats.slips.entry(SlipCause::Gap).or_default() += 1;
                }
                reset.push(s.key);
            } else {
                let q = match s.key {
                    StateKey::Iono(_) => iono_q,
                    _ => o.amb_process_noise,
                };
                noise.push((s.key, q.powi(2) * dt));
            }
        }
        for (key, var) in noise {
            self.state.add_variance(key, var);
        }
        let is_ambiguity = |k: &StateKey| matches!(k, StateKey::Ambiguity(_));
        let n_ambiguities = self
            .state
            .sats()
            .filter(|(_, s)| is_ambiguity(&s.key))
            .count();
        if n_ambiguities > 0 && reset.iter().filter(|k| is_ambiguity(k)).count() == n_ambiguities {
            self.segments.note_all_reset();
        }
        self.state.remove(&reset);
        self.pending_reset.clear();
    }

    /// New SD ambiguity states from phase minus code for every slot observed on both
    /// receivers without a state; new SD ionosphere states (zero) in the ionosphere-weighted
    /// model; new SD code-bias states (zero) on the slots whose codes differ.
    fn add_new_states(&mut self, t: Epoch, pairs: &[Pair], iono_sigma0: f64) {
        let o = self.opts;
        for pr in pairs {
            for f in 0..o.nf {
                let key = StateKey::Ambiguity(AmbKey {
                    sv: pr.r.sv,
                    slot: f,
                });
                let (lr, lb) = (pr.r.l[f], pr.b.l[f]);
                if !(lr.is_finite() && lb.is_finite()) || self.state.has(key) {
                    continue;
                }
                let lam = pr.r.wavelength(f);
                let (pr_r, pr_b) = (pr.r.p[f], pr.b.p[f]);
                if !(pr_r.is_finite() && pr_b.is_finite()) {
                    continue;
                }
                let n0 = (lr - lb) - (pr_r - pr_b) / lam;
                self.state.add(key, t, n0, o.amb_init_sigma.powi(2));
            }
        }
        let glonass_code = pairs.iter().any(|p| {
            p.r.sv.sys == crate::sv::Constellation::Glonass && (0..o.nf).any(|f| has_code(p, f))
        });
        if glonass_code && !self.state.has(StateKey::GlonassCodeBias) {
            let sigma = o.glonass_code_bias_sigma;
            self.state
                .add(StateKey::GlonassCodeBias, t, 0.0, sigma * sigma);
        }
        for pr in pairs {
            for &(sys, slot) in &o.code_bias_slots {
                let key = StateKey::CodeBias(AmbKey { sv: pr.r.sv, slot });
                if pr.r.sv.sys == sys && observes(pr, key) && !self.state.has(key) {
                    self.state.add(key, t, 0.0, o.code_bias_sigma.powi(2));
                }
            }
        }
        if o.tropo == Estimate::On && !self.state.has(StateKey::Tropo) {
            self.state
                .add(StateKey::Tropo, t, 0.0, o.tropo_sigma.powi(2));
        }
        if o.iono == Estimate::On {
            for pr in pairs {
                let key = StateKey::Iono(pr.r.sv);
                if observes(pr, key) && !self.state.has(key) {
                    self.state.add(key, t, 0.0, iono_sigma0.powi(2));
                }
            }
        }
    }

    /// Iterated measurement update (a second linearisation when the first moved the position
    /// by [`RELINEARISE`] or more: the geometry hardly cares about metres of start error, but
    /// the rover troposphere does — 5 m of height is 6 mm at 15°).
    /// Each linearisation forms the residuals at the current state, passes them through the
    /// innovation gate and updates from the prior (IEKF). The second keeps the first's gain
    /// and covariance when its rows are the same and the first moved the position by
    /// [`GAIN_REUSE`] or less (the usual case: a code start metres off); it then costs a
    /// triangular solve, not a second update. Returns the number of satellites used; None
    /// when no row is left or the innovation covariance is singular.
    fn measurement_update(&mut self, pairs: &[Pair]) -> Option<(usize, Linearisation)> {
        let o = self.opts;
        let x0 = self.state.x.clone();
        let p0 = self.state.p.clone();
        let mut used_sats = 0;
        let mut first: Option<(Vec<measure::RowId>, Gain)> = None;
        let mut last = None;
        for iter in 0..2 {
            let at = self.state.position();
            let all = measure::residuals(pairs, &self.state, o);
            // Rows are copied for the gate only when it removes some (rarely).
            let gated = all
                .rows
                .iter()
                .any(|r| r.innovation.abs() > o.max_innovation)
                .then(|| measure::gate(all.clone(), o.max_innovation));
            let kept = match &gated {
                Some((kept, rejected)) => {
                    for (reason, n) in rejected {
                        *self.stats.rejected.entry(*reason).or_default() += n;
                    }
                    kept
                }
                None => &all,
            };
            let lin = kept.linearise(self.state.x.len())?;
            let ids = kept.row_ids();
            last = Some(Linearisation {
                rows: all,
                at: self.state.x.clone(),
            });
            used_sats = lin.used_sats;
            // IEKF: innovation about the prior.
            let dxi = &x0 - &self.state.x;
            let innov = &lin.v - &lin.h * &dxi;
            if let Some((_, gain)) = first.as_ref().filter(|(first_ids, _)| *first_ids == ids) {
                // The same rows, linearised [`GAIN_REUSE`] or less away: their design rows
                // differ by the turn of the lines of sight (under 5·10⁻⁷), so the first gain
                // and covariance stand; what changed is the model the innovations carry.
                self.state.x = &x0 + gain.correction(&innov);
                break;
            }
            let (dx, p, gain) = super::update::update_keeping_gain(&p0, &lin.h, &lin.r, &innov)?;
            self.state.x = &x0 + dx;
            self.state.p = p;
            let moved = (self.state.position() - at).norm();
            first = (moved <= GAIN_REUSE).then_some((ids, gain));
            // A second linearisation only when the position moved enough to change the
            // model: 5 cm of height change the troposphere by under 0.1 mm at 15°.
            if iter == 0 && moved < RELINEARISE {
                break;
            }
        }
        let p = &self.state.p;
        self.state.p = (p + p.transpose()) * 0.5;
        self.before_update = Some((x0, p0));
        Some((used_sats, last?))
    }

    /// The measurement update, redone without the code of the worst post-fit code residual
    /// (see [`Self::worst_code_outlier`]: an excursion of the code) and without the
    /// ambiguity of the worst post-fit phase residual (see [`Self::worst_phase_outlier`]: a
    /// slip no detector saw, its ambiguity is reset now, so the epoch's solution does not
    /// carry it), up to [`EXCLUSIONS`] times each. A residual that most rows of a group
    /// share is the pivot's. Returns the pairs the update used (the codes left out blank).
    fn update_excluding_outliers<'p>(
        &mut self,
        pairs: &'p [Pair],
    ) -> Option<(usize, Linearisation, std::borrow::Cow<'p, [Pair]>)> {
        // The pairs are copied only when a code is left out (rarely).
        let mut used = std::borrow::Cow::Borrowed(pairs);
        let mut out = self.measurement_update(&used)?;
        let (mut codes, mut phases) = (0, 0);
        while codes + phases < 2 * EXCLUSIONS {
            let code = (codes < EXCLUSIONS)
                .then(|| self.worst_code_outlier(&out.1))
                .flatten();
            let phase = match code {
                Some(_) => None,
                None if phases < EXCLUSIONS => self.worst_phase_outlier(&out.1),
                None => None,
            };
            if code.is_none() && phase.is_none() {
                break;
            }
            // Back to the state before the update (its layout is unchanged), without `bad`.
            let (x0, p0) = self.before_update.take()?;
            self.state.x = x0;
            self.state.p = p0;
            if let Some(bad) = code {
                if let Some(p) = used.to_mut().iter_mut().find(|p| p.r.sv == bad.sv) {
                    p.r.p[bad.slot] = f64::NAN;
                }
                self.stats.code_outliers += 1;
                codes += 1;
            }
            if let Some(bad) = phase {
                self.state.remove(&[StateKey::Ambiguity(bad)]);
                self.stats.outlier_resets += 1;
                phases += 1;
            }
            out = self.measurement_update(&used)?;
        }
        Some((out.0, out.1, used))
    }

    /// Lock counts and last-seen epochs of the states observed this epoch; ambiguities kept
    /// float for a half cycle counted.
    fn count_locks(&mut self, t: Epoch, pairs: &[Pair]) {
        let mut half = 0;
        for (key, track) in self.state.tracks_mut() {
            if let Some(p) = pairs.iter().find(|p| observes(p, key)) {
                track.lock += 1;
                track.last = t;
                if let StateKey::Ambiguity(a) = key {
                    half += usize::from(ar::half_cycle(p, a.slot));
                }
            }
        }
        if self.opts.half_cycle_float {
            self.stats.half_cycle_float += half;
        }
    }
}
