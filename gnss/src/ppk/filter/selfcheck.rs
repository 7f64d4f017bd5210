//! The filter checks its state against its own code: the carrier phase carries the position
//! from epoch to epoch through the ambiguities, the code measures it afresh every epoch. When
//! the code keeps saying, over tens of seconds, that the position lies elsewhere than the
//! state claims to within its σ, the state is overconfident — an error the noise model does
//! not know of got into the ambiguities (code errors correlated over more epochs than
//! assumed, a slip nobody flagged, a wrong integer held) — and its covariance is widened by
//! how far it was off, so that the epochs after it weigh the new data as they should and
//! report σ that cover the error.
//!
//! Each epoch: the post-fit code residuals, projected on the position by weighted least
//! squares with the code's white variance, give the shift the code alone would apply
//! (δx, covariance C). Their exponential average over [`TAU_S`] (ā) is tested against the
//! state's position covariance and the average's own: m² = āᵀ(P_pos + C̄)⁻¹ā, C̄ the
//! average's covariance with the code's correlation over the epochs. Beyond χ²(3) at 99.9 %
//! the whole state covariance is multiplied by m²/3 (at most [`MAX_WIDEN`]) and the average
//! starts again. Counted in the pass's statistics.

use super::{Filter, Linearisation};
use crate::ppk::measure::{self, ObsKind};
use crate::ppk::state::StateKey;
use nalgebra::{Matrix3, Vector3};

/// Time constant of the average of the code's shifts, seconds.
const TAU_S: f64 = 30.0;
/// χ² of 3 degrees of freedom at 99.9 %.
const CHI2_3: f64 = 16.27;
/// The largest widening of one check.
const MAX_WIDEN: f64 = 10.0;

/// The running average of the code's shift and its covariance.
#[derive(Clone, Debug, Default)]
pub(super) struct CodeShift {
    mean: Vector3<f64>,
    cov: Matrix3<f64>,
    started: bool,
}

impl Filter<'_> {
    /// The shift the epoch's post-fit code residuals would apply to the position, with its
    /// covariance under the code's white noise; None with fewer than five code rows.
    fn code_shift(&self, last: &Linearisation) -> Option<(Vector3<f64>, Matrix3<f64>)> {
        let o = self.opts;
        let pos = self.state.index().range(StateKey::Position)?;
        let dx = &self.state.x - &last.at;
        let corr = measure::correlation(o.code_correlation_s, o).max(1.0);
        let mut n = Matrix3::zeros();
        let mut b = Vector3::zeros();
        let mut rows = 0;
        for r in &last.rows.rows {
            if r.kind != ObsKind::Code || r.innovation.abs() > o.max_innovation {
                continue;
            }
            let post = r.innovation - r.h.entries().iter().map(|&(j, v)| v * dx[j]).sum::<f64>();
            let mut h = Vector3::zeros();
            for &(j, v) in r.h.entries() {
                if pos.contains(&j) {
                    h[j - pos.start] = v;
                }
            }
            let w = corr / (r.var + last.rows.pivot_var[r.group]);
            n += w * h * h.transpose();
            b += w * h * post;
            rows += 1;
        }
        if rows < 5 {
            return None;
        }
        let c = n.try_inverse()?;
        Some((c * b, c))
    }

    /// The check of one epoch `dt` seconds after the previous (see the module).
    pub(super) fn check_against_code(&mut self, last: &Linearisation, dt: f64) {
        let Some((d, c)) = self.code_shift(last) else {
            return;
        };
        let o = self.opts;
        let corr = measure::correlation(o.code_correlation_s, o).max(1.0);
        let a = (dt / TAU_S).clamp(0.0, 1.0);
        let s = &mut self.code_shift_avg;
        if !s.started || a >= 1.0 {
            s.mean = d;
            // an average of one epoch: its correlated code counts as one
            s.cov = c * corr;
            s.started = true;
        } else {
            s.mean = (1.0 - a) * s.mean + a * d;
            // an exponential average of correlated epochs: the white variance times the
            // correlation factor, times a/(2 − a)
            s.cov = (1.0 - a) * (1.0 - a) * s.cov + (a * a) * c * corr;
        }
        let Some(m2) =
            crate::ppk::combine::try_mahalanobis2(&s.mean, &(self.state.position_cov() + s.cov))
        else {
            return;
        };
        if m2 > CHI2_3 {
            let k = (m2 / 3.0).min(MAX_WIDEN);
            self.state.p *= k;
            self.stats.widened += 1;
            self.code_shift_avg = CodeShift::default();
        }
    }
}
