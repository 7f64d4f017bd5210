//! The run checks its own σ against its two passes: the forward and the backward filter
//! estimate each epoch from mostly different data (the epochs before it, the epochs after
//! it), so how far apart they lie, against the covariances they claim, measures how honest
//! those covariances are, whatever the noise model got wrong (code errors correlated over
//! more epochs than it assumes, an undetected slip, an excursion of the code).
//!
//! What enters: the two passes' solutions of every epoch. What leaves: a factor per epoch
//! (at least 1) by which a combined float solution's covariance is multiplied: the median over
//! the epochs within [`WINDOW_S`] of the squared Mahalanobis distance between the passes per
//! degree of freedom, dᵀ(P_f + P_b)⁻¹d / 3, over that statistic's median for honest passes
//! (0.789), floored at the ends of the run by the one pass's own factor ([`pass_factors`]).
//! Honest and independent passes give 1;
//! as the two passes share the epoch's own measurements and the arcs that span it, honest
//! ones give less, so the factor errs on the safe side. Epochs both passes fixed are left out
//! of the mean (their millimetre σ would make a centimetre of agreement look like a
//! contradiction, and the combination judges them itself).
//!
//! Measured on the low-cost walk shaped on a real one's fingerprint (seeds 1–4 and 47): the
//! passes' distances are 7–12 times their σ² on average, and the combined float NEES falls
//! from 5–97 to 0.7–7 with this factor alone.

use super::output::EpochSol;
use crate::solution::Quality;

/// Half the width of the window the factor is averaged over, seconds.
const WINDOW_S: f64 = 60.0;

/// dᵀ(P_f + P_b)⁻¹d / 3 of one epoch's two solutions; None when one is missing, both are
/// fixed or the sum of their covariances is singular.
fn statistic(f: Option<&EpochSol>, b: Option<&EpochSol>) -> Option<f64> {
    let (f, b) = (f?, b?);
    if f.quality == Quality::Fixed && b.quality == Quality::Fixed {
        return None;
    }
    let d = f.pos.0 - b.pos.0;
    super::combine::try_mahalanobis2(&d, &(f.cov + b.cov)).map(|m| m / 3.0)
}

/// How far a run's two passes contradict each other: the epochs (not both fixed) whose
/// passes lie apart beyond their 99.9 % ellipsoid, and the epochs compared. Honest passes
/// put a handful of a thousand beyond it (fewer still: they share data); on the geodetic
/// benches, the drone and the open-sky walk none did, on the low-cost walk shaped on a real
/// one 11–94 % did, where a fix one pass had held was wrong.
pub fn contradictions(f: &[Option<EpochSol>], b: &[Option<EpochSol>]) -> (usize, usize) {
    let stats: Vec<f64> = f
        .iter()
        .zip(b)
        .filter_map(|(x, y)| statistic(x.as_ref(), y.as_ref()))
        .collect();
    let beyond = stats.iter().filter(|&&s| s * 3.0 > CHI2_3_999).count();
    (beyond, stats.len())
}

/// χ² of 3 degrees of freedom at 99.9 %.
const CHI2_3_999: f64 = 16.27;

/// The share of contradicting epochs (see [`contradictions`]) beyond which a run's holds
/// are not trusted: it is processed again without fix-and-hold.
const HOLDS_CONTRADICTED: f64 = 0.10;

/// Fewest epochs compared before [`HOLDS_CONTRADICTED`] is judged.
const MIN_COMPARED: usize = 20;

/// How much an epoch's share of the pair's covariance counts toward a pass's factor: a pass
/// needs this many epochs' worth of shares (its trace over both traces) in a window before
/// its factor is taken from it (a pass whose σ is a hundredth of the other's says nothing of
/// itself in their distance).
const MIN_SHARE: f64 = 3.0;

/// How overconfident each pass is over the epochs given, (forward, backward), each at least 1
/// and None where the epochs cannot tell: the squared distances between the passes regressed
/// on the traces of their covariances, |d|² ≈ k_f·tr(P_f) + k_b·tr(P_b) (least squares over
/// the epochs not both fixed, each weighed by its scale).
pub fn pass_factors(f: &[Option<EpochSol>], b: &[Option<EpochSol>]) -> (Option<f64>, Option<f64>) {
    let (mut a11, mut a12, mut a22, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut nf, mut nb) = (0.0, 0.0);
    for (x, y) in f.iter().zip(b) {
        let (Some(x), Some(y)) = (x, y) else {
            continue;
        };
        if x.quality == Quality::Fixed && y.quality == Quality::Fixed {
            continue;
        }
        let d2 = (x.pos.0 - y.pos.0).norm_squared();
        let (tf, tb) = (x.cov.trace(), y.cov.trace());
        let sum = (tf + tb).max(1e-300);
        nf += tf / sum;
        nb += tb / sum;
        let w = 1.0 / (sum * sum);
        a11 += w * tf * tf;
        a12 += w * tf * tb;
        a22 += w * tb * tb;
        y1 += w * tf * d2;
        y2 += w * tb * d2;
    }
    let det = a11 * a22 - a12 * a12;
    let (kf, kb) = if det > 1e-9 * a11 * a22 {
        ((a22 * y1 - a12 * y2) / det, (a11 * y2 - a12 * y1) / det)
    } else {
        // the passes' covariances move together: one factor for both
        let k = (y1 + y2) / (a11 + 2.0 * a12 + a22).max(1e-300);
        (k, k)
    };
    let take = |k: f64, n: f64| (n >= MIN_SHARE && k.is_finite()).then(|| k.max(1.0));
    (take(kf, nf), take(kb, nb))
}

