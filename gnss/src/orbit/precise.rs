//! Precise orbits and clocks from any number of SP3 files, with clocks optionally from RINEX
//! clock files: one time-sorted table per satellite, interpolated.
//!
//! - **Merging.** The records of all files go into one table per satellite (positions) and one
//!   per satellite (clocks). An epoch present in several files (the shared midnight of
//!   consecutive days in some products, or overlapping files) keeps one value: the one from the
//!   file whose span holds the epoch most centrally (largest distance to that file's nearer
//!   end), since orbit fits are weakest at their arc ends; on a tie, the file that starts later,
//!   then the one given later. How many epochs were duplicated and how far the duplicates
//!   disagreed is kept in [`MergeReport`].
//! - **Positions**: Lagrange interpolation of degree 10 (11 consecutive samples, as centred on
//!   the time asked as the table allows), velocity by differencing it. The window may span file
//!   joins; it never spans a gap (two samples more than 1.5 nominal intervals apart), and
//!   there is no extrapolation beyond the first or last sample or across a gap: then the
//!   satellite has no position.
//! - **Clocks**: linear interpolation between the two records around the time asked (SP3
//!   clocks when no clock file is given, otherwise only the clock files' records); two records
//!   more than 2 nominal intervals apart are not bridged, and there is no extrapolation: then
//!   the satellite has no clock at that time. The relativistic correction −2 r·v/c² is added.
//!
//! SP3 positions are those of the satellite's centre of mass, broadcast ones of its antenna
//! phase centre. No satellite antenna offset is applied here: in double differences over short
//! and long baselines the difference largely cancels, and single-point code positioning does
//! not see it; precise point positioning will need it.

use super::clk::ClockFile;
use super::kepler::{SatPosClock, C};
use super::sp3::Sp3;
use crate::error::{Error, Result};
use crate::frame::Ecef;
use crate::sv::Sv;
use hifitime::Epoch;
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Points of the position interpolator (degree 10 over 15-minute samples: millimetres).
pub const NPTS: usize = 11;
/// Two position samples further apart than this many nominal intervals are a gap.
const POSITION_GAP: f64 = 1.5;
/// Clock records further apart than this many nominal intervals are not interpolated between.
const CLOCK_GAP: f64 = 2.0;
/// Epochs closer than this (seconds) are the same epoch.
const SAME_EPOCH: f64 = 1e-6;

/// Why a satellite has no position or clock at a time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Unavailable {
    /// No usable ephemeris, or no precise position (outside the tables or in a gap).
    NoOrbit,
    /// A precise position but no precise clock (outside the clock records or in a gap).
    NoClock,
}

/// Where the precise clocks come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockSource {
    /// The SP3 files' own clocks.
    Sp3,
    /// RINEX clock files (the SP3 clocks are not used).
    ClockFiles,
}

/// Epochs found in more than one file.
#[derive(Clone, Debug, Default)]
pub struct MergeReport {
    /// Satellite positions given by more than one file (one kept).
    pub duplicate_positions: usize,
    /// Largest distance between duplicated positions, metres.
    pub max_position_disagreement: f64,
    /// Satellite clocks given by more than one file (one kept).
    pub duplicate_clocks: usize,
    /// Largest difference between duplicated clocks, seconds.
    pub max_clock_disagreement: f64,
}

/// One value of a table and the nominal interval of the file it came from.
#[derive(Clone, Copy, Debug)]
struct Sample<T> {
    t: Epoch,
    v: T,
    /// Nominal interval of the source file, seconds.
    step: f64,
}

/// A record of some file, with what decides between duplicates.
struct Candidate<T> {
    sample: Sample<T>,
    /// Distance to the nearer end of the file's span, seconds.
    central: f64,
    /// Start of the file's span.
    start: Epoch,
    /// Order in which the file was given.
    order: usize,
}

impl<T> Candidate<T> {
    /// The record `v` at `t` of the `order`-th file, whose records are `step` seconds apart
    /// and span `t0`–`t1`.
    fn new(t: Epoch, v: T, step: f64, (t0, t1): (Epoch, Epoch), order: usize) -> Self {
        Candidate {
            sample: Sample { t, v, step },
            central: (t - t0).to_seconds().min((t1 - t).to_seconds()),
            start: t0,
            order,
        }
    }
}

