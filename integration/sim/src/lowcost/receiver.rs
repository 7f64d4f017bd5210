//! A low-cost receiver as it tracks: C/N0 from elevation, lowered under trees; losses of lock
//! when it falls and new arcs when it comes back; a half-cycle ambiguity unresolved for the
//! first seconds of every arc (the phase then half a cycle off in half of them, the
//! RINEX LLI bit 1 set until the receiver resolves it and removes the half cycle); the odd
//! slip the receiver does not flag; code and phase noise and multipath that grow as C/N0
//! falls, multipath correlated in time; GLONASS inter-channel biases of its own.
//!
//! Enters: the receiver ([`LowCost`]: where it is at a true time, its clock, rate, bands, the
//! canopy over it, its [`Profile`]), the ephemerides and Klobuchar parameters of the
//! synthetic constellation. Leaves: the RINEX 3.04 text of its observations (time tags in
//! receiver time = true time + clock offset; the epochs `keep` lets through) and
//! [`TrackStats`] (half-cycle shares per system, C/N0 percentiles, arcs and slips) to check
//! the bench against the real figures it imitates.

use super::super::gnss_obs::{frequencies, geometry};
use super::super::obs_text::{header, write_epoch_bands, HeaderInfo, SatObs};
use super::super::rng::Rng;
use super::impair::{open_cn0, ClockSeries, Impairments, SatImpair};
use gnss::frame::{az_el, Ecef};
use gnss::model::{klobuchar_gps, troposphere};
use gnss::orbit::{Ephemerides, C};
use gnss::rinex::nav::Klobuchar;
use gnss::sv::{Constellation, Sv};
use gnss::time::week_tow;
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;
use std::collections::BTreeMap;

const F1: f64 = 1575.42e6;

/// How a receiver tracks and how noisy it is.
#[derive(Clone, Copy, Debug)]
pub struct Profile {
    /// C/N0 at the horizon and at the zenith under open sky, dB-Hz.
    pub cn0: (f64, f64),
    /// Mean loss under dense canopy, dB, and its spread (a Gauss–Markov process per
    /// satellite, dB, correlation time s).
    pub canopy_db: (f64, f64, f64),
    /// C/N0 below which the phase is lost, and at or above which a lost phase is acquired
    /// again, dB-Hz.
    pub lock: (f64, f64),
    /// Seconds an arc's half-cycle ambiguity stays unresolved (uniform in this range):
    /// GPS/QZSS, GLONASS (whose strings mark the bit edges more often).
    pub half_s: [(f64, f64); 2],
    /// The chance that an arc's phase is half a cycle off while its half cycle is unresolved
    /// (the loop locked on the other polarity).
    pub half_offset_probability: f64,
    /// Slips the receiver does not flag, per second of tracking below 32 dB-Hz.
    pub unflagged_slip_rate: f64,
    /// Code noise and code multipath at 45 dB-Hz (metres; both grow as 10^((45 − C/N0)/20)),
    /// multipath correlation time (s).
    pub code: (f64, f64, f64),
    /// Phase noise and phase multipath at 45 dB-Hz (metres, growing as the code's, the
    /// multipath capped at 3 cm), multipath correlation time (s).
    pub phase: (f64, f64, f64),
    /// Doppler noise at 45 dB-Hz, Hz.
    pub doppler: f64,
    /// GLONASS inter-channel biases: phase, code (metres per frequency channel number).
    pub glonass_icb: (f64, f64),
}

