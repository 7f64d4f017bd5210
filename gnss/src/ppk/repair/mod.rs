//! Slips mended instead of cut. A low-cost receiver's phase jumps by half cycles, whole
//! cycles or tens without a flag, loses lock for a second or five and comes back, and
//! resolves its half-cycle ambiguity seconds into an arc; each of those cut the arc and
//! started its ambiguity afresh, so that on a walk under trees no ambiguity lived long
//! enough to be fixed (the real walk's median arc: 3 s).
//!
//! Between two epochs a second or a few apart, the receiver's displacement and clock change
//! are four unknowns that the time-differenced phases of the satellites that kept their
//! arcs determine to millimetres, once each satellite's own motion and clock are taken out
//! with its orbit (the approximate positions the ranges are computed from may be metres off:
//! what that changes between the epochs projects on each line of sight as a displacement
//! does, and the fit takes it out). A satellite whose phase leaves that fit by a multiple of
//! half a cycle, within [`TOLERANCE`], slipped by that many: its later phases are corrected
//! by it and its arc goes on. A satellite back after a loss of lock is joined to its arc the
//! same way across the gap (at most `max_bridge` seconds), from the satellites whose arcs
//! span it. A jump the fit measures on a signal of [`MIN_CN0`] or more but cannot call a
//! multiple of half a cycle cuts the arc (the loss-of-lock flag set, so that the filter cuts
//! it too); on a weaker signal nothing is mended, joined or cut: it is left to the slip
//! detectors.
//!
//! Single-frequency phases only: where a satellite is tracked on two frequencies, the
//! geometry-free and Melbourne–Wübbena tests see its slips, and its phases are left to them
//! (they serve as references in the fit all the same).
//!
//! Half cycles: the phase of an arc whose half-cycle ambiguity the receiver has not
//! resolved (LLI bit 1) may be half a cycle off, and the receiver removes that half cycle
//! when it resolves it. Mending never changes that state: a phase is joined to its arc, or
//! a jump mended, only where the flag is the same on both sides; where it changes, the arc
//! ends as the filter ends it (carrying the state across, and clearing the flag of phases
//! joined to resolved arcs, gave wrong fixes on the open-sky walk that nothing here could
//! explain yet).
//!
//! Only where the fit can tell: six satellites or more left in it, its residuals within
//! [`FIT_SIGMA`], and epochs at most [`STEP_MAX`] apart for a jump (at 30 s the ionosphere
//! moves a satellite's phase by centimetres and nothing is mended).
//!
//! What enters: one receiver's epochs of measurements and, per measurement, its range from
//! the epoch's approximate position less the satellite clock (m) with the line of sight.
//! What leaves: the measurements with their phases and flags corrected, and [`Mended`].

use super::obs::{SatMeas, LLI_HALF_CYCLE, NF};
use crate::sv::Sv;
use hifitime::Epoch;
use nalgebra::{Matrix4, Vector3, Vector4};
use std::collections::HashMap;

/// How far (cycles) from a multiple of half a cycle a jump may lie to be mended.
pub const TOLERANCE: f64 = 0.1;
/// Largest RMS (m) of the fit's residuals for anything to be mended from it.
pub const FIT_SIGMA: f64 = 0.012;
/// Largest interval (s) between two epochs across which a jump is mended.
pub const STEP_MAX: f64 = 2.0;
/// Fewest satellites (and slots) left in a fit.
const FIT_MIN: usize = 6;
/// A residual (m) beyond this and four robust sigmas of the others leaves the fit.
const FIT_FLOOR: f64 = 0.02;
/// A jump smaller than this (cycles) is noise, not a slip.
const NOISE: f64 = 0.25;
/// Below this C/N0 (dB-Hz) a phase's noise reaches a tenth of a cycle or more: it is neither
/// mended nor joined nor cut, only left to the slip detectors (at 28 dB-Hz the simulated
/// walk's phase moved −0.44 cycle in a second with no slip, and mending it as half a cycle
/// gave fixes 10–14 cm off).
const MIN_CN0: f64 = 35.0;

