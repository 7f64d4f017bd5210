//! Which images to match: every pair for small sets or when positions are missing, else the
//! neighbours whose ground footprints overlap (footprint radius from the height above ground
//! and the field of view), and always each image's nearest few, so a wrong height cannot cut
//! the block apart.

use nalgebra::Vector3;

/// How pairs are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PairMode {
    /// Footprints when positions are known and the set is large, else every pair.
    Auto,
    /// Every pair.
    Exhaustive,
    /// Footprints (positions required).
    Gnss,
}

/// Sets up to this size are matched exhaustively in `auto`.
pub const EXHAUSTIVE_UP_TO: usize = 40;

/// Nearest neighbours always paired with each image when pairing by positions.
pub const NEAREST: usize = 8;

/// Pairs (i < j, sorted) and a sentence on how they were chosen. `pos` are local east/north/up
/// positions; `radius` the footprint radius of each image (m) when known.
pub fn choose(
    mode: PairMode,
    pos: &[Option<Vector3<f64>>],
    radius: &[Option<f64>],
) -> Result<(Vec<(usize, usize)>, String), String> {
    let n = pos.len();
    let all_known = pos.iter().all(Option::is_some);
    let exhaustive = match mode {
        PairMode::Exhaustive => true,
        PairMode::Auto => n <= EXHAUSTIVE_UP_TO || !all_known,
        PairMode::Gnss => {
            if !all_known {
                return Err(
                    "--pairs gnss needs a position for every photo (EXIF GPS or --exposures)"
                        .into(),
                );
            }
            false
        }
    };
    if exhaustive {
        let p: Vec<_> = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .collect();
        let why = if mode == PairMode::Exhaustive {
            "exhaustive (asked)".to_string()
        } else if !all_known {
            "exhaustive (not every photo has a position)".to_string()
        } else {
            format!("exhaustive ({n} photos, at most {EXHAUSTIVE_UP_TO} are matched all with all)")
        };
        return Ok((p, why));
    }
    let p: Vec<Vector3<f64>> = pos.iter().map(|x| x.unwrap_or_default()).collect();
    let mut set = std::collections::BTreeSet::new();
    for i in 0..n {
        let mut d: Vec<(f64, usize)> = (0..n)
            .filter(|&j| j != i)
            .map(|j| ((p[i] - p[j]).xy().norm(), j))
            .collect();
        d.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (k, &(dist, j)) in d.iter().enumerate() {
            let reach = match (radius[i], radius[j]) {
                (Some(a), Some(b)) => dist < 0.9 * (a + b),
                _ => false,
            };
            if k < NEAREST || reach {
                set.insert((i.min(j), i.max(j)));
            }
        }
    }
    let why = format!(
        "by position: overlapping footprints and the {NEAREST} nearest of each photo ({} of {} pairs)",
        set.len(),
        n * (n.saturating_sub(1)) / 2
    );
    Ok((set.into_iter().collect(), why))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_or_unplaced_sets_are_exhaustive_and_large_ones_by_footprint() {
        let (p, _) = choose(PairMode::Auto, &[None, None, None], &[None; 3]).unwrap();
        assert_eq!(p, vec![(0, 1), (0, 2), (1, 2)]);
        // A 100-photo strip, 10 m apart, footprints of radius 30 m.
        let pos: Vec<_> = (0..100)
            .map(|i| Some(Vector3::new(i as f64 * 10.0, 0.0, 50.0)))
            .collect();
        let (p, why) = choose(PairMode::Auto, &pos, &[Some(30.0); 100]).unwrap();
        assert!(why.starts_with("by position"), "{why}");
        // Footprints reach 5 neighbours on each side (54 m): 5·100 − 15 pairs; the 8 nearest
        // add 3 + 2 + 1 longer pairs at each end of the strip.
        assert_eq!(p.len(), 497);
        assert!(choose(PairMode::Gnss, &[None, Some(Vector3::zeros())], &[None; 2]).is_err());
    }
}
