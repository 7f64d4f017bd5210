//! Baarda data snooping with removal, and Förstner variance components per group.

use super::cofactor::Reliability;
use super::error::SolveError;
use super::factor::{FactorId, Group};
use super::lm::Summary;
use super::problem::Problem;

/// σ multiplier of a suspect that cannot be removed (it keeps its block determined, with
/// next to no weight).
pub const KEPT_SIGMA_FACTOR: f64 = 100.0;

/// Most suspects tested together in one round of data snooping.
pub const BATCH: usize = 64;

/// Least redundancy of a group whose variance component is always estimated.
pub const MIN_VCE_REDUNDANCY: f64 = 10.0;

/// Least redundancy of a group whose variance component [`Problem::gross_variance_components`]
/// estimates when its σ are plainly too small (see [`plainly_too_small`]).
pub const MIN_VCE_REDUNDANCY_WRONG: f64 = 2.0;

/// Whether a group's vᵀPv / r = `f` at redundancy `r` lies above the 99.95 % quantile of
/// χ²(r)/r (Wilson–Hilferty): its σ are too small beyond doubt, even with little redundancy
/// (navigation-grade GNSS centres given survey σ, in a block without tie points, have a
/// redundancy of a few units, and then the image points would take the blame). Only this
/// direction: σ too large are safe, and a small vᵀPv on a few units of redundancy is chance.
pub fn plainly_too_small(f: f64, r: f64) -> bool {
    let z = normal_quantile(1.0 - 0.0005);
    let a = 2.0 / (9.0 * r);
    f > (1.0 - a + z * a.sqrt()).powi(3)
}

impl Problem {
    /// Data snooping: adjust, remove the factor with the largest |w| above `critical`, repeat.
    /// Suspects whose tests hardly depend on each other are removed in the same round: the
    /// next worst ones that stay above `critical` after the worse ones' possible influence is
    /// taken off (see `independent_suspects`), so a large block with many blunders needs
    /// few rounds, while a good observation inflated by a blunder waits for the next round.
    /// Returns the last adjustment and the removed factors in removal order with their |w|; a
    /// block of an eliminated kind that a removal leaves undetermined (no more residual rows
    /// than unknowns) is fixed out, its remaining factors following with w = 0. A factor whose
    /// removal would leave any other block undetermined is kept (never an abort): it is
    /// listed by [`Self::kept_suspects`], its σ multiplied by `KEPT_SIGMA_FACTOR` (so its
    /// blunder does not spread into its neighbours), and the next largest |w| is tested.
    pub fn data_snooping(
        &mut self,
        critical: f64,
    ) -> Result<(Summary, Vec<(FactorId, f64)>), SolveError> {
        let t0 = std::time::Instant::now();
        let mut removed = Vec::new();
        let mut round = 0;
        loop {
            round += 1;
            self.notify(super::problem::SolveStep::SnoopingRound(round));
            let summary = self.solve()?;
            let rel = self.reliability()?;
            let batch = self.independent_suspects(&rel, critical)?;
            if batch.is_empty() {
                self.time("snooping", t0);
                return Ok((summary, removed));
            }
            // The normals of the blocks with many observations, kept up to date through the
            // round's removals (the values change only with the next solve).
            let mut normals = Normals::new();
            for (k, w) in batch {
                // A suspect that must be kept is weighted down: the others' tests change.
                if !self.remove_or_keep(k, w, &mut removed, &mut normals)? {
                    break;
                }
            }
        }
    }

    /// Remove suspect `k` (|w| = `w`), or keep it weighted down when its removal would leave
    /// a block undetermined. Returns whether it was removed.
    fn remove_or_keep(
        &mut self,
        k: FactorId,
        w: f64,
        removed: &mut Vec<(FactorId, f64)>,
        normals: &mut Normals,
    ) -> Result<bool, SolveError> {
        if self.model.entries[k.0].removed {
            return Ok(true);
        }
        let mark = removed.len();
        let fixed_before = self.model.fixed.clone();
        self.model.entries[k.0].removed = true;
        removed.push((k, w));
        self.drop_undetermined(k, removed);
        if !self.still_determined(&removed[mark..], normals)? {
            for (f, _) in removed.drain(mark..) {
                self.model.entries[f.0].removed = false;
            }
            self.model.fixed = fixed_before;
            // Its weight changes below: the normals of its blocks with it.
            for b in &self.model.entries[k.0].blocks {
                normals.remove(b);
            }
            // Kept, but weighted down so that its blunder does not spread into the
            // observations around it (which would then be removed instead).
            let e = &mut self.model.entries[k.0];
            e.noise = e.noise.scaled(KEPT_SIGMA_FACTOR, e.factor.dim());
            self.model.kept.push((k, w));
            return Ok(false);
        }
        Ok(true)
    }

