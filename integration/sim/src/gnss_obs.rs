//! Simulated GNSS observations (RINEX 3.04): geometric range with light time and Earth
//! rotation, satellite and receiver clocks, troposphere, ionosphere scaled to each signal's
//! frequency, elevation-dependent code and phase noise, multipath, integer ambiguities, cycle
//! slips and data gaps — each switchable — a GLONASS inter-channel bias per receiver (a hook,
//! off by default), and flag-5 event records at exposure times.
//!
//! Enters: a [`Receiver`] (true position as a function of true GPST, clock model, rate,
//! event times, GLONASS inter-channel biases), the ephemerides read back from the synthetic
//! navigation file (their satellites are the ones simulated, GLONASS channels from their
//! records), its Klobuchar parameters and the [`ErrorModel`]. Leaves: the RINEX text (C, L,
//! D, S on two signals: GPS L1/L2, GLONASS L1/L2 at 1602 + 0.5625·k and 1246 + 0.4375·k MHz,
//! Galileo E1/E5a, QZSS L1/L2; time tags in receiver time = true time + clock offset; written
//! by `obs_text`) and [`ObsStats`]. Uses `gnss::orbit`, `gnss::model` and `gnss::frame`.

pub use super::obs_text::SatObs;
use super::obs_text::{header, write_epoch, write_event, HeaderInfo};
use super::rng::Rng;
use super::scenario::ErrorModel;
use gnss::frame::{az_el, rotate_to_reception, Ecef};
use gnss::model::{klobuchar_gps, troposphere};
use gnss::orbit::{Ephemerides, C};
use gnss::rinex::nav::Klobuchar;
use gnss::sv::{Constellation, Sv};
use gnss::time::week_tow;
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;
use std::collections::HashMap;

const F1: f64 = 1575.42e6;
/// Second frequency: GPS L2, Galileo E5a.
fn f2(sys: Constellation) -> f64 {
    if sys == Constellation::Galileo {
        1176.45e6
    } else {
        1227.60e6
    }
}
/// The two carrier frequencies (Hz) simulated for a satellite of `sys` on GLONASS channel
/// `chan`: L1 and L2 (GPS, QZSS), E1 and E5a (Galileo), GLONASS L1 and L2 of the channel;
/// `None` for a GLONASS satellite without a channel.
pub(super) fn frequencies(sys: Constellation, chan: Option<i8>) -> Option<[f64; 2]> {
    if sys == Constellation::Glonass {
        let k = chan? as f64;
        Some([1602.0e6 + 0.5625e6 * k, 1246.0e6 + 0.4375e6 * k])
    } else {
        Some([F1, f2(sys)])
    }
}
/// Elevation below which the simulated receivers track nothing.
const SIM_MASK_DEG: f64 = 5.0;

/// A receiver to simulate.
pub struct Receiver<'a> {
    /// Marker name written in the header.
    pub name: &'a str,
    /// ECEF position at a true GPST time.
    pub pos: &'a dyn Fn(Epoch) -> Ecef,
    /// Clock offset (s) at the start and drift (s/s).
    pub clock: (f64, f64),
    /// First epoch, receiver time (GPST).
    pub start: Epoch,
    /// Last epoch (at most), receiver time (GPST).
    pub end: Epoch,
    /// Observation interval, seconds.
    pub interval: f64,
    /// True times of external events (camera exposures), written as flag-5 records.
    pub events: &'a [Epoch],
    /// Random cycle slips and gaps are injected in this receiver.
    pub faults: bool,
    /// True times at which the receiver loses lock on every satellite (sorted).
    pub lose_lock: &'a [Epoch],
    /// GLONASS inter-channel phase bias, metres per frequency channel number: both phases of
    /// a satellite on channel k carry k times this (0: none).
    pub glonass_phase_icb: f64,
    /// GLONASS inter-channel code bias, metres per frequency channel number, as the phase one.
    pub glonass_code_icb: f64,
}

/// Per-satellite persistent state of a receiver.
struct Track {
    /// Integer ambiguities of L1 and L2, cycles.
    amb: [f64; 2],
    /// Multipath phase (rad) and period (s).
    mp_phase: f64,
    mp_period: f64,
}

