//! What a real low-cost receiver does beyond [`super::receiver`]'s tracking model, shaped on
//! the statistics measured on a real u-blox M8P walk (`shared/data/lowcost-fingerprint`, read
//! with `shared/tools/fingerprint.py`): a clock whose time tags sit milliseconds off GPS time
//! and whose frequency wanders; losses of lock that do not wait for the C/N0 to fall, with
//! the phase missing (code still there) until the loop locks again; phase jumps the receiver
//! does not flag (half and whole cycles, now and then tens); code errors that vary slowly
//! and leave their level for metres at a time; Doppler with heavy tails; C/N0 that fades
//! smoothly rather than jitters.
//!
//! Enters: an [`Impairments`] per receiver (its figures), the C/N0 and time of each
//! satellite's epoch, a random stream of its own (so receivers without impairments draw
//! exactly what they drew before). Leaves: the clock of each epoch ([`ClockSeries`]) and, per
//! satellite ([`SatImpair`]), C/N0 offsets, lock losses, phase jumps, code and Doppler errors.

use super::super::rng::Rng;
use gnss::orbit::C;

/// How a receiver's clock runs: the bias of its time tags against GPS time and its frequency.
#[derive(Clone, Copy, Debug)]
pub struct ClockModel {
    /// Time-tag bias at the start (tag − true time), seconds.
    pub bias: f64,
    /// Frequency offset at the start (the bias's rate), s/s.
    pub drift: f64,
    /// Random walk of the frequency, (s/s)/√s: the wander of a temperature-compensated
    /// crystal.
    pub wander: f64,
    /// Steady change of the frequency, s/s².
    pub ageing: f64,
}

/// The clock of each epoch of a receiver that measures near the GPS second and tags the
/// measurement with its own clock, to the millisecond of its bias (a u-blox receiver: the
/// tag's fraction stays put while the bias drifts, and steps by 1 ms when the measurement
/// instant would leave ±0.5 ms of the second).
#[derive(Clone, Debug)]
pub struct ClockSeries {
    /// Per epoch: the offset of the tag from the nominal second (s, whole milliseconds), the
    /// clock bias at the measurement (s) and the frequency (s/s).
    pub epochs: Vec<(f64, f64, f64)>,
}

impl ClockSeries {
    /// `n` epochs `dt` seconds apart of clock `m`.
    pub fn new(m: &ClockModel, n: usize, dt: f64, rng: &mut Rng) -> ClockSeries {
        let (mut bias, mut freq) = (m.bias, m.drift);
        let mut epochs = Vec::with_capacity(n);
        for _ in 0..n {
            let tag = (bias * 1e3).round() * 1e-3;
            epochs.push((tag, bias, freq));
            let next = freq + m.ageing * dt + m.wander * dt.sqrt() * rng.normal();
            bias += 0.5 * (freq + next) * dt;
            freq = next;
        }
        ClockSeries { epochs }
    }
}

/// The figures of a receiver's impairments. Rates are per second of tracking at 45 dB-Hz and
/// grow tenfold for every `*.1` dB the C/N0 falls below 45 (never shrink above it).
#[derive(Clone, Copy, Debug)]
pub struct Impairments {
    /// Its clock.
    pub clock: ClockModel,
    /// Open-sky C/N0 against elevation: `horizon + (zenith − horizon)·sin(el)^shape`, dB-Hz
    /// (a patch antenna loses gain mostly near the horizon).
    pub cn0: (f64, f64, f64),
    /// C/N0 fading: Gauss–Markov σ at the zenith (dB) and correlation time (s), white noise
    /// (dB), and how much more the fading swings at the horizon (σ grows by this factor
    /// times (1 − sin el)²: multipath off the ground).
    pub fading: (f64, f64, f64, f64),
    /// Losses of lock whatever the C/N0 threshold says: rate, dB per tenfold.
    pub lock_loss: (f64, f64),
    /// After such a loss the signal stays troubled for a while (exponential, mean seconds)
    /// and loses lock this many times as often meanwhile: losses come in bursts, so that most
    /// arcs are a few seconds long while most of the tracking is in long ones.
    pub trouble: (f64, f64),
    /// Seconds (uniform range) the phase stays missing after such a loss, the code tracked.
    pub reacquire_s: (f64, f64),
    /// Phase jumps without a flag: rate, dB per tenfold.
    pub jump_rate: (f64, f64),
    /// Shares of those jumps that are half a cycle and one cycle (the rest 2 to 40 cycles).
    pub jump_mix: (f64, f64),
    /// While its half cycle is unresolved (RINEX LLI bit 1), the phase flips by half a cycle
    /// this often, per second.
    pub half_flips: f64,
    /// White code noise at 45 dB-Hz, m, growing tenfold for every so many dB below (the real
    /// receivers': about 18).
    pub code_white: (f64, f64),
    /// Code multipath: σ (m), correlation time (s) of a second-order Gauss–Markov process
    /// (two first-order stages: smooth from one second to the next, as the real code error
    /// was measured, autocorrelation 0.87–0.96 at 1 s); its σ grows by this factor per 10 dB
    /// below 45 dB-Hz.
    pub code_mp: (f64, f64, f64),
    /// The multipath's amplitude wanders: σ of its logarithm and correlation time (s), which
    /// gives the error the heavy tails measured (RMS 1.7× the robust σ).
    pub code_mp_swing: (f64, f64),
    /// Code excursions (the level leaves by metres for seconds): rate, dB per tenfold; median
    /// size (m); the shortest duration and the mean of the rest (exponential), s.
    pub excursion: (f64, f64, f64, (f64, f64)),
    /// Doppler: white noise at 45 dB-Hz (Hz), the dB below 45 that make it tenfold (the
    /// real receivers': about 35); the share of outliers at 45 dB-Hz and the dB below that
    /// make it tenfold; their σ (Hz).
    pub doppler: (f64, f64, (f64, f64), f64),
    /// Phase noise at 45 dB-Hz, cycles (growing as the code's).
    pub phase_white: f64,
}

