//! Images and points their own observations do not determine are left out of the adjustment
//! (their block fixed, their factors removed), each named with the reason, and the rest is
//! adjusted. Leaving one out can leave another undetermined (a point seen by a removed image),
//! so the test repeats until every remaining block is determined. An image or point the
//! solver later finds singular (its observations determine it only together with others, or
//! not after snooping) is left out the same way, and the solve starts again.
//!
//! A drift of part of the block (a strip's or a segment's offset) is no reason to stop: when
//! its images are all left out, or its GNSS centres do not determine it, its GNSS centres are
//! left out, it is held at zero and named, and the images go on with their other
//! observations. Only a block-wide unknown (the block's drift, a latency, a lever arm, a
//! camera) stops the run, with what to do.
//!
//! What enters: the project, the point names and the assembled problem. What leaves: the
//! problem with the undetermined blocks out, and the list of what was left out and why; an
//! error only when nothing is left to adjust.

use super::assemble::DriftBlock;
use super::error::{problem_err as err, AdjustError};
use super::project::{DriftGroup, Project};
use photo::lsq::{FactorId, Key, Problem};

/// Rounds of the test before giving up (each removes at least one block).
const MAX_ROUNDS: usize = 50;

/// What names the blocks left out: the project, the point names by `PointId`, the drift
/// groups by `DriftId`.
pub(super) struct Names<'a> {
    /// The project.
    pub project: &'a Project,
    /// Point names by `PointId`.
    pub points: &'a [String],
    /// Drift groups by `DriftId`.
    pub drifts: &'a [DriftBlock],
}

impl Names<'_> {
    /// Whether the solver may leave `key` out: an image, a point, or the drift of a part of
    /// the block (not the block's own drift).
    fn may_leave_out(&self, key: Key) -> bool {
        match key {
            Key::Pose(_) | Key::Point(_) => true,
            Key::Drift(_) => self
                .project
                .file
                .gnss
                .as_ref()
                .is_some_and(|g| g.drift != DriftGroup::Block),
            _ => false,
        }
    }
}

/// Leave out every undetermined image, point and part-of-block drift of `pr`, naming each in
/// `left_out`.
pub(super) fn undetermined(
    names: &Names,
    pr: &mut Problem,
    left_out: &mut Vec<(String, String)>,
) -> Result<(), AdjustError> {
    for _ in 0..MAX_ROUNDS {
        let keys = pr.undetermined().map_err(|e| err(e.to_string()))?;
        let keys: Vec<Key> = keys
            .into_iter()
            .filter(|k| names.may_leave_out(*k))
            .collect();
        if keys.is_empty() {
            break;
        }
        let mut touching = factors_of(pr, &keys);
        for (key, touching) in keys.into_iter().zip(touching.iter_mut()) {
            // A factor may touch two of them: left out with the first.
            touching.retain(|&(f, _)| !pr.is_removed(f));
            let equations = touching.iter().map(|&(_, dim)| dim).sum();
            left_out.push(describe(names, key, (touching.len(), equations)));
            for &(f, _) in touching.iter() {
                pr.remove(f);
            }
            pr.set_fixed(key, true).map_err(|e| err(e.to_string()))?;
        }
    }
    let free_poses = pr
        .keys()
        .iter()
        .filter(|k| matches!(k, Key::Pose(_)) && !pr.is_fixed(**k))
        .count();
    if free_poses == 0 {
        return Err(err(format!(
            "nothing can be adjusted: every image is left out ({} left out; first: {} — {})",
            left_out.len(),
            left_out.first().map_or("", |l| l.0.as_str()),
            left_out.first().map_or("", |l| l.1.as_str())
        )));
    }
    Ok(())
}

/// Leave out the image, point or part-of-block drift `key` the solver found singular (its
/// factors removed, its block fixed), named in `left_out` with `why`, then whatever that
/// leaves undetermined. Refused (`false`) for any other kind of block: a defect of the whole
/// block (the block's drift, latency, lever arm, camera) is the user's to mend.
pub(super) fn singular(
    names: &Names,
    pr: &mut Problem,
    key: Key,
    why: &str,
    left_out: &mut Vec<(String, String)>,
) -> Result<bool, AdjustError> {
    if !names.may_leave_out(key) || pr.is_fixed(key) {
        return Ok(false);
    }
    let touching = factors_of(pr, &[key]).pop().unwrap_or_default();
    let (what, own) = describe(names, key, (touching.len(), 0));
    let why = match key {
        Key::Drift(_) => own,
        _ => why.to_string(),
    };
    left_out.push((what, why));
    for (f, _) in touching {
        pr.remove(f);
    }
    pr.set_fixed(key, true).map_err(|e| err(e.to_string()))?;
    undetermined(names, pr, left_out)?;
    Ok(true)
}

/// The active factors that touch each of `keys` with their residual dimension, in factor order: one pass over the
/// factors (a pass per key was quadratic on large blocks with many single-ray points).
fn factors_of(pr: &Problem, keys: &[Key]) -> Vec<Vec<(FactorId, usize)>> {
    let index: std::collections::HashMap<Key, usize> =
        keys.iter().enumerate().map(|(i, k)| (*k, i)).collect();
    let mut out = vec![Vec::new(); keys.len()];
    for (id, f) in pr.factors().filter(|(id, _)| !pr.is_removed(*id)) {
        for k in f.keys() {
            if let Some(&i) = index.get(k) {
                out[i].push((id, f.dim()));
            }
        }
    }
    out
}

/// What a left-out block is and why, from the observations that touch it: `(count,
/// equations)` (an image point gives 2 equations, a GNSS centre 3).
fn describe(names: &Names, key: Key, n: (usize, usize)) -> (String, String) {
    let (p, point_names) = (names.project, names.points);
    let (n, equations) = n;
    match key {
        Key::Pose(i) => (
            format!(
                "image {}",
                p.images
                    .get(i.index())
                    .map_or(i.to_string(), |x| x.id.clone())
            ),
            if equations < 6 {
                format!("its observations give {equations} equations for its six unknowns (an image point gives 2, a GNSS centre 3; one ray leaves a rotation about it free): measure at least 3 well-spread points, or 2 with a GNSS centre")
            } else {
                format!("its {equations} equations do not fix its six unknowns (points in line with each other or with the GNSS centre, or all in one spot): measure points spread over the image")
            },
        ),
        Key::Point(k) => (
            format!(
                "point {}",
                point_names.get(k.index()).cloned().unwrap_or_default()
            ),
            if n < 2 {
                "measured in one adjusted image only: measure it in another image".to_string()
            } else {
                format!("its {n} rays are nearly parallel: measure it in images further apart")
            },
        ),
        Key::Drift(d) => (
            format!(
                "the GNSS drift of {} (with its centres)",
                names
                    .drifts
                    .get(d.index())
                    .map_or(d.to_string(), |x| x.name.clone())
            ),
            if n == 0 {
                "its images are all left out (or its centres rejected): nothing measures it"
                    .to_string()
            } else {
                format!("it is not determined by its {n} GNSS centre(s) together with the images' other observations (too few images, or too few points in them): its images go on with their control and tie points alone; measure more points in them, or use one drift for the block")
            },
        ),
        k => (k.to_string(), "not determined".to_string()),
    }
}