    /// Whether every free block is still determined by its own observations once `gone` are
    /// removed. Only the blocks those factors touch can have changed: each is tested alone
    /// when the problem asks for a unique solution (every block was determined at the last
    /// solve, and each removal since kept them so); otherwise the whole problem is. A block
    /// with more than [`KEEP_NORMALS`] observations (an image's pose) keeps its normals in
    /// `normals`, the removed factors' parts subtracted, instead of summing thousands again.
    fn still_determined(
        &mut self,
        gone: &[(FactorId, f64)],
        normals: &mut Normals,
    ) -> Result<bool, SolveError> {
        if !self.options.unique {
            return Ok(self.undetermined()?.is_empty());
        }
        let mut blocks: Vec<usize> = gone
            .iter()
            .flat_map(|(f, _)| self.model.entries[f.0].blocks.iter().copied())
            .filter(|&b| !self.model.fixed[b])
            .collect();
        blocks.sort_unstable();
        blocks.dedup();
        let mut updated = Vec::new();
        for b in blocks {
            // The normals after the removal, and whether to keep them for the round's next.
            let (n, keep) = match normals.get(&b) {
                Some(before) => {
                    let mut part = nalgebra::DMatrix::zeros(before.nrows(), before.ncols());
                    for (f, _) in gone {
                        if self.model.entries[f.0].blocks.contains(&b) {
                            self.model.add_factor_normals(f.0, b, &mut part)?;
                        }
                    }
                    (before - part, true)
                }
                None => {
                    let (n, count) = self.model.block_normals(b)?;
                    (n, count > KEEP_NORMALS)
                }
            };
            if !super::lin::regular(n.clone()) {
                return Ok(false);
            }
            if keep {
                updated.push((b, n));
            }
        }
        normals.extend(updated);
        Ok(true)
    }

    /// The suspects of one round, worst first: the worst active factor with |w| above
    /// `critical` (kept suspects aside), and each of the next worst (up to [`BATCH`] in all)
    /// that stays above `critical` even when every worse suspect's |w| is taken for a blunder
    /// of its own: |w_b| − Σ_a |ρ_ab|·|w_a| > critical for some component b, over the
    /// components a of the worse suspects (ρ: the correlation of the normalised residuals,
    /// `correl`). A good observation inflated by a blunder nearby, or through the datum,
    /// waits for the next round. The worst always comes first (ties: the last factor, as one
    /// removal per round did).
    fn independent_suspects(
        &self,
        rel: &[Reliability],
        critical: f64,
    ) -> Result<Vec<(FactorId, f64)>, SolveError> {
        let kept: Vec<FactorId> = self.model.kept.iter().map(|k| k.0).collect();
        let mut sus: Vec<(FactorId, f64, usize)> = rel
            .iter()
            .enumerate()
            .filter(|(_, r)| !kept.contains(&r.factor))
            .map(|(k, r)| (r.factor, r.normalised.amax(), k))
            .filter(|s| s.1 > critical)
            .collect();
        sus.sort_by(|a, b| b.1.total_cmp(&a.1).then(b.0 .0.cmp(&a.0 .0)));
        sus.truncate(BATCH);
        let mut out: Vec<(FactorId, f64)> = sus.iter().take(1).map(|s| (s.0, s.1)).collect();
        if sus.len() < 2 {
            return Ok(out);
        }
        let q = self.cofactors()?;
        let ks: Vec<usize> = sus.iter().map(|s| s.2).collect();
        let r: Vec<&nalgebra::DVector<f64>> = ks.iter().map(|&k| &rel[k].redundancy).collect();
        let Some(rho) = q.correlations(&ks, &r) else {
            return Ok(out);
        };
        for j in 1..ks.len() {
            let wj = &rel[ks[j]].normalised;
            let still = (0..wj.len()).any(|b| {
                let shift: f64 = (0..j)
                    .map(|i| {
                        let wi = &rel[ks[i]].normalised;
                        (0..wi.len())
                            .map(|a| rho[j][i][(a, b)] * wi[a].abs())
                            .sum::<f64>()
                    })
                    .sum();
                wj[b].abs() - shift > critical
            });
            if still {
                out.push((sus[j].0, sus[j].1));
            }
        }
        Ok(out)
    }

    /// Factors data snooping found suspect (|w| above the critical value) but kept, because
    /// removing them would have left a block undetermined, with their |w|.
    pub fn kept_suspects(&self) -> &[(FactorId, f64)] {
        &self.model.kept
    }

    /// After removing factor `k`: a block of an eliminated kind it touched that is left with
    /// no more residual rows than unknowns is fixed out, with its remaining factors.
    fn drop_undetermined(&mut self, k: FactorId, removed: &mut Vec<(FactorId, f64)>) {
        let blocks: Vec<usize> = self.model.entries[k.0]
            .blocks
            .iter()
            .copied()
            .filter(|&b| {
                !self.model.fixed[b] && self.options.eliminate.contains(&self.model.keys[b].kind())
            })
            .collect();
        for b in blocks {
            let active: Vec<usize> = (0..self.model.entries.len())
                .filter(|&j| {
                    !self.model.entries[j].removed && self.model.entries[j].blocks.contains(&b)
                })
                .collect();
            let rows: usize = active
                .iter()
                .map(|&j| self.model.entries[j].factor.dim())
                .sum();
            if rows <= self.model.values[b].dim() {
                for j in active {
                    self.model.entries[j].removed = true;
                    removed.push((FactorId(j), 0.0));
                }
                self.model.fixed[b] = true;
            }
        }
    }