/// How much more often a rate `(at45, db_per_decade)` strikes at `cn0`.
fn rate_at((at45, per_decade): (f64, f64), cn0: f64) -> f64 {
    at45 * 10f64.powf(((45.0 - cn0) / per_decade).max(0.0))
}

/// Amplitude growth of white noise below 45 dB-Hz: tenfold every `per_decade` dB (20 for
/// a noise that follows the C/N0 as theory has it).
fn amplitude(cn0: f64, per_decade: f64) -> f64 {
    10f64.powf((45.0 - cn0) / per_decade)
}

/// One satellite's impairments as it is tracked.
#[derive(Clone, Debug)]
pub struct SatImpair {
    fade: f64,
    /// The two stages of the multipath process (unit variance) and its log-amplitude.
    multipath: [f64; 2],
    swing: f64,
    /// The code excursion under way: until when (s) and its size (m).
    excursion: Option<(f64, f64)>,
    /// The phase comes back at this time (s) after a loss of lock.
    pub reacquire_at: f64,
    /// Losses of lock are frequent until this time (s).
    troubled_until: f64,
}

impl SatImpair {
    /// A satellite coming into view.
    pub fn new(rng: &mut Rng) -> SatImpair {
        SatImpair {
            fade: rng.normal(),
            multipath: [rng.normal(), rng.normal()],
            swing: rng.normal(),
            excursion: None,
            reacquire_at: f64::NEG_INFINITY,
            troubled_until: f64::NEG_INFINITY,
        }
    }

    /// The C/N0 offset of this epoch at elevation `el` (radians), dB (fading and white
    /// noise), `dt` seconds on.
    pub fn cn0_offset(&mut self, m: &Impairments, el: f64, dt: f64, rng: &mut Rng) -> f64 {
        let (sigma, tau, white, horizon) = m.fading;
        let a = (-dt / tau).exp();
        // the unit process, scaled by the elevation's σ
        self.fade = a * self.fade + (1.0 - a * a).sqrt() * rng.normal();
        let low = (1.0 - el.max(0.0).sin()).powi(2);
        self.fade * sigma * (1.0 + horizon * low) + white * rng.normal()
    }

    /// Whether the loop loses lock in the `dt` seconds to `ts` at `cn0` (then the phase is
    /// missing until [`Self::reacquire_at`]).
    pub fn loses_lock(
        &mut self,
        m: &Impairments,
        ts: f64,
        cn0: f64,
        dt: f64,
        rng: &mut Rng,
    ) -> bool {
        let (mean, factor) = m.trouble;
        let boost = if ts < self.troubled_until {
            factor
        } else {
            1.0
        };
        let lost = rng.uniform() < rate_at(m.lock_loss, cn0) * boost * dt;
        if lost {
            self.reacquire_at = ts + rng.range(m.reacquire_s.0, m.reacquire_s.1);
            if boost == 1.0 {
                self.troubled_until = ts - mean * rng.uniform().max(1e-12).ln();
            }
        }
        lost
    }

    /// An unflagged phase jump (cycles) in the `dt` seconds before this epoch, if any.
    pub fn phase_jump(m: &Impairments, cn0: f64, dt: f64, rng: &mut Rng) -> Option<f64> {
        if rng.uniform() >= rate_at(m.jump_rate, cn0) * dt {
            return None;
        }
        let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
        let u = rng.uniform();
        let size = if u < m.jump_mix.0 {
            0.5
        } else if u < m.jump_mix.0 + m.jump_mix.1 {
            1.0
        } else {
            // 2–40 cycles, log-uniform: most are a few cycles
            (2f64.ln() + rng.uniform() * (40f64.ln() - 2f64.ln()))
                .exp()
                .round()
        };
        Some(sign * size)
    }