/// The factor (≥ 1) of each epoch: the median statistic over the epochs within `window`
/// seconds of it (1 where none has one); where one pass carries [`ALONE`] or more of the
/// combination's weight (the ends of the run, where the other has only begun and their
/// distance says little of the one), that pass's own factor over the run is a floor. `f`
/// and `b` are the passes' solutions, epoch by epoch, at the times `times` (seconds,
/// ascending).
pub fn disagreement_scale(
    f: &[Option<EpochSol>],
    b: &[Option<EpochSol>],
    times: &[f64],
    window: f64,
) -> Vec<f64> {
    let stats: Vec<Option<f64>> = f
        .iter()
        .zip(b)
        .map(|(x, y)| statistic(x.as_ref(), y.as_ref()))
        .collect();
    let n = times.len().min(stats.len());
    let (mut lo, mut hi) = (0, 0);
    let run = pass_factors(f, b);
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        while hi < n && times[hi] <= times[i] + window {
            hi += 1;
        }
        while times[lo] < times[i] - window {
            lo += 1;
        }
        // The median, robust to the few epochs where one pass is grossly off (their mixture
        // covers those), over the median of χ²(3)/3 (0.789): 1 for honest passes.
        let mut w: Vec<f64> = stats[lo..hi].iter().flatten().copied().collect();
        let local = if w.is_empty() {
            1.0
        } else {
            let mid = w.len() / 2;
            let (_, m, _) = w.select_nth_unstable_by(mid, f64::total_cmp);
            *m / CHI2_3_MEDIAN
        };
        let floor = match (&f[i], &b[i]) {
            (Some(x), Some(y)) if stats[i].is_some() => {
                let (tf, tb) = (x.cov.trace(), y.cov.trace());
                let wf = tb / (tf + tb).max(1e-300);
                if wf >= ALONE {
                    run.0.unwrap_or(1.0)
                } else if wf <= 1.0 - ALONE {
                    run.1.unwrap_or(1.0)
                } else {
                    1.0
                }
            }
            _ => 1.0,
        };
        out.push(local.max(floor).max(1.0));
    }
    out
}

/// [`disagreement_scale`] of two passes over [`WINDOW_S`], at their own epochs' times (an
/// epoch neither solved takes the time of the last one that was).
pub fn disagreement(f: &[Option<EpochSol>], b: &[Option<EpochSol>]) -> Vec<f64> {
    disagreement_scale(f, b, &epoch_times(f, b), WINDOW_S)
}

/// The factor of each epoch of a two-filter smoother's run (`s`, its solutions, each with
/// the forward filter's own solution in `alone`; `b`, the backward pass's): as
/// [`disagreement`] of those two halves, over at least [`SMOOTHED_WINDOW_EPOCHS`] epochs on
/// each side (a long baseline's errors last for tens of minutes, and 30 s epochs put two
/// in a minute).
pub fn halves_disagreement(s: &[Option<EpochSol>], b: &[Option<EpochSol>]) -> Vec<f64> {
    let halves: Vec<Option<EpochSol>> = s
        .iter()
        .map(|x| {
            let x = x.as_ref()?;
            let (pos, cov) = x.alone?;
            Some(EpochSol {
                pos,
                cov,
                quality: Quality::Float,
                ..x.clone()
            })
        })
        .collect();
    let solved = s
        .iter()
        .zip(b)
        .filter_map(|(x, y)| x.as_ref().or(y.as_ref()));
    let interval = crate::time::median_spacing(solved.map(|e| e.time));
    let window = WINDOW_S.max(SMOOTHED_WINDOW_EPOCHS * interval);
    disagreement_scale(&halves, b, &epoch_times(s, b), window)
}

/// The factor of [`halves_disagreement`] beyond which a smoothed fix is not reported: the
/// halves contradict their σ so far around the epoch that the model does not hold there (an
/// orbit metres off, a slip nobody flagged), and a fix resolved on it is not to be trusted.
/// Measured at fixed epochs: the clean 250 km simulation (seeds 1–4) at most 7, BELL–EBRE
/// at most 4; with its unflagged slips and 30 m orbit, up to 47 (at 10, 12:17–12:31 kept
/// fixes 25–33 cm off at 9.3–10).
pub const HALVES_REFUTE: f64 = 8.0;