/// What [`mend`] did to one receiver's phases.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Mended {
    /// Jumps between consecutive epochs mended (half cycles, cycles, tens).
    pub jumps: usize,
    /// Arcs joined across a loss of lock or a gap.
    pub bridged: usize,
    /// Jumps the fit measured on a strong signal but could not call a multiple of half a
    /// cycle: arcs cut.
    pub cut: usize,
    /// Jumps on a weak signal (below [`MIN_CN0`]): left to the slip detectors.
    pub left: usize,
}

/// Range (m, from the epoch's approximate position, less the satellite clock) and line of
/// sight of one measurement; None without an orbit or a position.
pub type Range = Option<(f64, Vector3<f64>)>;

/// One corrected arc of a satellite's slot.
#[derive(Clone, Copy, Debug)]
struct Track {
    /// Epoch index of its last phase.
    last: usize,
    /// Epoch index it began at.
    start: usize,
    /// Cycles added to the raw phase.
    offset: f64,
    /// The raw phase's half-cycle flag at `last`.
    raw_half: u8,
}

/// One phase to test at the current epoch: measurement index, slot, the epoch it is
/// differenced with and its misfit (m) against the satellites' motion.
#[derive(Clone, Copy, Debug)]
struct Diff {
    k: usize,
    f: usize,
    from: usize,
    misfit: f64,
    los: Vector3<f64>,
    wavelength: f64,
    /// Both phases at or above [`MIN_CN0`] (or without a C/N0), and the satellite's only
    /// phase at epoch `i` (see [`single`]): a phase mending may change.
    strong: bool,
    /// The satellite has a phase on no other slot at epoch `i`.
    single: bool,
}

/// Mend the phases of one receiver's epochs in place (see the module's text); `ranges[i][k]`
/// belongs to `meas[i][k]`.
pub fn mend(
    times: &[Epoch],
    meas: &mut [Vec<SatMeas>],
    ranges: &[Vec<Range>],
    max_bridge: f64,
) -> Mended {
    let mut out = Mended::default();
    let mut tracks: HashMap<(Sv, usize), Track> = HashMap::new();
    for i in 0..meas.len().min(times.len()).min(ranges.len()) {
        let Classified {
            steps,
            joins,
            stale,
        } = classify(i, times, meas, ranges, &tracks, max_bridge);
        // Consecutive epochs first: the joins are fitted on arcs already mended here.
        if let Some(fit) = Fit::of(&steps) {
            for d in &steps {
                let x = fit.residual(d) / d.wavelength;
                let key = (meas[i][d.k].sv, d.f);
                if x.abs() < NOISE || !d.single {
                    continue;
                }
                match half_cycles(x).filter(|_| d.strong) {
                    Some(n) => {
                        out.jumps += 1;
                        if let Some(t) = tracks.get_mut(&key) {
                            t.offset -= n;
                        }
                    }
                    None if d.strong => {
                        out.cut += 1;
                        tracks.remove(&key);
                        meas[i][d.k].lli[d.f] |= 1;
                    }
                    None => out.left += 1,
                }
            }
        }
        for d in &joins {
            let key = (meas[i][d.k].sv, d.f);
            let spans = |r: &Diff| {
                tracks
                    .get(&(meas[i][r.k].sv, r.f))
                    .is_some_and(|t| t.start <= d.from)
            };
            let refs: Vec<Diff> = joined_misfits(i, d.from, meas, ranges, &tracks)
                .into_iter()
                .filter(spans)
                .collect();
            let n = Fit::of(&refs)
                .filter(|_| d.strong)
                .and_then(|fit| half_cycles(fit.residual(d) / d.wavelength));
            match (n, tracks.get_mut(&key)) {
                (Some(n), Some(t)) => {
                    out.bridged += 1;
                    t.offset -= n;
                    meas[i][d.k].lli[d.f] &= !1;
                }
                _ => cut_arc(&mut tracks, key, &mut meas[i][d.k]),
            }
        }
        for (k, f) in stale {
            let key = (meas[i][k].sv, f);
            cut_arc(&mut tracks, key, &mut meas[i][k]);
        }
        apply(i, meas, &mut tracks);
    }
    out
}

/// Epoch `i`'s phases with an arc to continue, as [`classify`] sorts them.
struct Classified {
    /// From the epoch before, without a loss of lock.
    steps: Vec<Diff>,
    /// Back after a loss of lock or a gap of at most `max_bridge`.
    joins: Vec<Diff>,
    /// Back after a longer gap, or with another half-cycle flag (measurement index, slot):
    /// their arcs end.
    stale: Vec<(usize, usize)>,
}