/// Precise orbits and clocks, merged from several files.
#[derive(Clone, Debug)]
pub struct PreciseOrbits {
    positions: BTreeMap<Sv, Vec<Sample<Vector3<f64>>>>,
    clocks: BTreeMap<Sv, Vec<Sample<f64>>>,
    span: (Epoch, Epoch),
    /// Where the clocks come from.
    pub clock_source: ClockSource,
    /// The files read (SP3, then clock files).
    pub files: Vec<PathBuf>,
    /// Duplicated epochs and their disagreement.
    pub merge: MergeReport,
    /// What the user should know (files in different frames …).
    pub warnings: Vec<String>,
    /// Reference frame of the (first) SP3 file, e.g. `IGb00`.
    pub frame: String,
}

impl PreciseOrbits {
    /// Merge SP3 files (positions, and clocks when `clk` is empty) and RINEX clock files.
    pub fn new(sp3: &[Sp3], clk: &[ClockFile]) -> Result<Self> {
        let mut files: Vec<PathBuf> = sp3.iter().map(|s| s.path.clone()).collect();
        files.extend(clk.iter().map(|c| c.path.clone()));
        let names = || {
            files
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        if sp3.is_empty() {
            return Err(Error::NoData(
                "precise orbits need at least one SP3 file (clock files hold no positions)".into(),
            ));
        }
        let mut merge = MergeReport::default();
        let positions = merge_tables(sp3_candidates(sp3, |p, _| p), |a, b| (a - b).norm());
        let (duplicate_positions, max_position_disagreement) = positions.1;
        merge.duplicate_positions = duplicate_positions;
        merge.max_position_disagreement = max_position_disagreement;
        let (clocks, clock_source) = if clk.is_empty() {
            (
                merge_tables(sp3_candidates(sp3, |_, c| c), |a, b| (a - b).abs()),
                ClockSource::Sp3,
            )
        } else {
            (
                merge_tables(clk_candidates(clk), |a, b| (a - b).abs()),
                ClockSource::ClockFiles,
            )
        };
        merge.duplicate_clocks = clocks.1 .0;
        merge.max_clock_disagreement = clocks.1 .1;
        let positions = positions.0;
        let epochs = positions.values().map(Vec::len).max().unwrap_or(0);
        if epochs < NPTS {
            return Err(Error::NoData(format!(
                "{}: at most {epochs} epochs per satellite: too few to interpolate ({NPTS} needed)",
                names()
            )));
        }
        let mut it = positions.values().flat_map(|v| [v[0].t, v[v.len() - 1].t]);
        let first = it.next().unwrap_or_default();
        let span = it.fold((first, first), |(a, b), t| (a.min(t), b.max(t)));
        let mut frames: Vec<&str> = sp3.iter().map(|s| s.frame.as_str()).collect();
        frames.sort_unstable();
        frames.dedup();
        let mut warnings = Vec::new();
        if frames.len() > 1 {
            warnings.push(format!(
                "the SP3 files are in different frames ({}): merged as they are",
                frames.join(", ")
            ));
        }
        Ok(PreciseOrbits {
            positions,
            clocks: clocks.0,
            span,
            clock_source,
            files,
            merge,
            warnings,
            frame: sp3.first().map(|s| s.frame.clone()).unwrap_or_default(),
        })
    }

    /// Seconds from the clock record of `sv` before `t` and to the one after (0 and the
    /// interval at a record): how far an interpolated clock is from measured ones.
    pub fn clock_node_distance(&self, sv: Sv, t: Epoch) -> Option<(f64, f64)> {
        let v = self.clocks.get(&sv)?;
        let (k, at) = bracket(v, t)?;
        if at {
            return Some((0.0, 0.0));
        }
        Some(((t - v[k].t).to_seconds(), (v[k + 1].t - t).to_seconds()))
    }

    /// The shortest nominal interval of the clock records, seconds.
    pub fn clock_interval(&self) -> f64 {
        self.clocks
            .values()
            .flatten()
            .map(|s| s.step)
            .fold(f64::INFINITY, f64::min)
    }

    /// First and last position sample over all satellites.
    pub fn span(&self) -> (Epoch, Epoch) {
        self.span
    }

    /// First and last clock record over all satellites (`None` without any clock).
    pub fn clock_span(&self) -> Option<(Epoch, Epoch)> {
        let mut it = self
            .clocks
            .values()
            .flat_map(|v| [v[0].t, v[v.len() - 1].t]);
        let first = it.next()?;
        Some(it.fold((first, first), |(a, b), t| (a.min(t), b.max(t))))
    }

    /// Satellites with positions.
    pub fn satellites(&self) -> impl Iterator<Item = &Sv> {
        self.positions.keys()
    }

    /// The merged position samples of a satellite (GPST, ECEF metres), in time order.
    pub fn position_samples(&self, sv: Sv) -> impl Iterator<Item = (Epoch, Vector3<f64>)> + '_ {
        self.positions
            .get(&sv)
            .into_iter()
            .flatten()
            .map(|s| (s.t, s.v))
    }

