//! Integer resolution of one epoch on the filter (or smoothed) state: the fixed solution
//! when the integers pass, checked against the two halves of the data on long baselines,
//! held when fix-and-hold allows, with the epoch's ambiguity segment.

use super::Filter;
use crate::frame::Ecef;
use crate::ppk::ar;
use crate::ppk::options::ArMode;
use crate::ppk::output::EpochSol;
use crate::ppk::pair::Pair;
use crate::ppk::segment::FixedIntegers;
use crate::ppk::smooth::Prior;
use crate::solution::Quality;
use hifitime::Epoch;

/// What the two halves of the data (before and after an epoch) say of a smoothed fix.
#[derive(Clone, Copy, Debug)]
struct HalvesSay {
    /// Neither fixes an ambiguity to another integer.
    agree: bool,
    /// Each alone fixes every integer of it (and they agree).
    confirm: bool,
}

impl Filter<'_> {
    /// What the data before and after this epoch, each alone, say of a smoothed fix: they
    /// agree when neither the forward state nor the backward `prior` resolves any ambiguity
    /// to another integer than `fix` (they may resolve fewer); they confirm it when each
    /// alone fixes every integer of `fix`. Independent halves agreeing is what makes a fix of
    /// long-baseline data trustworthy: a model error that biases the smoothed float rarely
    /// biases both halves to the same wrong integer.
    fn halves_agree(&self, fix: &ar::Fix, prior: &Prior, pairs: &[Pair]) -> HalvesSay {
        let mine = FixedIntegers::by_satellite(fix);
        let mut unused = None;
        let halves: Vec<Option<FixedIntegers<crate::sv::Sv>>> = [Some(&self.state), None]
            .into_iter()
            .map(|s| match s {
                Some(s) => ar::resolve(s, self.opts, pairs, &mut unused),
                None => ar::resolve(&prior.to_state(), self.opts, pairs, &mut unused),
            })
            .map(|h| h.map(|h| FixedIntegers::by_satellite(&h)))
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
        };
        if o.ar == ArMode::Off {
            sol.segment = self.segments.next(t, None);
            return sol;
        }
        let mut best_ratio = None;
        let raw = ar::resolve(st, o, pairs, &mut best_ratio);
        sol.widelanes = raw.as_ref().map_or(0, |f| f.widelanes);
        let mut fix = raw.filter(|f| f.complete);
        let mut confirmed = false;
        if let (Some(f), Some((_, prior))) = (&fix, &smoothed) {
            let halves = self.halves_agree(f, prior, pairs);
            confirmed = halves.confirm;
            if !halves.agree {
                self.stats.smoothed_fixes_rejected += 1;
                fix = None;
            }
        }
        let mut fixed = None;
        if let Some(fix) = fix {
            sol.float = Some((sol.pos, sol.cov));
            sol.pos = Ecef(fix.position);
            sol.cov = fix.covariance;
            sol.quality = Quality::Fixed;
            sol.ratio = fix.ratio;
            sol.nfix = fix.n_fixed;
            // A smoothed fix is held (into the forward state, so it carries forward along
            // its arcs) only when each half alone fixed every integer of it: holding one
            // that a single half or the smoothed float alone reaches held wrong integers for
            // hours on BELL-EBRE.
            if o.ar == ArMode::FixAndHold && (smoothed.is_none() || confirmed) {
                ar::hold(&mut self.state, &fix, o.hold_variance);
                let held = fix
                    .groups
                    .iter()
                    .flat_map(|g| g.others.iter().chain([&g.pivot]));
                self.stats.held_arcs.extend(held.map(|c| c.arc));
            }
            fixed = Some(FixedIntegers::of(&fix));
        } else if let Some(r) = best_ratio {
            sol.ratio = r;
        }
        sol.segment = self.segments.next(t, fixed);
        sol
    }
}
