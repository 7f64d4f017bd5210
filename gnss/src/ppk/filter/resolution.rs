//! Integer resolution of one epoch on the filter (or smoothed) state: the fixed solution
//! when the integers pass, checked against the two halves of the data on long baselines,
//! held when fix-and-hold allows, with the epoch's ambiguity segment.

use super::Filter;
use crate::frame::Ecef;
use crate::ppk::ar;
use crate::ppk::combine::try_mahalanobis2;
use crate::ppk::options::{ArMode, Estimate, PpkOptions};
use crate::ppk::output::EpochSol;
use crate::ppk::pair::Pair;
use crate::ppk::refusal::Refusal;
use crate::ppk::segment::FixedIntegers;
use crate::ppk::smooth::Prior;
use crate::ppk::state::State;
use crate::solution::Quality;
use crate::sv::Sv;
use hifitime::Epoch;

/// What the two halves of the data (before and after an epoch) say of a smoothed fix.
#[derive(Clone, Copy, Debug)]
struct HalvesSay {
    /// Neither fixes an ambiguity to another integer.
    agree: bool,
    /// Each alone fixes every integer of it (and they agree).
    confirm: bool,
}

/// Satellites with candidate ambiguities needed before one is left out: six must remain to
/// carry the fix and show the seventh's error (with fewer, BELL–EBRE's late evening gave
/// fixes 12–16 cm high at a 15° mask).
const LEAVE_OUT_MIN_SATELLITES: usize = 7;
/// The ratio a fix with a satellite left out must reach, as a multiple of the threshold:
/// one satellite after another is tried, and the best of several searches is held to more.
const LEAVE_OUT_RATIO_FACTOR: f64 = 1.25;

/// The largest squared Mahalanobis distance (in the float covariance) from the float position
/// to the fixed one that a long-baseline fix may move: χ²(3) at 99 %. A right fix lies
/// within the float's own error of it; on long baselines the float also carries errors that
/// last for hours (orbits, troposphere) and the integers that best absorb them can be wrong
/// by a narrow-lane cycle yet pass the ratio test: BELL–EBRE with four satellites' orbits
/// missing fixed 9 cm east of its float (3.5–5 σ) for an hour and a half, 252 fixed epochs
/// more than 10 cm off, NEES of the fixed epochs 3.7; held to this, 15 and 0.53, while the
/// full day keeps 86 % fixed.
const FLOAT_CONSISTENCY_CHI2: f64 = 11.34;

/// Whether a fixed position lies within the float solution's own error of it: the squared
/// Mahalanobis distance of the shift, in the float position covariance, at most
/// [`FLOAT_CONSISTENCY_CHI2`] (a singular float covariance passes: nothing to test with).
fn near_float(fixed: &nalgebra::Vector3<f64>, float: &State) -> bool {
    try_mahalanobis2(&(fixed - float.position()), &float.position_cov())
        .is_none_or(|m2| m2 <= FLOAT_CONSISTENCY_CHI2)
}