    /// The merged clock samples of a satellite (GPST, seconds), in time order.
    pub fn clock_samples(&self, sv: Sv) -> impl Iterator<Item = (Epoch, f64)> + '_ {
        self.clocks
            .get(&sv)
            .into_iter()
            .flatten()
            .map(|s| (s.t, s.v))
    }

    /// Interpolated position (centre of mass, ECEF m) and velocity (m/s) at `t`.
    pub fn position(&self, sv: Sv, t: Epoch) -> Option<(Vector3<f64>, Vector3<f64>)> {
        interpolate_position(self.positions.get(&sv)?, t)
    }

    /// Interpolated clock bias (s, without the relativistic correction) and rate (s/s) at `t`.
    pub fn clock(&self, sv: Sv, t: Epoch) -> Option<(f64, f64)> {
        interpolate_clock(self.clocks.get(&sv)?, t)
    }

    /// Position, velocity and clock (relativistic correction added) at GPST `t`.
    pub fn compute(&self, sv: Sv, t: Epoch) -> std::result::Result<SatPosClock, Unavailable> {
        let (pos, vel) = self.position(sv, t).ok_or(Unavailable::NoOrbit)?;
        let (clock, clock_rate) = self.clock(sv, t).ok_or(Unavailable::NoClock)?;
        Ok(SatPosClock {
            pos: Ecef(pos),
            vel,
            clock: clock + relativistic_clock(&pos, &vel),
            clock_rate,
        })
    }
}

/// The present values (position or clock, chosen by `pick`) of every SP3 file.
fn sp3_candidates<T: Copy + Finite>(
    sp3: &[Sp3],
    pick: impl Fn(Vector3<f64>, f64) -> T,
) -> BTreeMap<Sv, Vec<Candidate<T>>> {
    let mut out: BTreeMap<Sv, Vec<Candidate<T>>> = BTreeMap::new();
    for (order, f) in sp3.iter().enumerate() {
        let Some(span) = f.span() else { continue };
        for (sv, samples) in &f.sats {
            for (&t, &(p, c)) in f.epochs.iter().zip(samples) {
                let v = pick(p, c);
                if !v.finite() {
                    continue;
                }
                let cand = Candidate::new(t, v, f.interval, span, order);
                out.entry(*sv).or_default().push(cand);
            }
        }
    }
    out
}

/// The clock records of every clock file.
fn clk_candidates(clk: &[ClockFile]) -> BTreeMap<Sv, Vec<Candidate<f64>>> {
    let mut out: BTreeMap<Sv, Vec<Candidate<f64>>> = BTreeMap::new();
    for (order, f) in clk.iter().enumerate() {
        let Some(span) = f.span() else { continue };
        for (sv, records) in &f.sats {
            out.entry(*sv).or_default().extend(
                records
                    .iter()
                    .map(|&(t, v)| Candidate::new(t, v, f.interval, span, order)),
            );
        }
    }
    out
}

/// Values that can be absent (NaN).
trait Finite {
    fn finite(&self) -> bool;
}
impl Finite for f64 {
    fn finite(&self) -> bool {
        self.is_finite()
    }
}
impl Finite for Vector3<f64> {
    fn finite(&self) -> bool {
        self.iter().all(|x| x.is_finite())
    }
}

