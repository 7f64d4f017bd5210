//! Post-fit checks of one epoch's update: the worst code residual taken for an excursion
//! of the code (multipath that leaves its level by metres for seconds), the worst phase
//! residual taken for a slip no detector saw (detection, identification, adaptation), and
//! the residuals kept for the statistics, with the ambiguities to reset at the next epoch.

use super::{Filter, Linearisation, CODE_STUDENTIZED, SLIP_FLOOR, STUDENTIZED};
use crate::ppk::measure::{self, ObsKind};
use crate::ppk::state::AmbKey;

impl Filter<'_> {
    /// The satellite and slot of the worst post-fit code residual when it stands out of the
    /// code's white noise by [`CODE_STUDENTIZED`] (the pivot's when most rows of its group
    /// share it), None otherwise. The code's variance in the filter is its white noise
    /// times its correlation over the epochs (`measure::correlation`: about 20 at 1 Hz), so
    /// that the filter does not take correlated epochs for independent ones; an excursion of
    /// ten metres is five of those inflated sigmas but ten of the white ones, which is what
    /// it is tested against (less what the solution absorbed of it, which only makes the
    /// test safer).
    pub(super) fn worst_code_outlier(&self, last: &Linearisation) -> Option<AmbKey> {
        let o = self.opts;
        let dx = &self.state.x - &last.at;
        let corr = measure::correlation(o.code_correlation_s, o).max(1.0);
        let pivot_var = &last.rows.pivot_var;
        let rows: Vec<(&measure::Row, f64)> = last
            .rows
            .rows
            .iter()
            .filter(|r| r.kind == ObsKind::Code && r.innovation.abs() <= o.max_innovation)
            .map(|r| {
                let post =
                    r.innovation - r.h.entries().iter().map(|&(j, v)| v * dx[j]).sum::<f64>();
                let white = (r.var + pivot_var[r.group]) / corr;
                (r, post.abs() / white.sqrt())
            })
            .collect();
        let (worst, w) = rows.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
        if *w <= CODE_STUDENTIZED {
            return None;
        }
        let group: Vec<&(&measure::Row, f64)> = rows
            .iter()
            .filter(|(r, _)| r.group == worst.group)
            .collect();
        let over = group
            .iter()
            .filter(|(_, w)| *w > CODE_STUDENTIZED / 2.0)
            .count();
        let sv = if group.len() >= 2 && 2 * over > group.len() {
            worst.pivot
        } else {
            worst.sv
        };
        Some(AmbKey {
            sv,
            slot: worst.slot,
        })
    }

    /// The ambiguity of the worst post-fit phase residual (the pivot's when most rows of its
    /// group share it), None when the residuals hold none beyond chance.
    pub(super) fn worst_phase_outlier(&self, last: &Linearisation) -> Option<AmbKey> {
        let o = self.opts;
        let dx = &self.state.x - &last.at;
        let post = |r: &measure::Row| {
            r.innovation - r.h.entries().iter().map(|&(j, v)| v * dx[j]).sum::<f64>()
        };
        let phase =
            |r: &&measure::Row| r.kind == ObsKind::Phase && r.innovation.abs() <= o.max_innovation;
        // A slip no detector saw (detection, identification, adaptation): a post-fit
        // residual beyond `max_phase_residual`; or, when the phase residuals together fail
        // the χ² test (99.9 %) or one stands out by STUDENTIZED, the one of them largest
        // against its own post-fit sigma, if beyond SLIP_FLOOR. The post-fit sigma is the
        // row's variance less what the solution absorbed of it (h P hᵀ): with a few rows an
        // undetected half or whole cycle is largely taken up by the position, and its
        // residual alone (centimetres) does not stand out of a weak signal's noise.
        let pivot_var = &last.rows.pivot_var;
        let p = &self.state.p;
        let studentized = |r: &measure::Row| {
            let v = post(r).abs();
            if v > o.max_phase_residual {
                return f64::INFINITY;
            }
            let e = r.h.entries();
            let hph: f64 = e
                .iter()
                .map(|&(j, a)| a * e.iter().map(|&(k, b)| p[(j, k)] * b).sum::<f64>())
                .sum();
            let var = r.var + pivot_var[r.group];
            v / (var - hph).max(0.01 * var).sqrt()
        };
        let rows: Vec<(&measure::Row, f64)> = last
            .rows
            .rows
            .iter()
            .filter(phase)
            .map(|r| (r, studentized(r)))
            .collect();
        let global = rows.iter().map(|(_, w)| w * w).sum::<f64>();
        let (worst, w) = rows
            .iter()
            .filter(|(r, _)| post(r).abs() > SLIP_FLOOR)
            .max_by(|a, b| a.1.total_cmp(&b.1))?;
        if !(*w > STUDENTIZED || global > crate::spp::chi2_999(rows.len())) {
            return None;
        }
        // The pivot's slip shows in most rows of its group.
        let group: Vec<&(&measure::Row, f64)> = rows
            .iter()
            .filter(|(r, _)| r.group == worst.group)
            .collect();
        let over = group
            .iter()
            .filter(|(r, w)| post(r).abs() > SLIP_FLOOR && *w > STUDENTIZED / 2.0)
            .count();
        let sv = if group.len() >= 2 && 2 * over > group.len() {
            worst.pivot
        } else {
            worst.sv
        };
        Some(AmbKey {
            sv,
            slot: worst.slot,
        })
    }

    /// Post-fit phase residuals: one larger than `max_phase_residual` betrays an undetected
    /// slip; its ambiguity is reset at the next epoch. The residuals are those of the last
    /// linearisation carried to the updated state, v − h·(x − x_lin). The state is close to
    /// where they were formed: under [`RELINEARISE`] from it when the first linearisation
    /// was the last, the model's change (millimetres) after a second. The model's curvature
    /// over that is below 0.1 mm, so forming the rows a third time would tell nothing more.
    pub(super) fn post_fit_check(&mut self, last: Linearisation) {
        let o = self.opts;
        let dx = &self.state.x - &last.at;
        let mut res = last.rows;
        for row in &mut res.rows {
            row.innovation -= row.h.entries().iter().map(|&(j, v)| v * dx[j]).sum::<f64>();
        }
        for row in &res.rows {
            // Rows beyond the innovation gate did not enter the solution.
            if row.innovation.abs() <= o.max_innovation {
                match row.kind {
                    ObsKind::Phase => self.stats.phase_residuals.add(row.innovation),
                    ObsKind::Code => self.stats.code_residuals.add(row.innovation),
                }
            }
            if row.kind == ObsKind::Phase && row.innovation.abs() > o.max_phase_residual {
                self.pending_reset.push(AmbKey {
                    sv: row.sv,
                    slot: row.slot,
                });
                self.stats.outlier_resets += 1;
            }
        }
    }
}
