//! Double differences at chosen instants, for an adjustment that carries the rover antenna
//! positions and the ambiguities itself (tight coupling of GNSS and photogrammetry).
//!
//! What enters: the two observation files, the base position, the orbits, the PPK options
//! (systems, slots, mask, phase σ, code/phase ratio, gap) and the instants (GPST, true time)
//! at which the rover position is wanted — the camera exposures. What leaves: per instant, the
//! rover epoch nearest to it (its true time, so the caller can move the position from the
//! instant to that epoch along its trajectory) and one [`DdRow`] per satellite, slot and
//! receiver pair: the observed double-difference phase and code minus everything the model
//! knows that does not depend on the rover position (satellite clocks, base ranges, a-priori
//! troposphere at both ends), the satellites' positions for the rover range, and the key of
//! its double-difference ambiguity.
//!
//! An ambiguity's key holds the arcs of the four phases it combines (a cycle slip or a gap in
//! any of them, found by the same detector as the filter's, starts a new key), so one key is
//! one integer wherever it appears. The pivot of a system and slot is kept from instant to
//! instant while its arcs continue, so neighbouring exposures share their keys. GLONASS is
//! left out (its double differences across channels are not integers). The ionosphere is
//! left to the caller: each row gives its slot's ionospheric scale.

use super::geometry::{day_of_year, tropo, ReceiverEpoch, SatView};
use super::inputs::{self, PassInputs};
use super::obs::NF;
use super::{arp_offset, base_marker, BasePosition, PpkOptions};
use crate::error::Result;
use crate::frame::Ecef;
use crate::orbit::{Orbits, C};
use crate::rinex::ObsFile;
use crate::sv::{Constellation, Sv};
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;
use std::collections::{BTreeMap, HashMap};

/// The key of one double-difference ambiguity: satellite, pivot, frequency slot and the arc
/// numbers of the four phases (rover and base of the satellite, rover and base of the pivot).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DdAmbiguity {
    /// The satellite.
    pub sv: Sv,
    /// The pivot it is differenced against.
    pub pivot: Sv,
    /// Frequency slot (0 = L1/E1 …).
    pub slot: u8,
    /// Arc numbers: rover satellite, base satellite, rover pivot, base pivot.
    pub arcs: [u32; 4],
}

/// One double difference (satellite minus pivot, rover minus base) of one slot at one epoch.
#[derive(Clone, Debug)]
pub struct DdRow {
    /// The satellite.
    pub sv: Sv,
    /// The pivot.
    pub pivot: Sv,
    /// Frequency slot.
    pub slot: usize,
    /// Wavelength, metres.
    pub wavelength: f64,
    /// Ionospheric scale of the slot against the system's first slot, (f₁/f)²: a delay of I
    /// on the first slot is μ·I on this one (code later, phase earlier).
    pub iono_scale: f64,
    /// Observed DD phase (m) minus the modelled terms that do not depend on the rover
    /// position; NaN without phase. Model: `range(x) + λ·N − phase`.
    pub phase: f64,
    /// The same for code (m); NaN without code. Model: `range(x) − code`.
    pub code: f64,
    /// Variance of the satellite's single difference of phase, m² (rover + base).
    pub sd_var_phase: f64,
    /// Variance of the pivot's single difference of phase, m² (shared by the rows with
    /// this pivot and slot).
    pub pivot_var_phase: f64,
    /// Variance of the satellite's single difference of code, m².
    pub sd_var_code: f64,
    /// Variance of the pivot's single difference of code, m².
    pub pivot_var_code: f64,
    /// Elevation of the satellite at the rover, radians.
    pub elevation: f64,
    /// The ambiguity, when the row has phase.
    pub ambiguity: Option<DdAmbiguity>,
    sat: SatView,
    piv: SatView,
}

impl DdRow {
    /// The rover part of the model: ρ_sat(x) − ρ_pivot(x) at rover position `x` (ECEF, m)
    /// with its gradient (−e_sat + e_pivot).
    pub fn range(&self, x: &Vector3<f64>) -> (f64, Vector3<f64>) {
        let (rs, es) = self.sat.range(x);
        let (rp, ep) = self.piv.range(x);
        (rs - rp, ep - es)
    }
}

/// The double differences at one instant.
#[derive(Clone, Debug)]
pub struct DdEpoch {
    /// Index of the instant asked for.
    pub instant: usize,
    /// True (GPST) time of the rover observations used: the rover position in the model is
    /// the one at this time.
    pub rover_time: Epoch,
    /// The rows, grouped by system and slot, the pivot's group first.
    pub rows: Vec<DdRow>,
}