/// Per satellite, the candidates sorted by time with one kept per epoch (the most central,
/// then the later file); also the number of duplicates dropped and their largest
/// disagreement with the value kept (`differ`).
#[allow(clippy::type_complexity)]
fn merge_tables<T: Copy>(
    cands: BTreeMap<Sv, Vec<Candidate<T>>>,
    differ: impl Fn(&T, &T) -> f64,
) -> (BTreeMap<Sv, Vec<Sample<T>>>, (usize, f64)) {
    let mut dups = 0;
    let mut worst = 0.0f64;
    let mut out = BTreeMap::new();
    for (sv, mut c) in cands {
        c.sort_by(|a, b| {
            let ord = |x: Option<std::cmp::Ordering>| x.unwrap_or(std::cmp::Ordering::Equal);
            ord(a.sample.t.partial_cmp(&b.sample.t))
                .then(ord(b.central.partial_cmp(&a.central)))
                .then(ord(b.start.partial_cmp(&a.start)))
                .then(b.order.cmp(&a.order))
        });
        let mut table: Vec<Sample<T>> = Vec::with_capacity(c.len());
        for cand in c {
            let s = cand.sample;
            match table.last() {
                Some(last) if (s.t - last.t).to_seconds().abs() < SAME_EPOCH => {
                    dups += 1;
                    worst = worst.max(differ(&last.v, &s.v));
                }
                _ => table.push(s),
            }
        }
        if !table.is_empty() {
            out.insert(sv, table);
        }
    }
    (out, (dups, worst))
}

/// Whether samples `a` and `b` (consecutive) are further apart than `limit` nominal intervals.
fn is_gap<T>(a: &Sample<T>, b: &Sample<T>, limit: f64) -> bool {
    (b.t - a.t).to_seconds() > limit * a.step.max(b.step) * (1.0 + 1e-9)
}

/// Index of the last sample at or before `t`, and whether `t` is that sample's epoch;
/// `None` before the first sample and after the last.
fn bracket<T>(v: &[Sample<T>], t: Epoch) -> Option<(usize, bool)> {
    let i = v.partition_point(|s| s.t <= t);
    let k = i.checked_sub(1)?;
    let at = (t - v[k].t).to_seconds() < SAME_EPOCH;
    if k + 1 == v.len() && !at {
        return None;
    }
    Some((k, at))
}

/// Lagrange interpolation over 11 consecutive samples without a gap around `t`.
fn interpolate_position(
    v: &[Sample<Vector3<f64>>],
    t: Epoch,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let (k, at) = bracket(v, t)?;
    if !at && is_gap(&v[k], &v[k + 1], POSITION_GAP) {
        return None;
    }
    // The run of samples without a gap around k, as far as a window can reach.
    let mut a = k;
    while a > 0 && k - a < NPTS && !is_gap(&v[a - 1], &v[a], POSITION_GAP) {
        a -= 1;
    }
    let mut b = k;
    while b + 1 < v.len() && b - k < NPTS && !is_gap(&v[b], &v[b + 1], POSITION_GAP) {
        b += 1;
    }
    if b - a + 1 < NPTS {
        return None;
    }
    let start = (k + 1).saturating_sub(NPTS / 2).clamp(a, b + 1 - NPTS);
    let w = &v[start..start + NPTS];
    let mut x = [0.0; NPTS];
    for (xj, s) in x.iter_mut().zip(w) {
        *xj = (s.t - t).to_seconds();
    }
    let lagrange = |at: f64| -> Vector3<f64> {
        let mut acc = Vector3::zeros();
        for j in 0..NPTS {
            let mut l = 1.0;
            for m in 0..NPTS {
                if m != j {
                    l *= (at - x[m]) / (x[j] - x[m]);
                }
            }
            acc += w[j].v * l;
        }
        acc
    };
    let pos = lagrange(0.0);
    let vel = (lagrange(0.05) - lagrange(-0.05)) / 0.1;
    Some((pos, vel))
}

/// Linear interpolation between the records around `t` (a record's own value at its epoch).
fn interpolate_clock(v: &[Sample<f64>], t: Epoch) -> Option<(f64, f64)> {
    let (k, at) = bracket(v, t)?;
    let rate = |i: usize| -> Option<f64> {
        let (a, b) = (v.get(i)?, v.get(i + 1)?);
        (!is_gap(a, b, CLOCK_GAP)).then(|| (b.v - a.v) / (b.t - a.t).to_seconds())
    };
    if at {
        let r = rate(k).or_else(|| rate(k.checked_sub(1)?)).unwrap_or(0.0);
        return Some((v[k].v, r));
    }
    let r = rate(k)?;
    Some((v[k].v + r * (t - v[k].t).to_seconds(), r))
}