/// The receiver to simulate.
pub struct LowCost<'a> {
    /// Marker name.
    pub name: &'a str,
    /// Antenna position and velocity (ECEF, m and m/s) at a true GPST time.
    pub at: &'a dyn Fn(Epoch) -> (Ecef, Vector3<f64>),
    /// Canopy over the antenna (0 open … 1 dense) at seconds since `start`.
    pub canopy: &'a dyn Fn(f64) -> f64,
    /// Clock offset at the start (s) and drift (s/s).
    pub clock: (f64, f64),
    /// First and last epoch (receiver time, GPST) and the interval (s).
    pub span: (Epoch, Epoch, f64),
    /// Bands observed: 1 (L1) or 2 (L1 and L2).
    pub bands: usize,
    /// Elevation below which nothing is tracked, degrees.
    pub mask_deg: f64,
    /// How it tracks.
    pub profile: Profile,
    /// What the atmosphere holds beyond the broadcast models at this antenna, for a
    /// satellite at (azimuth, elevation) radians at a true time: the L1 ionosphere as a
    /// factor on Klobuchar's, and an extra slant troposphere (metres). `None`: the models.
    pub atmosphere: Option<&'a dyn Fn(Epoch, f64, f64) -> (f64, f64)>,
    /// The receiver's code biases on each band, metres (they differ between receiver types
    /// and do not cancel between two of them).
    pub code_bias: [f64; 2],
    /// Which GPS L1 code it tracks.
    pub gps_l1: GpsL1,
    /// What it does beyond the tracking model, as real receivers were measured to (its
    /// clock, losses of lock, unflagged jumps, code excursions …); None: the model alone.
    pub impair: Option<Impairments>,
}

/// The GPS L1 code a receiver tracks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpsL1 {
    /// C/A (`C1C`) as referred to P(Y): the flight and low-cost benches, whose two
    /// receivers are alike (each satellite's P1−C1 bias would cancel between them).
    CaAsP,
    /// C/A (`C1C`) with each satellite's own C1 − P1 bias ([`c1_p1_bias`]): what a C/A
    /// receiver measures against a P(Y) receiver.
    Ca,
    /// P(Y) code (`C1W`; the phase written as `L1C`, as RINEX 2 files write `L1` beside
    /// `P1`): a geodetic receiver's P1.
    P,
}

impl GpsL1 {
    /// The RINEX attribute of its code.
    pub fn attribute(self) -> u8 {
        match self {
            GpsL1::CaAsP | GpsL1::Ca => b'C',
            GpsL1::P => b'W',
        }
    }
}

/// A GPS satellite's C1 − P1 code bias, metres: what its C/A code reads longer than its
/// P(Y) code (the published P1−C1 bias with the opposite sign). Drawn once per PRN (normal,
/// σ 0.3 m, i.e. 1 ns, the spread of the published monthly values), the same for every
/// receiver and run.
pub fn c1_p1_bias(sv: Sv) -> f64 {
    0.3 * Rng::new(0x5031_4331 + u64::from(sv.prn)).normal()
}

/// What a receiver's simulation holds, to compare the bench with the real cases.
#[derive(Clone, Debug, Default)]
pub struct TrackStats {
    /// Epochs written.
    pub epochs: usize,
    /// Phase observations per system (L1), and how many carried an unresolved half cycle.
    pub phases: BTreeMap<Constellation, (usize, usize)>,
    /// Every L1 C/N0 written, dB-Hz.
    pub cn0: Vec<f64>,
    /// Satellites tracked per written epoch.
    pub sats_per_epoch: Vec<usize>,
    /// Arcs started after a loss of lock (the first arc of each satellite not counted).
    pub reacquisitions: usize,
    /// Slips the receiver did not flag.
    pub unflagged_slips: usize,
    /// The true reception time of each written epoch (its tag less the clock bias).
    pub instants: Vec<Epoch>,
}

impl TrackStats {
    /// The `p`-th percentile (0–100) of the L1 C/N0 written.
    pub fn cn0_percentile(&self, p: f64) -> f64 {
        let mut v = self.cn0.clone();
        v.sort_by(f64::total_cmp);
        v.get(((v.len().max(1) - 1) as f64 * p / 100.0).round() as usize)
            .copied()
            .unwrap_or(f64::NAN)
    }

    /// Satellites tracked in a median epoch (0 without epochs).
    pub fn median_sats(&self) -> usize {
        let mut v = self.sats_per_epoch.clone();
        v.sort_unstable();
        v.get(v.len() / 2).copied().unwrap_or(0)
    }