    /// The code error of this epoch, m: white noise, multipath and any excursion under way.
    pub fn code_error(
        &mut self,
        m: &Impairments,
        ts: f64,
        cn0: f64,
        dt: f64,
        rng: &mut Rng,
    ) -> f64 {
        let (sigma, tau, growth) = m.code_mp;
        let a = (-dt / tau).exp();
        let b = (1.0 - a * a).sqrt();
        self.multipath[0] = a * self.multipath[0] + b * rng.normal();
        self.multipath[1] = a * self.multipath[1] + b * self.multipath[0];
        // the second stage's variance is (1 + a²)/(1 − a²) of the first's
        let unit = self.multipath[1] * ((1.0 - a * a) / (1.0 + a * a)).sqrt();
        let (log_sigma, swing_tau) = m.code_mp_swing;
        let c = (-dt / swing_tau).exp();
        self.swing = c * self.swing + (1.0 - c * c).sqrt() * rng.normal();
        // log-normal amplitude of mean square one
        let amp = (log_sigma * self.swing - log_sigma * log_sigma).exp();
        let mp_scale = growth.powf(((45.0 - cn0) / 10.0).max(0.0)) * amp;
        if self.excursion.is_some_and(|(until, _)| ts >= until) {
            self.excursion = None;
        }
        let (rate, per_decade, size, (shortest, mean_more)) = m.excursion;
        if self.excursion.is_none() && rng.uniform() < rate_at((rate, per_decade), cn0) * dt {
            // size: the median times a log-normal factor (most of them clearly metres),
            // either sign
            let s = size * (0.3 * rng.normal()).exp();
            let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            let d = shortest - mean_more * rng.uniform().max(1e-12).ln();
            self.excursion = Some((ts + d.max(dt), sign * s));
        }
        let excursion = self.excursion.map_or(0.0, |(_, s)| s);
        let (white, per_decade) = m.code_white;
        sigma * unit * mp_scale + white * amplitude(cn0, per_decade) * rng.normal() + excursion
    }

    /// The Doppler error of this epoch, Hz.
    pub fn doppler_error(m: &Impairments, cn0: f64, rng: &mut Rng) -> f64 {
        let (white, per_decade, share, outlier) = m.doppler;
        let e = white * amplitude(cn0, per_decade) * rng.normal();
        if rng.uniform() < rate_at(share, cn0) {
            e + outlier * rng.normal()
        } else {
            e
        }
    }

    /// The phase noise of this epoch, metres, at wavelength `lambda`.
    pub fn phase_error(m: &Impairments, cn0: f64, lambda: f64, rng: &mut Rng) -> f64 {
        m.phase_white * amplitude(cn0, 30.0) * lambda * rng.normal()
    }
}

/// The open-sky C/N0 at elevation `el` (radians), dB-Hz.
pub fn open_cn0(m: &Impairments, el: f64) -> f64 {
    let (h, z, shape) = m.cn0;
    h + (z - h) * el.max(0.0).sin().powf(shape)
}

/// The clock bias in metres (for reports).
pub fn metres(seconds: f64) -> f64 {
    seconds * C
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tag stays on whole milliseconds of the bias, so the measurement instant stays
    /// within half a millisecond of the second, and the bias follows its frequency.
    #[test]
    fn the_clock_tags_to_the_millisecond_and_drifts() {
        let m = ClockModel {
            bias: -10.65e-3,
            drift: 4.1e-7,
            wander: 5e-10,
            ageing: -1.5e-11,
        };
        let c = ClockSeries::new(&m, 3600, 1.0, &mut Rng::new(3));
        for &(tag, bias, _) in &c.epochs {
            assert!(((tag * 1e3).round() - tag * 1e3).abs() < 1e-9);
            assert!((tag - bias).abs() <= 0.5e-3 + 1e-12, "{tag} {bias}");
        }
        let (first, last) = (c.epochs[0], c.epochs[3599]);
        let span = last.1 - first.1;
        assert!((span - 4.1e-7 * 3599.0).abs() < 0.3e-3, "{span}");
        let steps = c.epochs.windows(2).filter(|w| w[0].0 != w[1].0).count();
        assert!((1..=3).contains(&steps), "{steps}");
    }

    /// Rates grow tenfold per `db_per_decade` below 45 dB-Hz and stay put above.
    #[test]
    fn rates_grow_as_the_signal_weakens() {
        assert!((rate_at((0.01, 10.0), 35.0) - 0.1).abs() < 1e-12);
        assert!((rate_at((0.01, 10.0), 50.0) - 0.01).abs() < 1e-12);
    }
}