/// The periodic relativistic clock correction −2 r·v/c² (s) of a satellite at ECEF `pos`
/// (m) moving at `vel` (m/s): what a precise clock, which leaves it out, needs added, and what
/// a broadcast clock with it applied needs taken off to be written as a precise one.
pub fn relativistic_clock(pos: &Vector3<f64>, vel: &Vector3<f64>) -> f64 {
    -2.0 * pos.dot(vel) / (C * C)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sv::Constellation;
    use hifitime::Duration;

    fn t(h: f64) -> Epoch {
        Epoch::from_gregorian_utc_at_midnight(2020, 1, 1) + Duration::from_seconds(h * 3600.0)
    }

    /// A synthetic SP3 file of one satellite on a smooth circular orbit, epochs every 15 min
    /// from `h0` to `h1` hours; `bias` is added to every position (to tell files apart).
    fn file(name: &str, h0: f64, h1: f64, bias: f64) -> Sp3 {
        let sv = Sv::new(Constellation::Gps, 1);
        let mut f = Sp3 {
            path: PathBuf::from(name),
            version: 'c',
            frame: "IGS14".into(),
            interval: 900.0,
            ..Sp3::default()
        };
        let mut samples = Vec::new();
        let mut h = h0;
        while h <= h1 + 1e-9 {
            f.epochs.push(t(h));
            let a = h * 2.0 * std::f64::consts::PI / 12.0;
            let p = Vector3::new(a.cos(), a.sin(), 0.3 * a.sin()) * 2.6e7;
            samples.push((p + Vector3::repeat(bias), 1e-4 + 1e-9 * h + bias * 1e-9));
            h += 0.25;
        }
        f.sats.insert(sv, samples);
        f
    }

    #[test]
    fn duplicates_keep_the_most_central_file() {
        let sv = Sv::new(Constellation::Gps, 1);
        // Day 1 ends at 24:00, day 2 starts at 24:00: the shared epoch is at the end of day 1
        // and at the start of day 2 (equally central): the later file wins.
        let a = file("a", 0.0, 24.0, 0.0);
        let b = file("b", 24.0, 48.0, 1.0);
        let p = PreciseOrbits::new(&[b.clone(), a.clone()], &[]).unwrap();
        assert_eq!(p.merge.duplicate_positions, 1);
        assert!((p.merge.max_position_disagreement - 3f64.sqrt()).abs() < 1e-6);
        let at24 = p.position(sv, t(24.0)).unwrap().0;
        assert!((at24 - b.sats[&sv][0].0).norm() < 1e-6);
        // A third file centred on the join holds it most centrally: it wins.
        let c = file("c", 12.0, 36.0, 2.0);
        let p = PreciseOrbits::new(&[a, b, c.clone()], &[]).unwrap();
        let at24 = p.position(sv, t(24.0)).unwrap().0;
        assert!((at24 - c.sats[&sv][48].0).norm() < 1e-6);
        // One sample per epoch over the union of the spans.
        assert_eq!(p.position_samples(sv).count(), 4 * 48 + 1);
    }

    #[test]
    fn no_extrapolation_and_no_bridging_of_gaps() {
        let sv = Sv::new(Constellation::Gps, 1);
        let mut f = file("a", 0.0, 12.0, 0.0);
        // Remove 03:00 and 03:15: a 45-minute gap in positions and clocks.
        for k in [12, 13] {
            f.sats.get_mut(&sv).unwrap()[k] = (Vector3::repeat(f64::NAN), f64::NAN);
        }
        let p = PreciseOrbits::new(&[f], &[]).unwrap();
        assert!(p.position(sv, t(-0.01)).is_none());
        assert!(p.position(sv, t(12.01)).is_none());
        assert!(p.position(sv, t(12.0)).is_some());
        assert!(p.position(sv, t(3.1)).is_none(), "inside the gap");
        assert!(p.clock(sv, t(3.1)).is_none(), "a 3-interval clock gap");
        assert!(p.clock(sv, t(2.75)).is_some(), "the record before the gap");
        // Beyond the gap the window is one-sided but still exact for a record.
        assert!(p.position(sv, t(3.5)).is_some());
        let (c, rate) = p.clock(sv, t(2.125)).unwrap();
        assert!((rate - 1e-9 / 3600.0).abs() < 1e-20);
        assert!((c - (1e-4 + 2.125e-9)).abs() < 1e-18);
    }
}