/// Epoch `i`'s phases with an arc to continue, each with its misfit against the epoch it
/// is differenced with. Phases without a range are left as they are.
fn classify(
    i: usize,
    times: &[Epoch],
    meas: &[Vec<SatMeas>],
    ranges: &[Vec<Range>],
    tracks: &HashMap<(Sv, usize), Track>,
    max_bridge: f64,
) -> Classified {
    let (mut steps, mut joins, mut stale) = (Vec::new(), Vec::new(), Vec::new());
    for (k, m) in meas[i].iter().enumerate() {
        for f in 0..NF {
            let Some(t) = tracks.get(&(m.sv, f)) else {
                continue;
            };
            let dt = (times[i] - times[t.last]).to_seconds();
            if !m.l[f].is_finite() || t.last >= i {
                continue;
            }
            if dt > max_bridge || t.raw_half != m.lli[f] & LLI_HALF_CYCLE {
                stale.push((k, f));
                continue;
            }
            let Some(d) = diff(i, t.last, k, f, meas, ranges, t.offset) else {
                continue;
            };
            if t.last + 1 == i && dt <= STEP_MAX && m.lli[f] & 1 == 0 {
                steps.push(d);
            } else {
                joins.push(d);
            }
        }
    }
    Classified {
        steps,
        joins,
        stale,
    }
}

/// The arc of `key` ends at this measurement: flagged as a loss of lock when an offset was
/// in force (the raw phase no longer continues the corrected one).
fn cut_arc(tracks: &mut HashMap<(Sv, usize), Track>, key: (Sv, usize), m: &mut SatMeas) {
    if tracks.remove(&key).is_some_and(|t| t.offset != 0.0) {
        m.lli[key.1] |= 1;
    }
}

/// The misfit of `meas[i][k]`'s phase on slot `f` (raw plus `offset`) against epoch `from`'s
/// corrected phase of the same satellite: the phase's change less the range's (m).
fn diff(
    i: usize,
    from: usize,
    k: usize,
    f: usize,
    meas: &[Vec<SatMeas>],
    ranges: &[Vec<Range>],
    offset: f64,
) -> Option<Diff> {
    let m = &meas[i][k];
    let j = meas[from].iter().position(|h| h.sv == m.sv)?;
    let h = &meas[from][j];
    let ((r1, e), (r0, _)) = (ranges[i].get(k).copied()??, ranges[from].get(j).copied()??);
    let wavelength = m.wavelength(f);
    if !(h.l[f].is_finite() && wavelength.is_finite()) {
        return None;
    }
    let strong = |c: f64| c.is_nan() || c >= MIN_CN0;
    Some(Diff {
        k,
        f,
        from,
        misfit: (m.l[f] + offset - h.l[f]) * wavelength - (r1 - r0),
        los: e,
        wavelength,
        strong: strong(m.cn0(f)) && strong(h.cn0(f)) && single(m),
        single: single(m),
    })
}

/// The misfits between epochs `from` and `i` of every phase with an arc at both (corrected at
/// `from`, raw plus its offset at `i`).
fn joined_misfits(
    i: usize,
    from: usize,
    meas: &[Vec<SatMeas>],
    ranges: &[Vec<Range>],
    tracks: &HashMap<(Sv, usize), Track>,
) -> Vec<Diff> {
    let mut v = Vec::new();
    for (k, m) in meas[i].iter().enumerate() {
        for f in 0..NF {
            let Some(t) = tracks.get(&(m.sv, f)) else {
                continue;
            };
            if t.last + 1 != i || !m.l[f].is_finite() || m.lli[f] & 1 != 0 {
                continue;
            }
            v.extend(diff(i, from, k, f, meas, ranges, t.offset));
        }
    }
    v
}

/// A satellite with a phase on one slot only: no geometry-free or Melbourne–Wübbena test
/// can see its slips, and mending is for those. Where two frequencies are tracked those
/// tests find the slips and mending stays out of their way (on the hard-sky flight's
/// dual-frequency phases at 10 Hz, mending one slot beside the other made the tight
/// coupling fix nothing).
fn single(m: &SatMeas) -> bool {
    m.l.iter().filter(|l| l.is_finite()).count() == 1
}