/// Resolve on `st` as [`ar::resolve`] does; on long baselines (the ionosphere estimated),
/// when the whole set gives no fixed solution, each satellite is left out in turn: one
/// satellite's model error — an orbit metres off, as a stale upload leaves it (BELL–EBRE's
/// PRN 21 in the afternoon), or multipath — spoils every integer set it is in. The fixes
/// that pass without one satellite (at [`LEAVE_OUT_RATIO_FACTOR`] times the ratio threshold,
/// with [`LEAVE_OUT_MIN_SATELLITES`]) are taken only when they agree on every integer they
/// share (else the model error is not one satellite's); then the one with the highest ratio.
fn resolve_leaving_one_out(
    st: &State,
    o: &PpkOptions,
    pairs: &[Pair],
    best_ratio: &mut Option<f64>,
) -> Result<ar::Fix, Refusal> {
    let full = ar::resolve(st, o, pairs, best_ratio);
    if o.iono != Estimate::On || full.as_ref().is_ok_and(|f| f.precise(o)) {
        return full;
    }
    let sats = ar::candidate_satellites(st, o, pairs);
    if sats.len() < LEAVE_OUT_MIN_SATELLITES {
        return full;
    }
    let passing: Vec<ar::Fix> = sats
        .into_iter()
        .filter_map(|sv| ar::resolve_without(st, o, pairs, &mut None, Some(sv)).ok())
        .filter(|f| f.precise(o))
        .filter(|f| f.ratio >= o.ratio_threshold * LEAVE_OUT_RATIO_FACTOR)
        .collect();
    let named: Vec<FixedIntegers<Sv>> = passing.iter().map(FixedIntegers::by_satellite).collect();
    let agree = named
        .iter()
        .enumerate()
        .all(|(i, a)| named[i + 1..].iter().all(|b| !a.conflicts(b)));
    if !agree {
        return full;
    }
    passing
        .into_iter()
        .reduce(|a, b| if b.ratio > a.ratio { b } else { a })
        .map_or(full, Ok)
}