impl Track {
    /// A satellite coming into view: random ambiguities (when simulated) and multipath.
    fn new(err: &ErrorModel, rng: &mut Rng) -> Track {
        Track {
            amb: if err.ambiguities {
                [
                    (rng.uniform() * 2.0e6 - 1.0e6).round(),
                    (rng.uniform() * 2.0e6 - 1.0e6).round(),
                ]
            } else {
                [0.0, 0.0]
            },
            mp_phase: rng.range(0.0, 6.3),
            mp_period: rng.range(200.0, 600.0),
        }
    }
}

/// What was simulated, for the report.
#[derive(Clone, Debug, Default)]
pub struct ObsStats {
    /// Observation epochs written.
    pub epochs: usize,
    /// Satellite records written.
    pub sat_records: usize,
    /// Cycle slips injected.
    pub slips: usize,
    /// Satellite records left out by injected gaps.
    pub gap_records: usize,
    /// Size of the RINEX text, bytes.
    pub bytes: usize,
}

/// Cycle slips and data gaps of a receiver, drawn before the run.
#[derive(Default)]
struct Faults {
    /// (epoch, satellite index, frequency).
    slips: Vec<(usize, usize, usize)>,
    /// (first epoch, length in epochs, satellite index).
    gaps: Vec<(usize, usize, usize)>,
}

impl Faults {
    /// The scenario's slips and gaps (5–30 s) at random epochs and satellites.
    fn draw(
        err: &ErrorModel,
        interval: f64,
        n_epochs: usize,
        nsat: usize,
        rng: &mut Rng,
    ) -> Faults {
        let mut f = Faults::default();
        for _ in 0..err.cycle_slips {
            f.slips.push((
                (rng.uniform() * n_epochs as f64) as usize,
                (rng.uniform() * nsat as f64) as usize,
                (rng.uniform() * 2.0) as usize,
            ));
        }
        for _ in 0..err.gaps {
            let len = (rng.range(5.0, 30.0) / interval) as usize;
            f.gaps.push((
                (rng.uniform() * n_epochs as f64) as usize,
                len,
                (rng.uniform() * nsat as f64) as usize,
            ));
        }
        f
    }

    /// Whether satellite `si` is in a gap at epoch `k`.
    fn in_gap(&self, k: usize, si: usize) -> bool {
        self.gaps
            .iter()
            .any(|&(s, len, gs)| gs == si && k >= s && k < s + len)
    }
}

fn clock_at(rx: &Receiver, t: Epoch, on: bool) -> f64 {
    if !on {
        return 0.0;
    }
    rx.clock.0 + rx.clock.1 * (t - rx.start).to_seconds()
}

/// Geometric range with light time and Earth rotation from the receiver at true time `t`;
/// returns (range, range rate, satellite clock incl. relativity, clock rate, sat position).
pub fn geometry(
    eph: &Ephemerides,
    sv: Sv,
    t: Epoch,
    rx: &Vector3<f64>,
    rx_vel: &Vector3<f64>,
) -> Option<(f64, f64, f64, f64, Vector3<f64>)> {
    let mut tau = 0.075;
    let mut out = None;
    for _ in 0..3 {
        let ttx = t - Duration::from_seconds(tau);
        let e = eph.select(sv, ttx)?;
        let s = e.compute(ttx);
        let sp = rotate_to_reception(&s.pos.0, tau);
        let sv_vel = rotate_to_reception(&s.vel, tau);
        let d = sp - rx;
        let rho = d.norm();
        let rate = d.dot(&(sv_vel - rx_vel)) / rho;
        tau = rho / C;
        out = Some((rho, rate, s.clock, s.clock_rate, sp));
    }
    out
}

