//! The Rauch–Tung–Striebel smoother over the forward filter's checkpoints
//! ([`crate::filter::Checkpoint`]), backward from the last: with A = P⁺(k)·Φᵀ(k+1)·P⁻(k+1)⁻¹,
//! the smoothed state is x⁺(k) ⊕ A·(x̂(k+1) ⊖ x⁻(k+1)) and its covariance
//! P⁺(k) + A·(P̂(k+1) − P⁻(k+1))·Aᵀ. Errors are taken between nominal states
//! ([`crate::filter::Estimate::minus`]), so the forward filter's resets between checkpoints
//! are part of what is smoothed.

use crate::errstate::Mat;
use crate::filter::{Checkpoint, Estimate};

/// One smoothed checkpoint: the estimate and its error covariance.
#[derive(Clone, Debug)]
pub struct Smoothed {
    /// The smoothed estimate.
    pub est: Estimate,
    /// Its error covariance.
    pub cov: Mat,
}

/// The smoothed estimates at every checkpoint (the last is the forward filter's own). A
/// checkpoint whose next prior covariance cannot be inverted keeps its forward estimate.
pub fn smooth(cps: &[Checkpoint]) -> Vec<Smoothed> {
    let Some(last) = cps.last() else {
        return Vec::new();
    };
    let mut out = vec![
        Smoothed {
            est: last.post,
            cov: last.post_cov,
        };
        cps.len()
    ];
    for k in (0..cps.len() - 1).rev() {
        let (here, next) = (&cps[k], &cps[k + 1]);
        let sym = 0.5 * (next.prior_cov + next.prior_cov.transpose());
        let Some(inv) = sym.try_inverse() else {
            out[k] = Smoothed {
                est: here.post,
                cov: here.post_cov,
            };
            continue;
        };
        let a = here.post_cov * next.phi.transpose() * inv;
        let d = out[k + 1].est.minus(&next.prior);
        let cov = here.post_cov + a * (out[k + 1].cov - next.prior_cov) * a.transpose();
        out[k] = Smoothed {
            est: here.post.corrected(&(a * d)),
            cov: 0.5 * (cov + cov.transpose()),
        };
    }
    out
}
