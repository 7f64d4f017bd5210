//! Search helpers shared by guided matching and track completion: a grid of points for
//! radius queries, the displacement predicted by nearby verified matches, descriptor
//! distances and the nearest two of a candidate set.

use super::epipolar::median_shift;
use super::{Descriptor, Keypoint};
use nalgebra::Vector2;

/// A uniform grid of points for radius queries.
pub(crate) struct Grid {
    cell: f64,
    cols: usize,
    rows: usize,
    buckets: Vec<Vec<u32>>,
}

impl Grid {
    pub(crate) fn new(points: &[Vector2<f64>], cell: f64) -> Grid {
        let (mx, my) = points
            .iter()
            .fold((0.0f64, 0.0f64), |(x, y), p| (x.max(p.x), y.max(p.y)));
        let cols = (mx / cell) as usize + 1;
        let rows = (my / cell) as usize + 1;
        let mut buckets = vec![Vec::new(); cols * rows];
        for (i, p) in points.iter().enumerate() {
            let (c, r) = (
                (p.x.max(0.0) / cell) as usize,
                (p.y.max(0.0) / cell) as usize,
            );
            buckets[r.min(rows - 1) * cols + c.min(cols - 1)].push(i as u32);
        }
        Grid {
            cell,
            cols,
            rows,
            buckets,
        }
    }

    /// Indices of the points within `r` of `p` (in bucket order: deterministic).
    pub(crate) fn within(
        &self,
        points: &[Vector2<f64>],
        p: &Vector2<f64>,
        r: f64,
        out: &mut Vec<u32>,
    ) {
        out.clear();
        let span = |v: f64, n: usize| {
            let lo = ((v - r) / self.cell).floor().max(0.0) as usize;
            let hi = (((v + r) / self.cell).floor().max(0.0) as usize).min(n - 1);
            (lo, hi)
        };
        let (c0, c1) = span(p.x, self.cols);
        let (r0, r1) = span(p.y, self.rows);
        if c0 > c1 || r0 > r1 {
            return;
        }
        for row in r0..=r1 {
            for col in c0..=c1 {
                for &i in &self.buckets[row * self.cols + col] {
                    if (points[i as usize] - p).norm_squared() <= r * r {
                        out.push(i);
                    }
                }
            }
        }
    }
}

pub(crate) fn xy(k: &Keypoint) -> Vector2<f64> {
    Vector2::new(k.x, k.y)
}

pub(crate) fn dist2(a: &Descriptor, b: &Descriptor) -> i64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| {
            let d = x as i64 - y as i64;
            d * d
        })
        .sum()
}

/// Where keypoints of one image move to in another, from verified matches: the median
/// displacement of the `k` matches nearest to a point.
pub(crate) struct Mover {
    from: Vec<Vector2<f64>>,
    disp: Vec<Vector2<f64>>,
    grid: Grid,
    k: usize,
}

impl Mover {
    /// From matched positions (`from` in the first image, `to` in the second) spread over an
    /// image of `w × h` pixels, predicting from the `k` nearest; cells of at least `cell`.
    pub(crate) fn new(
        from: Vec<Vector2<f64>>,
        to: &[Vector2<f64>],
        k: usize,
        (w, h): (f64, f64),
        cell: f64,
    ) -> Mover {
        let disp = from.iter().zip(to).map(|(p, q)| q - p).collect();
        // Cells hold about half the neighbours sought, so the search widens a step or two.
        let seed_cell = (w * h * k as f64 / (2.0 * from.len().max(1) as f64)).sqrt();
        let grid = Grid::new(&from, seed_cell.max(cell).max(1.0));
        Mover {
            from,
            disp,
            grid,
            k: k.max(1),
        }
    }

    /// The median displacement of the matches nearest to `p`, searching ever wider; None
    /// without matches.
    pub(crate) fn shift(&self, p: &Vector2<f64>, buf: &mut Vec<u32>) -> Option<Vector2<f64>> {
        let g = &self.grid;
        let mut r = g.cell;
        let widest = g.cell * (g.cols.max(g.rows) as f64 + 1.0) * 1.5;
        loop {
            g.within(&self.from, p, r, buf);
            if buf.len() >= self.k || r > widest {
                break;
            }
            r *= 2.0;
        }
        if buf.is_empty() {
            return None;
        }
        let mut near: Vec<(f64, u32)> = buf
            .iter()
            .map(|&i| ((self.from[i as usize] - p).norm_squared(), i))
            .collect();
        near.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        near.truncate(self.k);
        Some(median_shift(
            near.iter().map(|&(_, i)| &self.disp[i as usize]),
        ))
    }
}

/// The nearest and second-nearest descriptor distances² among `candidates` (keypoint,
/// distance²), and the nearest's keypoint (the lower of equals); `i64::MAX` and `u32::MAX`
/// where there are none.
pub(crate) fn nearest_two(candidates: impl Iterator<Item = (u32, i64)>) -> (i64, i64, u32) {
    let (mut d1, mut d2, mut k1) = (i64::MAX, i64::MAX, u32::MAX);
    for (k, d) in candidates {
        if d < d1 || (d == d1 && k < k1) {
            d2 = d1;
            d1 = d;
            k1 = k;
        } else if d < d2 {
            d2 = d;
        }
    }
    (d1, d2, k1)
}