/// Simulate one receiver: RINEX text and counts.
pub fn simulate(
    rx: &Receiver,
    eph: &Ephemerides,
    klob: &Klobuchar,
    err: &ErrorModel,
    rng: &Rng,
) -> (String, ObsStats) {
    let sats: Vec<Sv> = eph.satellites().copied().collect();
    let chans: Vec<Option<i8>> = sats
        .iter()
        .map(|sv| {
            (sv.sys == Constellation::Glonass)
                .then(|| eph.glonass_channel(sv.prn))
                .flatten()
        })
        .collect();
    let n_epochs = ((rx.end - rx.start).to_seconds() / rx.interval).floor() as usize + 1;
    let mut rng_fault = rng.fork(2);
    let faults = if rx.faults {
        Faults::draw(err, rx.interval, n_epochs, sats.len(), &mut rng_fault)
    } else {
        Faults::default()
    };
    let mut sim = Sim {
        rx,
        eph,
        klob,
        err,
        sats,
        chans,
        tracks: HashMap::new(),
        rng_noise: rng.fork(1),
        rng_fault,
        faults,
        stats: ObsStats::default(),
        mask: if rx.faults {
            err.rover_mask_deg.max(SIM_MASK_DEG)
        } else {
            SIM_MASK_DEG
        }
        .to_radians(),
        all_slip: false,
    };
    let mut body = String::with_capacity(n_epochs * 600);
    let events = event_tags(rx, err);
    let mut ev_i = 0;
    let mut first_pos = None;
    let mut lost = 0;
    for k in 0..n_epochs {
        let tag = rx.start + Duration::from_seconds(k as f64 * rx.interval);
        let t_true = tag - Duration::from_seconds(clock_at(rx, tag, err.receiver_clock));
        sim.all_slip = false;
        while lost < rx.lose_lock.len() && rx.lose_lock[lost] <= t_true {
            sim.all_slip = k > 0;
            lost += 1;
        }
        // Event records that fall before this epoch's tag.
        while ev_i < events.len() && events[ev_i] < tag {
            write_event(&mut body, events[ev_i]);
            ev_i += 1;
        }
        let (p, recs) = sim.epoch(k, tag);
        first_pos.get_or_insert(p);
        sim.stats.epochs += 1;
        sim.stats.sat_records += recs.len();
        write_epoch(&mut body, tag, &recs);
    }
    for &e in &events[ev_i..] {
        write_event(&mut body, e);
    }
    let mut systems: Vec<Constellation> = sim.sats.iter().map(|sv| sv.sys).collect();
    systems.dedup();
    let glonass: Vec<(u8, i8)> = sim
        .sats
        .iter()
        .zip(&sim.chans)
        .filter_map(|(sv, ch)| Some((sv.prn, (*ch)?)))
        .collect();
    let header = header(&HeaderInfo {
        name: rx.name,
        interval: rx.interval,
        start: rx.start,
        pos: first_pos.unwrap_or(Ecef::new(0.0, 0.0, 0.0)),
        systems: &systems,
        glonass: &glonass,
        bands: 2,
        gps_l1: b'C',
    });
    let text = header + &body;
    let mut stats = sim.stats;
    stats.bytes = text.len();
    (text, stats)
}

/// The receiver's event times as tags in receiver time (true time + clock offset), sorted.
fn event_tags(rx: &Receiver, err: &ErrorModel) -> Vec<Epoch> {
    let mut events: Vec<Epoch> = rx
        .events
        .iter()
        .map(|t| *t + Duration::from_seconds(clock_at(rx, *t, err.receiver_clock)))
        .collect();
    events.sort();
    events
}

/// One receiver's simulation in progress.
struct Sim<'a> {
    rx: &'a Receiver<'a>,
    eph: &'a Ephemerides,
    klob: &'a Klobuchar,
    err: &'a ErrorModel,
    /// Every satellite of the ephemerides, in order (faults refer to their indices).
    sats: Vec<Sv>,
    /// GLONASS frequency channel of each of `sats` (`None` for other systems).
    chans: Vec<Option<i8>>,
    /// Satellites in view and their state.
    tracks: HashMap<Sv, Track>,
    /// Noise, ambiguities and multipath.
    rng_noise: Rng,
    /// Slip sizes (and, before the run, the faults).
    rng_fault: Rng,
    faults: Faults,
    stats: ObsStats,
    /// Tracking mask, radians.
    mask: f64,
    /// Every satellite slips at this epoch (a loss of lock since the previous one).
    all_slip: bool,
}

