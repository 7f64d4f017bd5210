//! Strips from a track of positions, for imports whose image lists name none: images in name
//! order (flight order for sequentially numbered photos), a new strip where the track turns
//! by more than [`TURN_DEG`] from the strip's direction or jumps more than [`JUMP`] times the
//! usual step. Navigation-grade positions then get one offset per strip, which takes up a
//! constant offset and the along-track shift of a latency (opposite in strips flown the other
//! way) without times.
//!
//! What enters: image ids with their horizontal positions (any metric frame, `None` where an
//! image has none). What leaves: the strip number (from 1) of each, in the input order.

use nalgebra::Vector2;

/// A turn from the strip's direction that starts a new strip, degrees.
pub const TURN_DEG: f64 = 45.0;
/// A step longer than this many median steps starts a new strip.
pub const JUMP: f64 = 3.0;

/// The strip (from 1) of every image, in the order given.
pub fn strips_from_track(images: &[(String, Option<Vector2<f64>>)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..images.len()).collect();
    order.sort_by(|&a, &b| images[a].0.cmp(&images[b].0));
    let located: Vec<(usize, Vector2<f64>)> = order
        .iter()
        .filter_map(|&i| images[i].1.map(|p| (i, p)))
        .collect();
    let mut steps: Vec<f64> = located
        .windows(2)
        .map(|w| (w[1].1 - w[0].1).norm())
        .collect();
    steps.sort_by(f64::total_cmp);
    let median = steps.get(steps.len() / 2).copied().unwrap_or(0.0);
    let mut strip_of = vec![0usize; images.len()];
    let (mut strip, mut dir) = (1usize, Vector2::zeros());
    let mut prev: Option<Vector2<f64>> = None;
    for &i in &order {
        if let (Some(p), Some(q)) = (images[i].1, prev) {
            let d = p - q;
            let turned = dir.norm() > 0.0
                && d.norm() > 0.0
                && d.normalize().dot(&dir.normalize()) < TURN_DEG.to_radians().cos();
            if d.norm() > JUMP * median || turned {
                strip += 1;
                dir = Vector2::zeros();
            } else {
                dir += d;
            }
        }
        if images[i].1.is_some() {
            prev = images[i].1;
        }
        strip_of[i] = strip;
    }
    strip_of
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A serpentine of three strips of five photos (flown east, west, east) with 2 m of noise
    /// and one photo without a position: three strips, split at the turns.
    #[test]
    fn serpentine_track_splits_at_the_turns() {
        let mut images = Vec::new();
        let noise = [1.5, -2.0, 0.7, -0.4, 1.9];
        for s in 0..3 {
            for k in 0..5 {
                let x = if s % 2 == 0 { k } else { 4 - k } as f64 * 250.0;
                let p = Vector2::new(x + noise[k], s as f64 * 700.0 - noise[4 - k]);
                let id = format!("F{:03}", s * 5 + k + 1);
                images.push((id, (s * 5 + k != 7).then_some(p)));
            }
        }
        images.reverse();
        let strips = strips_from_track(&images);
        let by_id: Vec<usize> = (0..15).map(|k| strips[14 - k]).collect();
        assert_eq!(by_id, [1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 3, 3, 3, 3, 3]);
    }
}