    /// Share (0–1) of a system's phases with an unresolved half cycle.
    pub fn half_share(&self, sys: Constellation) -> f64 {
        self.phases
            .get(&sys)
            .map_or(0.0, |&(n, h)| h as f64 / n.max(1) as f64)
    }
}

/// A Gauss–Markov process of correlation time `tau` and standard deviation `sigma`.
#[derive(Clone, Copy, Debug)]
struct Markov {
    x: f64,
    sigma: f64,
    tau: f64,
}

impl Markov {
    fn new(sigma: f64, tau: f64, rng: &mut Rng) -> Markov {
        Markov {
            x: sigma * rng.normal(),
            sigma,
            tau,
        }
    }
    fn step(&mut self, dt: f64, rng: &mut Rng) -> f64 {
        let a = (-dt / self.tau).exp();
        self.x = a * self.x + self.sigma * (1.0 - a * a).sqrt() * rng.normal();
        self.x
    }
}

/// One satellite as the receiver tracks it.
struct Sat {
    amb: [f64; 2],
    locked: bool,
    /// Locked at some time before.
    ever: bool,
    /// This epoch is the first of an arc (its phase carries LLI bit 0).
    new_arc: bool,
    /// Until when (s since start) the half cycle is unresolved, and the phase's offset then.
    half: (f64, f64),
    canopy: Markov,
    code_mp: [Markov; 2],
    phase_mp: [Markov; 2],
    /// The impairments' state (receivers with impairments).
    imp: Option<SatImpair>,
}

/// How far above 45 dB-Hz noise and multipath scale (amplitude).
fn scale(cn0: f64) -> f64 {
    10f64.powf((45.0 - cn0) / 20.0)
}

impl Sat {
    fn new(p: &Profile, rng: &mut Rng) -> Sat {
        Sat {
            amb: [
                (rng.uniform() * 2.0e6 - 1.0e6).round(),
                (rng.uniform() * 2.0e6 - 1.0e6).round(),
            ],
            locked: false,
            ever: false,
            new_arc: false,
            half: (0.0, 0.0),
            canopy: Markov::new(p.canopy_db.1, p.canopy_db.2, rng),
            code_mp: [
                Markov::new(p.code.1, p.code.2, rng),
                Markov::new(p.code.1, p.code.2, rng),
            ],
            phase_mp: [
                Markov::new(p.phase.1, p.phase.2, rng),
                Markov::new(p.phase.1, p.phase.2, rng),
            ],
            imp: None,
        }
    }

    /// A new arc at `ts`: new ambiguities, a half cycle unresolved for a while.
    fn acquire(&mut self, sys: Constellation, ts: f64, p: &Profile, rng: &mut Rng) {
        self.locked = true;
        self.new_arc = true;
        for a in &mut self.amb {
            *a += rng.range(-50.0, 50.0).round();
        }
        let (lo, hi) = p.half_s[usize::from(sys == Constellation::Glonass)];
        let offset = if rng.uniform() < p.half_offset_probability {
            0.5
        } else {
            0.0
        };
        self.half = (ts + rng.range(lo, hi), offset);
    }
}

/// The simulation of one receiver in progress.
struct Run<'a> {
    rx: &'a LowCost<'a>,
    eph: &'a Ephemerides,
    klob: &'a Klobuchar,
    sats: Vec<(Sv, Option<i8>)>,
    state: BTreeMap<Sv, Sat>,
    rng: Rng,
    /// The impairments' own stream (untouched without them).
    irng: Rng,
    stats: TrackStats,
}

/// One satellite's geometry at an epoch, as [`Run::sat_obs`] uses it.
struct Seen {
    sv: Sv,
    chan: Option<i8>,
    freqs: Vec<f64>,
    rho: f64,
    rate: f64,
    dts: f64,
    dts_rate: f64,
    az: f64,
    el: f64,
}

/// The receiver's clock at an epoch: bias (s) and frequency (s/s).
#[derive(Clone, Copy)]
struct Clock {
    bias: f64,
    rate: f64,
}