/// The double differences at the instants asked for.
#[derive(Clone, Debug)]
pub struct DdSet {
    /// One entry per instant that has double differences.
    pub epochs: Vec<DdEpoch>,
    /// Instants without: index and why.
    pub missing: Vec<(usize, String)>,
    /// The base antenna reference point used, ECEF.
    pub base: Ecef,
    /// What the input checks said.
    pub warnings: Vec<String>,
}

/// The arcs of one receiver: per epoch and satellite, the arc number of each slot.
struct Arcs(Vec<HashMap<Sv, [u32; NF]>>);

impl Arcs {
    /// Arc numbers from the arc breaks: a slot's number grows at each break.
    fn of(breaks: &[super::slip::Slips], meas: &[Vec<super::obs::SatMeas>]) -> Arcs {
        let mut now: HashMap<Sv, [u32; NF]> = HashMap::new();
        let mut out = Vec::with_capacity(meas.len());
        for (b, m) in breaks.iter().zip(meas) {
            for (sv, causes) in b {
                let a = now.entry(*sv).or_insert([0; NF]);
                for (k, c) in causes.iter().enumerate() {
                    if c.is_some() {
                        a[k] += 1;
                    }
                }
            }
            out.push(
                m.iter()
                    .map(|s| (s.sv, *now.entry(s.sv).or_insert([0; NF])))
                    .collect(),
            );
        }
        Arcs(out)
    }
}

/// Double differences of the rover epochs nearest to `instants` (GPST true times; an instant
/// farther than half a rover interval from every epoch, or whose epoch has no base epoch or
/// too few satellites, is listed in `missing`). The code of each row is smoothed by the
/// carrier over the rover epochs within `window` seconds either side where the four phases
/// continue (the mean code-minus-phase added to the epoch's phase), and its variance divided
/// by their number: windows that do not overlap keep the rows of different instants
/// independent.
pub fn double_differences(
    rover: &ObsFile,
    base: &ObsFile,
    base_pos: BasePosition,
    orbits: &Orbits,
    opts: &PpkOptions,
    instants: &[Epoch],
    window: f64,
) -> Result<DdSet> {
    let mut warnings = Vec::new();
    super::require_phase(rover, "rover")?;
    super::require_phase(base, "base")?;
    let marker = base_marker(base, base_pos, &mut warnings)?;
    let base_arp = Ecef(marker.0 + arp_offset(&base.header, &marker));
    let mut opts = opts.clone();
    if opts.max_gap <= 0.0 {
        opts.max_gap = (5.0 * super::interval(&rover.epochs)).max(5.0);
    }
    let inp = inputs::prepare(
        (rover, inputs::Records::Borrowed(&rover.epochs)),
        (base, inputs::Records::Borrowed(&base.epochs)),
        orbits,
        &opts,
        &base_arp,
        &mut warnings,
    )?;
    let rover_arcs = Arcs::of(&inp.rover_breaks, &inp.rover_meas);
    let base_arcs = Arcs::of(&inp.base_breaks, &inp.base_meas);
    let times: Vec<Epoch> = inp
        .starts
        .iter()
        .zip(&rover.epochs)
        .map(|(s, e)| match s {
            Ok((_, dt)) => e.time - Duration::from_seconds(*dt),
            Err(_) => e.time,
        })
        .collect();
    let half = 0.5 * super::interval(&rover.epochs) + 1e-6;
    let mut set = DdSet {
        epochs: Vec::new(),
        missing: Vec::new(),
        base: base_arp,
        warnings,
    };
    let mut pivots: BTreeMap<(Constellation, usize), (Sv, [u32; 2])> = BTreeMap::new();
    let ctx = Ctx {
        inp: &inp,
        opts: &opts,
        base_arp,
        rover_arcs: &rover_arcs,
        base_arcs: &base_arcs,
        times: &times,
        window,
    };
    for (n, t) in instants.iter().enumerate() {
        let i = times.partition_point(|x| x < t);
        let near = [i.checked_sub(1), (i < times.len()).then_some(i)]
            .into_iter()
            .flatten()
            .min_by(|a, b| {
                let da = (times[*a] - *t).abs();
                let db = (times[*b] - *t).abs();
                da.partial_cmp(&db).unwrap_or(std::cmp::Ordering::Equal)
            });
        let Some(i) = near.filter(|i| (times[*i] - *t).abs().to_seconds() <= half) else {
            set.missing.push((n, "no rover epoch at that time".into()));
            continue;
        };
        match ctx.epoch(i, &mut pivots) {
            Ok(rows) => set.epochs.push(DdEpoch {
                instant: n,
                rover_time: times[i],
                rows,
            }),
            Err(why) => set.missing.push((n, why)),
        }
    }
    Ok(set)
}

