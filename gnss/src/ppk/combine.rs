//! Combination of the forward and backward passes (covariance-weighted smoothing).
//!
//! An epoch is fixed when at least one pass fixed it and the other pass agrees with that fix:
//! two fixes within 4σ and 5 cm of each other; or a fix inside the 99.9 % ellipsoid of the
//! other pass's float solution, when that test can tell a wrong fix (the float's largest σ at
//! most [`DISCERNING`]) or the fix's ambiguity segment is *confirmed* (somewhere in it both
//! passes were fixed and agreed: the data before and after both found those integers).
//! Otherwise it is float (covariance-weighted mean of the two). A fix of single-frequency
//! data one cycle off lies 5–30 cm away: a float of decimetres cannot refute it, so a fix
//! that only such a float "agrees" with is not reported as fixed.

use super::output::EpochSol;
use super::refusal::Refusal;
use crate::frame::Ecef;
use crate::solution::Quality;
use nalgebra::Matrix3;

fn weighted(a: &EpochSol, b: &EpochSol) -> Option<(nalgebra::Vector3<f64>, Matrix3<f64>)> {
    let ia = a.cov.try_inverse()?;
    let ib = b.cov.try_inverse()?;
    let p = (ia + ib).try_inverse()?;
    Some((p * (ia * a.pos.0 + ib * b.pos.0), p))
}

/// The covariance-weighted mean of the two passes; when they disagree beyond their σ (the
/// 99.9 % ellipsoid), one of them carries an error its σ does not know of (an undetected slip,
/// a wrong hold or fix), and the solution is the mixture of the two at equal odds: their
/// midpoint, with half the sum of their covariances plus the quarter gap between them, so
/// that it covers whichever pass is right. (The weighted mean with the gap added covered the
/// gap's direction only: beside a wrong fix, whose σ is millimetres, it kept millimetres
/// across it, and the low-cost walk's float NEES reached thousands there.)
fn mean_of(a: &EpochSol, b: &EpochSol) -> (nalgebra::Vector3<f64>, Matrix3<f64>) {
    let d = a.pos.0 - b.pos.0;
    if mahalanobis2(&d, &(a.cov + b.cov)) > CHI2_3 {
        let mid = 0.5 * (a.pos.0 + b.pos.0);
        (mid, 0.5 * (a.cov + b.cov) + 0.25 * d * d.transpose())
    } else {
        weighted(a, b).unwrap_or((a.pos.0, a.cov))
    }
}

/// A pass's solution as float: a fixed one's float solution (its integers were not taken),
/// else itself. Combined with the other pass, a refused fix must not lend its millimetre
/// covariance to the float it is refused for (the low-cost walk: a wrong backward fix 1.6 m
/// off, refused, still made the combined float claim 1–2 cm).
pub(super) fn as_float(s: &EpochSol) -> EpochSol {
    match (s.quality, s.float) {
        (Quality::Fixed, Some((pos, cov))) => EpochSol {
            pos,
            cov,
            quality: Quality::Float,
            nfix: 0,
            float: None,
            refused: Some(Refusal::PassesDisagree),
            ..s.clone()
        },
        _ => s.clone(),
    }
}

/// dᵀ·C⁻¹·d, infinite when `cov` is singular (nothing agrees with an unknown).
fn mahalanobis2(d: &nalgebra::Vector3<f64>, cov: &Matrix3<f64>) -> f64 {
    try_mahalanobis2(d, cov).unwrap_or(f64::INFINITY)
}

/// dᵀ·C⁻¹·d, None when `cov` is singular (the caller says what that means).
pub(super) fn try_mahalanobis2(d: &nalgebra::Vector3<f64>, cov: &Matrix3<f64>) -> Option<f64> {
    cov.try_inverse().map(|i| (d.transpose() * i * d)[0])
}