/// The multiple of half a cycle `x` (cycles) lies within [`TOLERANCE`] of, if any.
fn half_cycles(x: f64) -> Option<f64> {
    let n = (2.0 * x).round() / 2.0;
    ((x - n).abs() <= TOLERANCE).then_some(n)
}

/// Epoch `i`'s phases corrected by their arcs' offsets, with their tracks brought up to date
/// (a phase without one starts an arc).
fn apply(i: usize, meas: &mut [Vec<SatMeas>], tracks: &mut HashMap<(Sv, usize), Track>) {
    for m in meas[i].iter_mut() {
        for f in 0..NF {
            if !m.l[f].is_finite() {
                continue;
            }
            let raw_half = m.lli[f] & LLI_HALF_CYCLE;
            let t = tracks.entry((m.sv, f)).or_insert(Track {
                last: i,
                start: i,
                offset: 0.0,
                raw_half,
            });
            t.last = i;
            t.raw_half = raw_half;
            m.l[f] += t.offset;
        }
    }
}

/// The receiver's displacement and clock change fitted to a set of misfits.
struct Fit {
    x: Vector4<f64>,
}

impl Fit {
    /// The robust fit over `diffs`: the one whose residual against the fit of the others is
    /// worst left out while more than [`FIT_MIN`] remain and it lies beyond [`FIT_FLOOR`]
    /// and four robust sigmas of the others (a jump of tens of cycles would spread over a
    /// fit that includes it); None with fewer than [`FIT_MIN`] or residuals beyond
    /// [`FIT_SIGMA`].
    fn of(diffs: &[Diff]) -> Option<Fit> {
        let mut kept: Vec<&Diff> = diffs.iter().collect();
        loop {
            if kept.len() < FIT_MIN {
                return None;
            }
            let loo: Vec<f64> = (0..kept.len())
                .map(|j| {
                    let others: Vec<&Diff> = (kept.iter().enumerate())
                        .filter(|(i, _)| *i != j)
                        .map(|(_, d)| *d)
                        .collect();
                    solve(&others).map_or(f64::INFINITY, |x| {
                        (kept[j].misfit - row(kept[j]).dot(&x)).abs()
                    })
                })
                .collect();
            let (worst, w) = loo
                .iter()
                .copied()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(&b.1))?;
            let others: Vec<&Diff> = (kept.iter().enumerate())
                .filter(|(i, _)| *i != worst)
                .map(|(_, d)| *d)
                .collect();
            let y = solve(&others)?;
            let mut spread: Vec<f64> = others
                .iter()
                .map(|d| (d.misfit - row(d).dot(&y)).abs())
                .collect();
            spread.sort_by(f64::total_cmp);
            let sigma = 1.4826 * spread[spread.len() / 2];
            if w > FIT_FLOOR.max(4.0 * sigma) {
                if kept.len() > FIT_MIN {
                    kept.swap_remove(worst);
                    continue;
                }
                return None;
            }
            let x = solve(&kept)?;
            let sum: f64 = kept
                .iter()
                .map(|d| (d.misfit - row(d).dot(&x)).powi(2))
                .sum();
            let rms = (sum / (kept.len() - 4) as f64).sqrt();
            return (rms <= FIT_SIGMA).then_some(Fit { x });
        }
    }

    /// A misfit's residual about the fit, m.
    fn residual(&self, d: &Diff) -> f64 {
        d.misfit - row(d).dot(&self.x)
    }
}

/// The design row of a misfit: minus the line of sight (displacement), one (clock).
fn row(d: &Diff) -> Vector4<f64> {
    Vector4::new(-d.los.x, -d.los.y, -d.los.z, 1.0)
}

/// Least squares over the misfits.
fn solve(diffs: &[&Diff]) -> Option<Vector4<f64>> {
    let mut n = Matrix4::zeros();
    let mut b = Vector4::zeros();
    for d in diffs {
        let a = row(d);
        n += a * a.transpose();
        b += a * d.misfit;
    }
    n.try_inverse().map(|ni| ni * b)
}

#[cfg(test)]
mod tests;