/// The half-width of a smoothed run's window, in epochs.
const SMOOTHED_WINDOW_EPOCHS: f64 = 20.0;

/// The time of each epoch (seconds) of two passes' solutions; an epoch neither solved takes
/// the time of the last one that was.
fn epoch_times(f: &[Option<EpochSol>], b: &[Option<EpochSol>]) -> Vec<f64> {
    let mut last = 0.0;
    f.iter()
        .zip(b)
        .map(|(x, y)| {
            if let Some(s) = x.as_ref().or(y.as_ref()) {
                last = s.time.to_gpst_seconds();
            }
            last
        })
        .collect()
}

/// When two fix-and-hold passes contradict each other too often to trust what they held
/// (see [`contradictions`]), the warning that says so and that the run goes again without
/// holds; None when they may be kept.
pub fn holds_refused(f: &[Option<EpochSol>], b: &[Option<EpochSol>]) -> Option<String> {
    let (beyond, compared) = contradictions(f, b);
    let share = beyond as f64 / compared.max(1) as f64;
    (compared >= MIN_COMPARED && share > HOLDS_CONTRADICTED).then(|| {
        format!(
            "the forward and backward passes lay apart beyond their 99.9 % ellipsoid at {beyond} of {compared} epochs ({:.0} %): a fix held by one of them may be wrong, so the passes ran again without fix-and-hold (each epoch resolved on its own)",
            100.0 * share
        )
    })
}

/// The median of χ²(3)/3.
const CHI2_3_MEDIAN: f64 = 0.789;

/// The share of the combination's weight beyond which one pass carries it alone.
const ALONE: f64 = 0.9;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Ecef;
    use nalgebra::Matrix3;

    fn sol(x: f64, sigma: f64, quality: Quality) -> EpochSol {
        EpochSol {
            time: crate::time::from_week_tow(2300, 0.0),
            pos: Ecef::new(4e6 + x, 0.0, 5e6),
            cov: Matrix3::identity() * sigma * sigma,
            quality,
            nsat: 8,
            ratio: 0.0,
            age: 0.0,
            nfix: 0,
            widelanes: 0,
            segment: 0,
            float: None,
            refused: None,
            alone: None,
        }
    }

    /// Passes 1 m apart that claim 10 cm each: the factor is their distance per degree of
    /// freedom in σ² (over χ²(3)'s median), within the window and not beyond it; passes that
    /// agree give 1; both fixed are left out; a pass that carries the combination alone
    /// takes its own factor over the run.
    #[test]
    fn the_factor_is_the_passes_distance_in_their_sigmas() {
        let n = 300;
        let times: Vec<f64> = (0..n).map(|k| k as f64).collect();
        let f: Vec<Option<EpochSol>> = (0..n)
            .map(|k| {
                let q = if k >= 250 {
                    Quality::Fixed
                } else {
                    Quality::Float
                };
                Some(sol(if k < 100 { 1.0 } else { 0.05 }, 0.1, q))
            })
            .collect();
        let b: Vec<Option<EpochSol>> = (0..n)
            .map(|k| {
                let q = if k >= 250 {
                    Quality::Fixed
                } else {
                    Quality::Float
                };
                Some(sol(0.0, 0.1, q))
            })
            .collect();
        let s = disagreement_scale(&f, &b, &times, 60.0);
        // 1 m over σ² = 0.02 (two passes) is 50 per axis, 50/3 per degree of freedom.
        let want = 50.0 / 3.0 / CHI2_3_MEDIAN;
        assert!((s[10] - want).abs() < 1e-9, "{}", s[10]);
        assert_eq!(s[200], 1.0);
        // the fixed ones (5 cm apart at 1 mm would be 800) are left out
        assert_eq!(s[299], 1.0);
        let (beyond, compared) = contradictions(&f, &b);
        assert_eq!((beyond, compared), (100, 250));
        // A forward pass alone at the start (σ 10 m against 10 cm) 1 m off a backward pass
        // that claims 10 cm: the window cannot tell the backward pass; its factor over the run
        // (from epochs where the two weigh alike) is the floor.
        let mut f2 = b.clone();
        for (k, s) in f2.iter_mut().enumerate().take(250) {
            let Some(s) = s else { continue };
            if k < 50 {
                s.pos.0.x += 1.0;
                s.cov *= 1e4;
            } else {
                s.pos.0.x += if k % 2 == 0 { 0.3 } else { -0.3 };
            }
        }
        let s2 = disagreement_scale(&f2, &b, &times, 60.0);
        let (_, kb) = pass_factors(&f2, &b);
        let kb = kb.unwrap();
        // 0.09 m² apart where each claims 0.03 m²: 3 for the two together; the epochs where
        // the forward pass claimed 10 m and lay 1 m off clear it, so the backward takes all
        assert!((kb - 3.0).abs() < 0.05, "{kb}");
        assert!((s2[10] - kb).abs() < 1e-9, "{} {kb}", s2[10]);
    }
}