impl Filter<'_> {
    /// What the data before and after this epoch, each alone, say of a smoothed fix: they
    /// agree when neither the forward state nor the backward `prior` resolves any ambiguity
    /// to another integer than `fix` (they may resolve fewer); they confirm it when each
    /// alone fixes every integer of `fix` (each with the satellite `fix` left float, if it
    /// left one out, left float too). Independent halves agreeing is what makes a fix of
    /// long-baseline data trustworthy: a model error that biases the smoothed float rarely
    /// biases both halves to the same wrong integer.
    fn halves_agree(&self, fix: &ar::Fix, prior: &Prior, pairs: &[Pair]) -> HalvesSay {
        let mine = FixedIntegers::by_satellite(fix);
        let mut unused = None;
        let halves: Vec<Option<FixedIntegers<crate::sv::Sv>>> = [Some(&self.state), None]
            .into_iter()
            .map(|s| match s {
                Some(s) => ar::resolve_without(s, self.opts, pairs, &mut unused, fix.left_out),
                None => {
                    let s = prior.to_state();
                    ar::resolve_without(&s, self.opts, pairs, &mut unused, fix.left_out)
                }
            })
            .map(|h| h.ok().map(|h| FixedIntegers::by_satellite(&h)))
            .collect();
        let agree = halves
            .iter()
            .all(|h| h.as_ref().is_none_or(|h| !h.conflicts(&mine)));
        let confirm = agree
            && halves
                .iter()
                .all(|h| h.as_ref().is_some_and(|h| mine.covered_by(h)));
        HalvesSay { agree, confirm }
    }

    /// Whether every ambiguity of `fix` continues an arc this pass has held.
    fn all_held(&self, fix: &ar::Fix) -> bool {
        fix.arcs().all(|a| self.stats.held_arcs.contains(&a))
    }

    /// The float solution (the smoothed one when given), replaced by the fixed one when the
    /// ambiguities resolve (and then held in fix-and-hold mode; a smoothed fix only when both
    /// halves confirm it), with its ambiguity segment.
    pub(super) fn solve(
        &mut self,
        t: Epoch,
        age: f64,
        used_sats: usize,
        pairs: &[Pair],
        smoothed: Option<(crate::ppk::state::State, &Prior)>,
    ) -> EpochSol {
        let o = self.opts;
        let st = smoothed.as_ref().map_or(&self.state, |s| &s.0);
        let mut sol = EpochSol {
            time: t,
            pos: Ecef(st.position()),
            cov: st.position_cov(),
            quality: Quality::Float,
            nsat: used_sats,
            ratio: 0.0,
            age,
            nfix: 0,
            widelanes: 0,
            segment: 0,
            float: None,
            refused: None,
            alone: smoothed
                .is_some()
                .then(|| (Ecef(self.state.position()), self.state.position_cov())),
        };
        if o.ar == ArMode::Off {
            sol.segment = self.segments.next(t, None);
            return sol;
        }
        let mut best_ratio = None;
        // A fix found with a satellite left out is taken only where the halves check it
        // (the smoother): held by a single pass, a wrong one spreads along the arcs.
        let raw = match smoothed {
            Some(_) => resolve_leaving_one_out(st, o, pairs, &mut best_ratio),
            None => ar::resolve(st, o, pairs, &mut best_ratio),
        };
        sol.widelanes = raw.as_ref().map_or(0, |f| f.widelanes);
        let mut fix = raw.and_then(|f| {
            if f.precise(o) || (f.complete && o.weak_held_fixes_stand() && self.all_held(&f)) {
                Ok(f)
            } else {
                Err(Refusal::SigmaLimit)
            }
        });
        let mut confirmed = false;
        if let (Ok(f), Some((_, prior))) = (&fix, &smoothed) {
            let halves = self.halves_agree(f, prior, pairs);
            confirmed = halves.confirm;
            if !halves.agree {
                self.stats.smoothed_fixes_rejected += 1;
                fix = Err(Refusal::HalvesDisagree);
            }
        }
        // On long baselines a fix must also lie near the float it came from (see
        // FLOAT_CONSISTENCY_CHI2), before it is reported or held.
        if o.iono == Estimate::On && fix.as_ref().is_ok_and(|f| !near_float(&f.position, st)) {
            self.stats.far_from_float_fixes += 1;
            fix = Err(Refusal::FarFromFloat);
        }
        let mut fixed = None;
        sol.refused = fix.as_ref().err().copied();
        if let Ok(fix) = fix {
            sol.float = Some((sol.pos, sol.cov));
            sol.pos = Ecef(fix.position);
            sol.cov = fix.covariance;
            sol.quality = Quality::Fixed;
            sol.ratio = fix.ratio;
            sol.nfix = fix.n_fixed;
            self.stats.left_out_fixes += usize::from(fix.left_out.is_some());
            // A smoothed fix is held (into the forward state, so it carries forward along
            // its arcs) only when each half alone fixed every integer of it: holding one
            // that a single half or the smoothed float alone reaches held wrong integers for
            // hours on BELL-EBRE.
            if o.ar == ArMode::FixAndHold && (smoothed.is_none() || confirmed) {
                ar::hold(&mut self.state, &fix, o.hold_variance);
                self.stats.held_arcs.extend(fix.arcs());
            }
            fixed = Some(FixedIntegers::of(&fix));
        } else if let Some(r) = best_ratio {
            sol.ratio = r;
        }
        sol.segment = self.segments.next(t, fixed);
        sol
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// The test is χ²(3) at 99 % in the float's own covariance: 3σ along an axis passes,
    /// 3.5σ does not, and a correlated covariance judges by direction.
    #[test]
    fn a_fix_within_its_float_error_passes_and_beyond_it_is_refused() {
        let mut st = State::new(0.02f64.powi(2));
        st.x[0] = 4_775_849.4;
        let at = |st: &State, d: Vector3<f64>| near_float(&(st.position() + d), st);
        assert!(at(&st, Vector3::new(0.06, 0.0, 0.0)));
        assert!(!at(&st, Vector3::new(0.07, 0.0, 0.0)));
        assert!(!at(&st, Vector3::new(0.0, 0.0, -0.07)));
        // x and y correlated 0.9: 4 cm along (1, 1) is 1.4σ, along (1, −1) 6.3σ.
        st.p[(0, 1)] = 0.9 * 0.02f64.powi(2);
        st.p[(1, 0)] = st.p[(0, 1)];
        let k = 0.04 / 2f64.sqrt();
        assert!(at(&st, Vector3::new(k, k, 0.0)));
        assert!(!at(&st, Vector3::new(k, -k, 0.0)));
        // Nothing to test with: a singular covariance passes.
        assert!(at(&State::new(0.0), Vector3::new(1.0, 0.0, 0.0)));
    }
}