/// What forming one epoch's rows reads.
struct Ctx<'a> {
    inp: &'a PassInputs,
    opts: &'a PpkOptions,
    base_arp: Ecef,
    rover_arcs: &'a Arcs,
    base_arcs: &'a Arcs,
    /// True times of the rover epochs.
    times: &'a [Epoch],
    /// Half-width of the code smoothing window, seconds.
    window: f64,
}

/// One satellite's single differences of one slot (rover − base), before differencing.
struct Sd {
    sv: Sv,
    el: f64,
    phase: f64,
    code: f64,
    known: f64,
    var_phase: f64,
    var_code: f64,
    arcs: [u32; 2],
    lambda: f64,
    iono_scale: f64,
    view: SatView,
}

impl Ctx<'_> {
    /// The rows of rover epoch `i`, pivots kept in `pivots` while their arcs continue.
    fn epoch(
        &self,
        i: usize,
        pivots: &mut BTreeMap<(Constellation, usize), (Sv, [u32; 2])>,
    ) -> std::result::Result<Vec<DdRow>, String> {
        let Some(j) = self.inp.matched[i] else {
            return Err("no base epoch within the age limit".into());
        };
        let Ok((start, _)) = &self.inp.starts[i] else {
            return Err("no code solution of the rover".into());
        };
        let (r, b) = (self.inp.rover_epoch(i), self.inp.base_epoch(j));
        let groups = self.single_differences(start, &r, &b, i, j);
        let mut rows = Vec::new();
        for ((sys, slot), sds) in groups {
            if sds.len() < 2 {
                continue;
            }
            let keep = pivots
                .get(&(sys, slot))
                .and_then(|(sv, arcs)| sds.iter().position(|s| s.sv == *sv && s.arcs == *arcs));
            let p = keep.unwrap_or_else(|| {
                (0..sds.len())
                    .max_by(|a, b| sds[*a].el.total_cmp(&sds[*b].el))
                    .unwrap_or(0)
            });
            let piv = &sds[p];
            pivots.insert((sys, slot), (piv.sv, piv.arcs));
            for s in sds.iter().filter(|s| s.sv != piv.sv) {
                rows.push(DdRow {
                    sv: s.sv,
                    pivot: piv.sv,
                    slot,
                    wavelength: s.lambda,
                    iono_scale: s.iono_scale,
                    phase: (s.phase - piv.phase) - (s.known - piv.known),
                    code: (s.code - piv.code) - (s.known - piv.known),
                    sd_var_phase: s.var_phase,
                    pivot_var_phase: piv.var_phase,
                    sd_var_code: s.var_code,
                    pivot_var_code: piv.var_code,
                    elevation: s.el,
                    ambiguity: s.phase.is_finite().then_some(DdAmbiguity {
                        sv: s.sv,
                        pivot: piv.sv,
                        slot: slot as u8,
                        arcs: [s.arcs[0], s.arcs[1], piv.arcs[0], piv.arcs[1]],
                    }),
                    sat: s.view,
                    piv: piv.view,
                });
            }
        }
        if rows.len() < 3 {
            return Err(format!(
                "{} double differences (at least 3 needed)",
                rows.len()
            ));
        }
        self.smooth_code(i, &mut rows);
        Ok(rows)
    }

    /// Carrier-smoothed code: each row's code becomes its phase plus the mean code-minus-phase
    /// over the epochs within the window where the satellite's and the pivot's arcs continue.
    fn smooth_code(&self, i: usize, rows: &mut [DdRow]) {
        let t = self.times[i];
        let near = |k: usize| (self.times[k] - t).abs().to_seconds() <= self.window;
        let lo = (0..i).rev().take_while(|&k| near(k)).last().unwrap_or(i);
        let hi = (i..self.times.len())
            .take_while(|&k| near(k))
            .last()
            .unwrap_or(i);
        let mut sum: Vec<(f64, usize)> = rows
            .iter()
            .map(|r| {
                let cmc = r.code - r.phase;
                if cmc.is_finite() {
                    (cmc, 1)
                } else {
                    (0.0, 0)
                }
            })
            .collect();
        for k in (lo..=hi).filter(|k| *k != i) {
            let (Some(j), Ok((start, _))) = (self.inp.matched[k], &self.inp.starts[k]) else {
                continue;
            };
            let (r, b) = (self.inp.rover_epoch(k), self.inp.base_epoch(j));
            let groups = self.single_differences(start, &r, &b, k, j);
            for (row, acc) in rows.iter().zip(&mut sum) {
                let Some((a, amb)) = groups.get(&(row.sv.sys, row.slot)).zip(row.ambiguity) else {
                    continue;
                };
                let find = |sv: Sv, arcs: [u32; 2]| a.iter().find(|s| s.sv == sv && s.arcs == arcs);
                let (Some(s), Some(p)) = (
                    find(row.sv, [amb.arcs[0], amb.arcs[1]]),
                    find(row.pivot, [amb.arcs[2], amb.arcs[3]]),
                ) else {
                    continue;
                };
                let cmc = (s.code - p.code) - (s.phase - p.phase);
                if cmc.is_finite() && acc.1 > 0 {
                    acc.0 += cmc;
                    acc.1 += 1;
                }
            }
        }
        for (row, (s, n)) in rows.iter_mut().zip(sum) {
            if n > 0 {
                row.code = row.phase + s / n as f64;
                row.sd_var_code /= n as f64;
                row.pivot_var_code /= n as f64;
            }
        }
    }

    /// Single differences of every satellite with phase at both receivers above the mask,
    /// per (system, slot); GLONASS left out.
    fn single_differences(
        &self,
        start: &Ecef,
        r: &ReceiverEpoch,
        b: &ReceiverEpoch,
        i: usize,
        j: usize,
    ) -> BTreeMap<(Constellation, usize), Vec<Sd>> {
        let (gr, gb) = (start.to_geodetic(), self.base_arp.to_geodetic());
        let doy = day_of_year(r.time);
        let mut out: BTreeMap<(Constellation, usize), Vec<Sd>> = BTreeMap::new();
        for (k, m) in r.meas.iter().enumerate() {
            if m.sv.sys == Constellation::Glonass {
                continue;
            }
            let Some(bk) = b.meas.iter().position(|x| x.sv == m.sv) else {
                continue;
            };
            let (Some(vr), Some(vb)) = (r.views[k], b.views[bk]) else {
                continue;
            };
            let (_, el) = vr.az_el(start, &gr);
            let (_, elb) = vb.az_el(&self.base_arp, &gb);
            if el < self.opts.elev_mask || elb <= 0.0 {
                continue;
            }
            let bm = &b.meas[bk];
            let (ra, ba) = (
                self.rover_arcs.0[i].get(&m.sv),
                self.base_arcs.0[j].get(&m.sv),
            );
            let (Some(ra), Some(ba)) = (ra, ba) else {
                continue;
            };
            // Everything but the rover range: the base range, both a-priori tropospheres
            // and both satellite clocks.
            let (rb, _) = vb.range(&self.base_arp.0);
            let known =
                tropo(&gr, el, doy) - C * vr.clock - (rb + tropo(&gb, elb, doy)) + C * vb.clock;
            for slot in 0..self.opts.nf.min(NF) {
                let (lr, lb) = (m.l[slot], bm.l[slot]);
                if !(lr.is_finite() && lb.is_finite() && m.freq[slot].is_finite()) {
                    continue;
                }
                let lambda = m.wavelength(slot);
                let f1 = if m.freq[0].is_finite() {
                    m.freq[0]
                } else {
                    1575.42e6
                };
                let (pr, pb) = (m.p[slot], bm.p[slot]);
                let vp = var_phase(el, self.opts) + var_phase(elb, self.opts);
                out.entry((m.sv.sys, slot)).or_default().push(Sd {
                    sv: m.sv,
                    el,
                    phase: lambda * (lr - lb),
                    code: if pr.is_finite() && pb.is_finite() {
                        pr - pb
                    } else {
                        f64::NAN
                    },
                    known,
                    var_phase: vp,
                    var_code: vp * self.opts.code_phase_ratio.powi(2),
                    arcs: [ra[slot], ba[slot]],
                    lambda,
                    iono_scale: (f1 / m.freq[slot]).powi(2),
                    view: vr,
                });
            }
        }
        out
    }
}

/// Variance of one undifferenced phase at elevation `el` (the filter's model), m².
fn var_phase(el: f64, o: &PpkOptions) -> f64 {
    let s = el.sin().max(0.05);
    o.phase_sigma.0.powi(2) + (o.phase_sigma.1 / s).powi(2)
}
