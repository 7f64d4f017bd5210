//! Images and points their own observations do not determine are left out of the adjustment
//! (their block fixed, their factors removed), each named with the reason, and the rest is
//! adjusted. Leaving one out can leave another undetermined (a point seen by a removed image),
//! so the test repeats until every remaining block is determined.
//!
//! What enters: the project, the point names and the assembled problem. What leaves: the
//! problem with the undetermined blocks out, and the list of what was left out and why; an
//! error only when nothing is left to adjust.

use super::error::{problem_err as err, AdjustError};
use super::project::Project;
use photo::lsq::{FactorId, Key, Problem};

/// Rounds of the test before giving up (each removes at least one block).
const MAX_ROUNDS: usize = 50;

/// Leave out every undetermined image and point of `pr`, naming each in `left_out`.
pub(super) fn undetermined(
    p: &Project,
    point_names: &[String],
    pr: &mut Problem,
    left_out: &mut Vec<(String, String)>,
) -> Result<(), AdjustError> {
    for _ in 0..MAX_ROUNDS {
        let keys = pr.undetermined().map_err(|e| err(e.to_string()))?;
        let keys: Vec<Key> = keys
            .into_iter()
            .filter(|k| matches!(k, Key::Pose(_) | Key::Point(_)))
            .collect();
        if keys.is_empty() {
            break;
        }
        let mut touching = factors_of(pr, &keys);
        for (key, touching) in keys.into_iter().zip(touching.iter_mut()) {
            // A factor may touch two of them: left out with the first.
            touching.retain(|&f| !pr.is_removed(f));
            let rays = touching.len();
            left_out.push(describe(p, point_names, key, rays));
            for &f in touching.iter() {
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

/// The active factors that touch each of `keys`, in factor order: one pass over the
/// factors (a pass per key was quadratic on large blocks with many single-ray points).
fn factors_of(pr: &Problem, keys: &[Key]) -> Vec<Vec<FactorId>> {
    let index: std::collections::HashMap<Key, usize> =
        keys.iter().enumerate().map(|(i, k)| (*k, i)).collect();
    let mut out = vec![Vec::new(); keys.len()];
    for (id, f) in pr.factors().filter(|(id, _)| !pr.is_removed(*id)) {
        for k in f.keys() {
            if let Some(&i) = index.get(k) {
                out[i].push(id);
            }
        }
    }
    out
}

/// What a left-out block is and why, from the number of observations that touch it.
fn describe(p: &Project, point_names: &[String], key: Key, n: usize) -> (String, String) {
    match key {
        Key::Pose(i) => (
            format!(
                "image {}",
                p.images
                    .get(i.index())
                    .map_or(i.to_string(), |x| x.id.clone())
            ),
            if n < 4 {
                format!("too few observations for its six elements ({n}: points and GNSS); measure at least 3 well-spread points")
            } else {
                format!("its {n} observations do not fix its six elements (points on a line, or all in one spot); measure points spread over the image")
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
        k => (k.to_string(), "not determined".to_string()),
    }
}