impl Run<'_> {
    /// The observations of epoch `tag` (receiver time) with the clock at that epoch, the
    /// receiver's true position; `logged`: whether the log keeps the epoch.
    fn epoch(&mut self, tag: Epoch, clock: Clock, logged: bool) -> (Ecef, Vec<SatObs>) {
        let rx = self.rx;
        let (start, _, _) = rx.span;
        let ts = (tag - start).to_seconds();
        let t = tag - Duration::from_seconds(clock.bias);
        let (pos, vel) = (rx.at)(t);
        let g = pos.to_geodetic();
        let canopy = (rx.canopy)(ts);
        let mut out = Vec::new();
        for k in 0..self.sats.len() {
            let (sv, chan) = self.sats[k];
            let Some(freqs) = frequencies(sv.sys, chan) else {
                continue;
            };
            let Some((rho, rate, dts, dts_rate, sp)) = geometry(self.eph, sv, t, &pos.0, &vel)
            else {
                continue;
            };
            let (az, el) = az_el(&pos, &g, &Ecef(sp));
            if el < rx.mask_deg.to_radians() {
                self.state.remove(&sv);
                continue;
            }
            let seen = Seen {
                sv,
                chan,
                freqs: freqs.to_vec(),
                rho,
                rate,
                dts,
                dts_rate,
                az,
                el,
            };
            if let Some(o) = self.sat_obs(&seen, (t, ts), &g, canopy, (clock, logged)) {
                out.push(o);
            }
        }
        (pos, out)
    }

    /// The C/N0 of a satellite this epoch (rounded to the dB-Hz a receiver reports).
    fn cn0(&mut self, sv: Sv, el: f64, canopy: f64, dt: f64) -> f64 {
        let p = &self.rx.profile;
        let s = self.state.get_mut(&sv).expect("the satellite's state");
        // C/N0: elevation, canopy (worse through more foliage at low elevation), noise.
        let open = match &self.rx.impair {
            Some(m) => open_cn0(m, el),
            None => p.cn0.0 + (p.cn0.1 - p.cn0.0) * el.sin(),
        };
        let loss = canopy
            * (p.canopy_db.0 + s.canopy.step(dt, &mut self.rng)).max(0.0)
            * (1.0 + 0.5 * el.cos());
        let noise = match (&self.rx.impair, s.imp.as_mut()) {
            (Some(m), Some(i)) => i.cn0_offset(m, el, dt, &mut self.irng),
            _ => 0.7 * self.rng.normal(),
        };
        (open - loss + noise).round()
    }

    /// Lock lost when the C/N0 falls below the threshold (or, with impairments, by chance),
    /// acquired again when it is back above the other and any wait is over.
    fn track(&mut self, sv: Sv, cn0: f64, ts: f64, dt: f64) {
        let p = &self.rx.profile;
        let s = self.state.get_mut(&sv).expect("the satellite's state");
        let chance = match (&self.rx.impair, s.imp.as_mut()) {
            (Some(m), Some(i)) => s.locked && i.loses_lock(m, ts, cn0, dt, &mut self.irng),
            _ => false,
        };
        let waiting = s.imp.as_ref().is_some_and(|i| ts < i.reacquire_at);
        if s.locked && (cn0 < p.lock.0 || chance) {
            s.locked = false;
        } else if !s.locked && cn0 >= p.lock.1 && !waiting {
            self.stats.reacquisitions += usize::from(s.ever);
            s.ever = true;
            s.acquire(sv.sys, ts, p, &mut self.rng);
        }
    }

    /// A jump of the phase the receiver does not flag, by chance, in the `dt` seconds before
    /// this epoch: with impairments, as they say; without, a cycle now and then below 32 dB-Hz.
    fn unflagged_jump(&mut self, sv: Sv, cn0: f64, dt: f64) {
        let p = &self.rx.profile;
        let s = self.state.get_mut(&sv).expect("the satellite's state");
        match &self.rx.impair {
            Some(m) if s.locked => {
                if let Some(j) = SatImpair::phase_jump(m, cn0, dt, &mut self.irng) {
                    s.amb[0] += j;
                    self.stats.unflagged_slips += 1;
                }
            }
            Some(_) => {}
            None => {
                if s.locked && cn0 < 32.0 && self.rng.uniform() < p.unflagged_slip_rate * dt {
                    s.amb[0] += if self.rng.uniform() < 0.5 { 1.0 } else { -1.0 };
                    self.stats.unflagged_slips += 1;
                }
            }
        }
    }

    /// One satellite's record this epoch (None when not even its code is tracked).
    fn sat_obs(
        &mut self,
        o: &Seen,
        (t, ts): (Epoch, f64),
        g: &gnss::frame::Geodetic,
        canopy: f64,
        (clock, logged): (Clock, bool),
    ) -> Option<SatObs> {
        let rx = self.rx;
        let p = &rx.profile;
        let dt = rx.span.2;
        let (_, tow) = week_tow(t);
        let sv = o.sv;
        let rng = &mut self.rng;
        let irng = &mut self.irng;
        self.state.entry(sv).or_insert_with(|| {
            let mut s = Sat::new(p, rng);
            s.imp = rx.impair.as_ref().map(|_| SatImpair::new(irng));
            s
        });
        let cn0 = self.cn0(sv, o.el, canopy, dt);
        self.track(sv, cn0, ts, dt);
        if cn0 < p.lock.0 - 6.0 {
            return None; // nothing tracked, not even code
        }
        self.unflagged_jump(sv, cn0, dt);
        let s = self.state.get_mut(&sv).expect("the satellite's state");
        let half = s.locked && ts < s.half.0;
        if let Some(m) = rx.impair.as_ref().filter(|_| half) {
            // the loop, its half cycle unresolved, flips between the two polarities
            if self.irng.uniform() < m.half_flips * dt {
                s.half.1 = 0.5 - s.half.1;
            }
        }
        let k = f64::from(o.chan.unwrap_or(0));
        let icb = (k * p.glonass_icb.0, k * p.glonass_icb.1);
        let (iono_factor, trop_extra) = rx.atmosphere.map_or((1.0, 0.0), |f| f(t, o.az, o.el));
        let trop = troposphere(g, o.el) + trop_extra;
        let l1_bias = match (sv.sys, rx.gps_l1) {
            (Constellation::Gps, GpsL1::Ca) => c1_p1_bias(sv),
            _ => 0.0,
        };
        let i1 = klobuchar_gps(self.klob, g, o.az, o.el, tow) * iono_factor;
        let base = o.rho + C * (clock.bias - o.dts);
        let range_rate = o.rate + C * (clock.rate - o.dts_rate);
        let mut v = [f64::NAN; 8];
        let sc = scale(cn0);
        for (b, f) in o.freqs.iter().enumerate().take(rx.bands) {
            let lam = C / f;
            let iono = i1 * (F1 / f).powi(2);
            // Errors as parts added one after the other (the model's own order of sums,
            // so that receivers without impairments write the same digits as before).
            let (code_err, phase_err, doppler_err) = match (&rx.impair, s.imp.as_mut()) {
                (Some(m), Some(i)) => (
                    [i.code_error(m, ts, cn0, dt, &mut self.irng), 0.0],
                    SatImpair::phase_error(m, cn0, lam, &mut self.irng),
                    SatImpair::doppler_error(m, cn0, &mut self.irng),
                ),
                _ => {
                    let code_mp = s.code_mp[b].step(dt, &mut self.rng) * sc;
                    let phase_mp = (s.phase_mp[b].step(dt, &mut self.rng) * sc).clamp(-0.03, 0.03);
                    let code = [code_mp, p.code.0 * sc * self.rng.normal()];
                    // the phase noise is drawn below, and only while locked
                    (code, phase_mp, f64::NAN)
                }
            };
            v[4 * b] = base
                + trop
                + iono
                + icb.1
                + rx.code_bias[b]
                + l1_bias * f64::from(u8::from(b == 0))
                + code_err[0]
                + code_err[1];
            if s.locked {
                let phase = match rx.impair {
                    Some(_) => base + trop - iono + icb.0 + phase_err,
                    None => {
                        base + trop - iono + icb.0 + phase_err + p.phase.0 * sc * self.rng.normal()
                    }
                };
                let offset = if half { s.half.1 } else { 0.0 };
                v[4 * b + 1] = phase / lam + s.amb[b] + offset;
            }
            let doppler_err = if doppler_err.is_nan() {
                p.doppler * sc * self.rng.normal()
            } else {
                doppler_err
            };
            v[4 * b + 2] = -range_rate / lam + doppler_err;
            v[4 * b + 3] = cn0;
        }
        let lli_b = u8::from(s.locked && s.new_arc) | if half { 2 } else { 0 };
        // A new arc's flag stays until an epoch the log keeps carries it (its lock time
        // restarted whether the epoch was logged or not).
        if logged {
            s.new_arc = false;
        }
        if v[1].is_finite() {
            let e = self.stats.phases.entry(sv.sys).or_default();
            e.0 += 1;
            e.1 += usize::from(half);
        }
        self.stats.cn0.push(cn0);
        Some(SatObs {
            sv,
            v,
            lli: [lli_b, if rx.bands > 1 { lli_b } else { 0 }],
        })
    }
}