/// A smoothed solution checked against the backward pass's own solution of the epoch: a fix
/// more than 4σ (3D) from it is demoted to the smoothed float solution.
pub fn checked(s: &EpochSol, b: Option<&EpochSol>) -> EpochSol {
    let (Some(b), Some((pos, cov))) = (b, s.float) else {
        return s.clone();
    };
    if s.quality != Quality::Fixed
        || mahalanobis2(&(s.pos.0 - b.pos.0), &(s.cov + b.cov)) < 16.0 * 3.0
    {
        return s.clone();
    }
    EpochSol {
        pos,
        cov,
        quality: Quality::Float,
        nfix: 0,
        float: None,
        refused: Some(Refusal::PassesDisagree),
        ..s.clone()
    }
}

/// The largest σ (m) of a float solution that can refute a fix one L1 cycle off: a wrong
/// integer moves the position 10 cm or more, 3.3σ of this.
pub const DISCERNING: f64 = 0.03;

/// χ² of 3 degrees of freedom at 99.9 %.
const CHI2_3: f64 = 16.27;

/// The segments of pass `a` confirmed by pass `b`: at some epoch of the segment both fixed and
/// agreed (within 5 cm and the 99.9 % ellipsoid).
pub fn confirmed_segments(
    a: &[Option<EpochSol>],
    b: &[Option<EpochSol>],
) -> std::collections::BTreeSet<u32> {
    a.iter()
        .zip(b)
        .filter_map(|(x, y)| Some((x.as_ref()?, y.as_ref()?)))
        .filter(|(x, y)| x.quality == Quality::Fixed && y.quality == Quality::Fixed)
        .filter(|(x, y)| {
            let d = x.pos.0 - y.pos.0;
            d.norm() < 0.05 && mahalanobis2(&d, &(x.cov + y.cov)) < CHI2_3
        })
        .map(|(x, _)| x.segment)
        .collect()
}

/// Combine the two passes' solutions of one epoch; `confirmed`: whether each pass's fixed
/// segment is confirmed by the other (see [`confirmed_segments`]).
pub fn combine(
    f: Option<&EpochSol>,
    b: Option<&EpochSol>,
    confirmed: (bool, bool),
) -> Option<EpochSol> {
    let (f, b) = match (f, b) {
        (Some(f), Some(b)) => (f, b),
        (Some(x), None) | (None, Some(x)) => return Some(x.clone()),
        (None, None) => return None,
    };
    let d = f.pos.0 - b.pos.0;
    let fixed = |s: &EpochSol| s.quality == Quality::Fixed;
    let mut out = f.clone();
    out.nsat = f.nsat.max(b.nsat);
    out.ratio = f.ratio.max(b.ratio);
    match (fixed(f), fixed(b)) {
        (true, true) => {
            let agree = d.norm() < 0.05 && mahalanobis2(&d, &(f.cov + b.cov)) < 16.0 * 3.0;
            let (x, p) = if agree {
                weighted(f, b).unwrap_or((f.pos.0, f.cov))
            } else {
                mean_of(&as_float(f), &as_float(b))
            };
            out.pos = Ecef(x);
            out.cov = p;
            (out.quality, out.refused) = if agree {
                (Quality::Fixed, None)
            } else {
                (Quality::Float, Some(Refusal::PassesDisagree))
            };
        }
        (true, false) | (false, true) => {
            let (fx, fl, sure) = if fixed(f) {
                (f, b, confirmed.0)
            } else {
                (b, f, confirmed.1)
            };
            let discerning = fl.cov.symmetric_eigenvalues().max().sqrt() <= DISCERNING;
            if (sure || discerning) && mahalanobis2(&d, &(fl.cov + fx.cov)) < CHI2_3 {
                out = fx.clone();
                out.nsat = f.nsat.max(b.nsat);
            } else {
                let (x, p) = mean_of(&as_float(f), &as_float(b));
                out.pos = Ecef(x);
                out.cov = p;
                out.quality = Quality::Float;
                out.refused = Some(Refusal::PassesDisagree);
            }
        }
        (false, false) => {
            let (x, p) = mean_of(f, b);
            out.pos = Ecef(x);
            out.cov = p;
            out.quality = f.quality.min(b.quality);
            // the check that came nearest to a fix in either pass
            out.refused = f.refused.max(b.refused);
        }
    }
    Some(out)
}