    /// Variance component estimation (Förstner): per group σ̂² = vᵀPv / r over the group,
    /// iterated until the factors settle; groups with a redundancy below
    /// [`MIN_VCE_REDUNDANCY`] keep their weights. Returns each group's σ multiplier (√ of its
    /// variance factor), indexed by [`Group`].
    pub fn variance_components(&mut self, max_rounds: usize) -> Result<Vec<f64>, SolveError> {
        self.estimate_components(max_rounds, false)?;
        Ok(self.model.group_scale.iter().map(|s| s.sqrt()).collect())
    }

    /// Variance components for σ that are wrong by far, before data snooping would weigh the
    /// right observations of such a group down one by one: estimated as
    /// [`Self::variance_components`] does, a group of redundancy [`MIN_VCE_REDUNDANCY_WRONG`]
    /// or more also when its σ are plainly too small ([`plainly_too_small`]); then only a
    /// group whose σ multiplier came out beyond `beyond` keeps it, every other one its
    /// weight of before. Returns each group's σ multiplier.
    pub fn gross_variance_components(
        &mut self,
        max_rounds: usize,
        beyond: f64,
    ) -> Result<Vec<f64>, SolveError> {
        let before = self.model.group_scale.clone();
        self.estimate_components(max_rounds, true)?;
        for (s, b) in self.model.group_scale.iter_mut().zip(&before) {
            if *s < b * beyond * beyond {
                *s = *b;
            }
        }
        Ok(self.model.group_scale.iter().map(|s| s.sqrt()).collect())
    }

    /// The Förstner iterations; `low`: groups of little redundancy whose σ are plainly too
    /// small are estimated too.
    fn estimate_components(&mut self, max_rounds: usize, low: bool) -> Result<(), SolveError> {
        for _ in 0..max_rounds {
            self.solve()?;
            let (num, red) = self.group_sums()?;
            let mut change: f64 = 0.0;
            for g in 0..self.model.group_scale.len() {
                // A group with little redundancy keeps its weight: its estimate would be
                // noise (unless, with `low`, it is plainly too small).
                let f = num[g] / red[g];
                if red[g] >= MIN_VCE_REDUNDANCY
                    || (low && red[g] >= MIN_VCE_REDUNDANCY_WRONG && plainly_too_small(f, red[g]))
                {
                    self.model.group_scale[g] *= f;
                    change = change.max((f - 1.0).abs());
                }
            }
            if change < 0.01 {
                break;
            }
        }
        Ok(())
    }

    /// σ multiplier of a group (√ of its variance factor).
    pub fn group_sigma(&self, g: Group) -> f64 {
        self.group_scale(g).sqrt()
    }
}

/// Upper quantile of the standard normal distribution (Acklam's rational approximation,
/// relative error below 1.2e-9).
pub fn normal_quantile(p: f64) -> f64 {
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let a = [
        -3.969683028665376e+01,
        2.209460984245205e+02,
        -2.759285104469687e+02,
        1.38357751867269e+02,
        -3.066479806614716e+01,
        2.506628277459239e+00,
    ];
    let b = [
        -5.447609879822406e+01,
        1.615858368580409e+02,
        -1.556989798598866e+02,
        6.680131188771972e+01,
        -1.328068155288572e+01,
    ];
    let c = [
        -7.784894002430293e-03,
        -3.223964580411365e-01,
        -2.400758277161838e+00,
        -2.549732539343734e+00,
        4.374664141464968e+00,
        2.938163982698783e+00,
    ];
    let d = [
        7.784695709041462e-03,
        3.224671290700398e-01,
        2.445134137142996e+00,
        3.754408661907416e+00,
    ];
    let lo = 0.02425;
    if p < lo {
        let q = (-2.0 * p.ln()).sqrt();
        (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5])
            / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0)
    } else if p <= 1.0 - lo {
        let q = p - 0.5;
        let r = q * q;
        (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q
            / (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0)
    } else {
        -normal_quantile(1.0 - p)
    }
}

/// Critical value of the normalised residual for `tests` two-sided tests at a family-wise
/// error `alpha` (Bonferroni): with thousands of observations, Baarda's per-test 3.29
/// (α = 0.1 %) would reject a few good observations by chance alone.
pub fn snooping_critical(alpha: f64, tests: usize) -> f64 {
    normal_quantile(1.0 - alpha / (2.0 * tests.max(1) as f64))
}

/// Blocks with more observations than this keep their normals through a round of data
/// snooping (see `still_determined`).
const KEEP_NORMALS: usize = 64;

/// Normals of blocks kept through a round of data snooping, by block.
type Normals = std::collections::HashMap<usize, nalgebra::DMatrix<f64>>;

#[cfg(test)]
mod tests {
    #[test]
    fn quantiles() {
        assert!((super::normal_quantile(0.975) - 1.959964).abs() < 1e-5);
        assert!((super::normal_quantile(0.9995) - 3.290527).abs() < 1e-5);
        assert!((super::snooping_critical(0.001, 1) - 3.290527).abs() < 1e-5);
    }
}