/// Simulate `rx` against the constellation: RINEX 3.04 text of the epochs `keep` lets
/// through (by epoch index: a log that lost epochs), and what was simulated.
pub fn simulate(
    rx: &LowCost,
    eph: &Ephemerides,
    klob: &Klobuchar,
    seed: &Rng,
    keep: &dyn Fn(usize) -> bool,
) -> (String, TrackStats) {
    let sats: Vec<(Sv, Option<i8>)> = eph
        .satellites()
        .map(|&sv| {
            let chan = (sv.sys == Constellation::Glonass)
                .then(|| eph.glonass_channel(sv.prn))
                .flatten();
            (sv, chan)
        })
        .collect();
    let (start, end, dt) = rx.span;
    let n = ((end - start).to_seconds() / dt).floor() as usize + 1;
    let mut run = Run {
        rx,
        eph,
        klob,
        sats,
        state: BTreeMap::new(),
        rng: seed.clone(),
        irng: seed.fork(0x696d_7061_6972),
        stats: TrackStats::default(),
    };
    let clocks = rx
        .impair
        .map(|m| ClockSeries::new(&m.clock, n, dt, &mut seed.fork(0x0063_6c6f_636b)));
    let mut body = String::with_capacity(n * 400);
    let mut first = None;
    for k in 0..n {
        let nominal = start + Duration::from_seconds(k as f64 * dt);
        let (tag, clock) = match &clocks {
            Some(c) => {
                let (offset, bias, rate) = c.epochs[k];
                (
                    nominal + Duration::from_seconds(offset),
                    Clock { bias, rate },
                )
            }
            None => {
                let ts = (nominal - start).to_seconds();
                let clock = Clock {
                    bias: rx.clock.0 + rx.clock.1 * ts,
                    rate: rx.clock.1,
                };
                (nominal, clock)
            }
        };
        let (pos, recs) = run.epoch(tag, clock, keep(k));
        if !keep(k) || recs.is_empty() {
            continue;
        }
        first.get_or_insert(pos);
        run.stats
            .instants
            .push(tag - Duration::from_seconds(clock.bias));
        run.stats.epochs += 1;
        run.stats.sats_per_epoch.push(recs.len());
        write_epoch_bands(&mut body, tag, &recs, rx.bands);
    }
    let mut systems: Vec<Constellation> = run.sats.iter().map(|s| s.0.sys).collect();
    systems.dedup();
    let glonass: Vec<(u8, i8)> = run
        .sats
        .iter()
        .filter_map(|&(sv, ch)| Some((sv.prn, ch?)))
        .collect();
    let head = header(&HeaderInfo {
        name: rx.name,
        interval: dt,
        start,
        pos: first.unwrap_or(Ecef::new(0.0, 0.0, 0.0)),
        systems: &systems,
        glonass: &glonass,
        bands: rx.bands,
        gps_l1: rx.gps_l1.attribute(),
    });
    (head + &body, run.stats)
}
