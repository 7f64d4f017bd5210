//! Which images to match: every pair for small sets; by position the neighbours whose ground
//! footprints overlap (footprint radius from the height above ground and the field of view),
//! and always each image's nearest few, so a wrong height cannot cut the block apart; without
//! positions, each photo with the photos that look most alike (a global descriptor built
//! from the block, `photo::features::vlad`) and its neighbours in name order (the flight's
//! sequence), so the work grows with the photos, not their square.

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
    /// The most alike by global descriptor, and the neighbours in name order.
    Appearance,
}

/// Sets up to this size are matched exhaustively in `auto`.
pub const EXHAUSTIVE_UP_TO: usize = 40;

/// Nearest neighbours always paired with each image when pairing by positions.
pub const NEAREST: usize = 8;

/// Photos most alike (global descriptor) paired with each photo when pairing by appearance.
pub const MOST_ALIKE: usize = 12;

/// Neighbours in name order on each side paired with each photo when pairing by appearance.
pub const SEQUENCE: usize = 2;

/// Whether `choose` will want the photos' likeness (pairing by appearance).
pub fn wants_appearance(mode: PairMode, pos: &[Option<Vector3<f64>>]) -> bool {
    let n = pos.len();
    match mode {
        PairMode::Appearance => true,
        PairMode::Auto => n > EXHAUSTIVE_UP_TO && !pos.iter().all(Option::is_some),
        _ => false,
    }
}

/// Pairs from each photo's most alike (`alike[i]`, most alike first) and its `SEQUENCE`
/// neighbours on each side in name order.
fn by_appearance(alike: &[Vec<usize>], why: &str) -> (Vec<(usize, usize)>, String) {
    let n = alike.len();
    let mut set = std::collections::BTreeSet::new();
    for (i, a) in alike.iter().enumerate() {
        for &j in a.iter().take(MOST_ALIKE) {
            if j != i && j < n {
                set.insert((i.min(j), i.max(j)));
            }
        }
        for j in i + 1..(i + 1 + SEQUENCE).min(n) {
            set.insert((i, j));
        }
    }
    let note = format!(
        "by appearance ({why}): the {MOST_ALIKE} most alike of each photo by a global descriptor built from the block, and {SEQUENCE} neighbours on each side in name order ({} of {} pairs)",
        set.len(),
        n * (n.saturating_sub(1)) / 2
    );
    (set.into_iter().collect(), note)
}

/// Pairs (i < j, sorted) and a sentence on how they were chosen. `pos` are local east/north/up
/// positions; `radius` the footprint radius of each image (m) when known; `alike` each
/// photo's most alike others, given when [`wants_appearance`] says so.
pub fn choose(
    mode: PairMode,
    pos: &[Option<Vector3<f64>>],
    radius: &[Option<f64>],
    alike: Option<&[Vec<usize>]>,
) -> Result<(Vec<(usize, usize)>, String), String> {
    let n = pos.len();
    let all_known = pos.iter().all(Option::is_some);
    if let (true, Some(alike)) = (wants_appearance(mode, pos), alike) {
        let why = if mode == PairMode::Appearance {
            "asked".to_string()
        } else {
            format!("{n} photos, not every one with a position")
        };
        return Ok(by_appearance(alike, &why));
    }
    let exhaustive = match mode {
        PairMode::Exhaustive => true,
        PairMode::Auto | PairMode::Appearance => n <= EXHAUSTIVE_UP_TO || !all_known,
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
        let (p, _) = choose(PairMode::Auto, &[None, None, None], &[None; 3], None).unwrap();
        assert_eq!(p, vec![(0, 1), (0, 2), (1, 2)]);
        // A 100-photo strip, 10 m apart, footprints of radius 30 m.
        let pos: Vec<_> = (0..100)
            .map(|i| Some(Vector3::new(i as f64 * 10.0, 0.0, 50.0)))
            .collect();
        let (p, why) = choose(PairMode::Auto, &pos, &[Some(30.0); 100], None).unwrap();
        assert!(why.starts_with("by position"), "{why}");
        // Footprints reach 5 neighbours on each side (54 m): 5·100 − 15 pairs; the 8 nearest
        // add 3 + 2 + 1 longer pairs at each end of the strip.
        assert_eq!(p.len(), 497);
        assert!(choose(
            PairMode::Gnss,
            &[None, Some(Vector3::zeros())],
            &[None; 2],
            None
        )
        .is_err());
    }

    #[test]
    fn unplaced_large_sets_pair_by_appearance_and_sequence() {
        let n = 60;
        assert!(wants_appearance(PairMode::Auto, &vec![None; n]));
        assert!(!wants_appearance(PairMode::Auto, &vec![None; 10]));
        // Each photo most alike the photo 30 away (another strip), then the next one.
        let alike: Vec<Vec<usize>> = (0..n).map(|i| vec![(i + 30) % n, (i + 1) % n]).collect();
        let (p, why) = choose(PairMode::Auto, &vec![None; n], &[None; 60], Some(&alike)).unwrap();
        assert!(why.starts_with("by appearance"), "{why}");
        assert!(p.contains(&(0, 30)) && p.contains(&(0, 2)) && p.contains(&(58, 59)));
        // 30 cross pairs, 59 + 58 sequence pairs, and (0, 59) from the wrap of "the next".
        assert_eq!(p.len(), 30 + 59 + 58 + 1);
    }
}