impl Sim<'_> {
    /// Epoch `k` with receiver time tag `tag`: the receiver's true position (ECEF) and the
    /// observations of every satellite above the tracking mask and outside a gap.
    fn epoch(&mut self, k: usize, tag: Epoch) -> (Ecef, Vec<SatObs>) {
        let (rx, err) = (self.rx, self.err);
        let dtr = clock_at(rx, tag, err.receiver_clock);
        let t = tag - Duration::from_seconds(dtr);
        let p = (rx.pos)(t);
        let p2 = (rx.pos)(t + Duration::from_seconds(0.01));
        let vel = (p2.0 - p.0) / 0.01;
        let g = p.to_geodetic();
        let (_, tow) = week_tow(t);
        let mut recs: Vec<SatObs> = Vec::new();
        for (si, &sv) in self.sats.iter().enumerate() {
            if self.faults.in_gap(k, si) {
                self.stats.gap_records += 1;
                continue;
            }
            let Some(freqs) = frequencies(sv.sys, self.chans[si]) else {
                continue;
            };
            let Some((rho, rate, dts, dts_rate, sp)) = geometry(self.eph, sv, t, &p.0, &vel) else {
                continue;
            };
            let (az, el) = az_el(&p, &g, &Ecef(sp));
            if el < self.mask {
                self.tracks.remove(&sv);
                continue;
            }
            let rng_noise = &mut self.rng_noise;
            let tr = self
                .tracks
                .entry(sv)
                .or_insert_with(|| Track::new(err, rng_noise));
            let mut lli = [0u8; 2];
            if self.all_slip {
                for (f, a) in tr.amb.iter_mut().enumerate() {
                    *a += self.rng_fault.range(1.0, 20.0).round();
                    lli[f] |= 1;
                    self.stats.slips += 1;
                }
            }
            for &(s, gs, f) in &self.faults.slips {
                if s == k && gs == si {
                    tr.amb[f] += self.rng_fault.range(1.0, 20.0).round();
                    lli[f] |= 1;
                    self.stats.slips += 1;
                }
            }
            let trop = if err.troposphere {
                troposphere(&g, el)
            } else {
                0.0
            };
            let i1 = if err.ionosphere {
                klobuchar_gps(self.klob, &g, az, el, tow)
            } else {
                0.0
            };
            let ts = (t - rx.start).to_seconds();
            let mp = if err.multipath {
                (-el.to_degrees() / 20.0).exp()
                    * (2.0 * std::f64::consts::PI * ts / tr.mp_period + tr.mp_phase).sin()
            } else {
                0.0
            };
            let k = self.chans[si].unwrap_or(0) as f64;
            let signal = Signal {
                base: rho + C * (dtr - dts),
                rate: rate + C * (err.receiver_clock as u8 as f64 * rx.clock.1 - dts_rate),
                trop,
                i1,
                mp,
                el,
                freqs,
                code_bias: k * rx.glonass_code_icb,
                phase_bias: k * rx.glonass_phase_icb,
            };
            let v = signal.observables(&tr.amb, err, &mut self.rng_noise);
            recs.push(SatObs { sv, v, lli });
        }
        (p, recs)
    }
}

/// What a satellite's signals carry at one epoch, before noise.
struct Signal {
    /// Range plus receiver minus satellite clock, metres.
    base: f64,
    /// Range rate plus clock rates, m/s.
    rate: f64,
    /// Slant troposphere, metres.
    trop: f64,
    /// Ionosphere delay on L1, metres.
    i1: f64,
    /// Multipath factor (code gets 0.5 m of it, phase 5 mm).
    mp: f64,
    /// Elevation, radians.
    el: f64,
    /// Carrier frequencies of the two signals, Hz.
    freqs: [f64; 2],
    /// Receiver bias of the code and of the phase (both signals), metres.
    code_bias: f64,
    phase_bias: f64,
}

impl Signal {
    /// Code (m), phase (cycles, with the ambiguities `amb`), Doppler (Hz) and SNR (dB-Hz) on
    /// the two signals, with elevation-dependent noise drawn from `rng`.
    fn observables(&self, amb: &[f64; 2], err: &ErrorModel, rng: &mut Rng) -> [f64; 8] {
        let se = self.el.sin();
        let noise = |sigma: f64, r: &mut Rng| {
            if sigma > 0.0 {
                sigma * (0.5 + 0.5 / se) * r.normal()
            } else {
                0.0
            }
        };
        let (base, trop, mp) = (self.base, self.trop, self.mp);
        let mut v = [0.0; 8];
        for (f, freq) in self.freqs.into_iter().enumerate() {
            let lam = C / freq;
            let i = self.i1 * (F1 / freq).powi(2);
            let code = base + trop + i + 0.5 * mp + noise(err.code_noise, rng) + self.code_bias;
            let phase =
                base + trop - i + 0.005 * mp + noise(err.phase_noise, rng) + self.phase_bias;
            v[4 * f] = code;
            v[4 * f + 1] = phase / lam + amb[f];
            v[4 * f + 2] = -self.rate / lam
                + if err.code_noise > 0.0 {
                    0.02 * rng.normal()
                } else {
                    0.0
                };
            v[4 * f + 3] = (30.0 + 20.0 * se).round();
        }
        v
    }
}
