//! The texture draped on the terrain of the textured block: sharp-edged elements (fields,
//! gabled roofs, roads with dashed marks, small rectangles and discs of many grey levels, and
//! a control target — a black square with a white disc — at each control and check point)
//! over a smooth background, plus fine value noise. Corner and blob detectors find features
//! at scales from a few pixels (marks, small discs) to hundreds (fields).
//!
//! What enters: a seed, the [`Extent`] to cover and the target positions (east, north; m).
//! What leaves: grey levels (0–255 scale, unclamped) at horizontal ENU positions, split as the
//! renderer samples them: [`Texture::layer`] (the sharp elements, to be supersampled),
//! [`Texture::background`] and [`Texture::detail`] (smooth, sampled once per pixel).
//! Deterministic for the seed; elements are found through a grid of 2 m cells.

use super::terrain::Extent;
use crate::rng::Rng;
use nalgebra::Vector2;

/// A shape on the ground plane (east, north; m).
#[derive(Clone, Copy, Debug)]
enum Shape {
    /// Centre and squared radius.
    Disc(Vector2<f64>, f64),
    /// Centre, half sides along and across its direction, direction cosine and sine.
    Rect(Vector2<f64>, [f64; 2], [f64; 2]),
}

impl Shape {
    fn contains(&self, p: Vector2<f64>) -> bool {
        match *self {
            Shape::Disc(c, r2) => (p - c).norm_squared() <= r2,
            Shape::Rect(c, [hu, hv], [co, si]) => {
                let d = p - c;
                (d.x * co + d.y * si).abs() <= hu && (d.y * co - d.x * si).abs() <= hv
            }
        }
    }

    /// Bounding box: min and max corners.
    fn bbox(&self) -> (Vector2<f64>, Vector2<f64>) {
        let half = match *self {
            Shape::Disc(_, r2) => Vector2::repeat(r2.sqrt()),
            Shape::Rect(_, [hu, hv], [co, si]) => {
                Vector2::new(hu * co.abs() + hv * si.abs(), hu * si.abs() + hv * co.abs())
            }
        };
        let c = match *self {
            Shape::Disc(c, _) | Shape::Rect(c, _, _) => c,
        };
        (c - half, c + half)
    }
}

/// The salt of the texture's random stream (`Rng::fork`).
const TEXTURE_SALT: u64 = 72;
/// Side of a lookup cell, m.
const CELL: f64 = 2.0;

/// Wavelength (m) and amplitude (grey levels) of each octave of value noise.
type Octaves = [(f64, f64); 3];

/// The texture: elements painted in order (later over earlier) over a background.
#[derive(Clone, Debug)]
pub struct Texture {
    seed: u64,
    elements: Vec<(Shape, f64)>,
    /// Lookup grid: origin, cells along east and north, and per cell (CSR) the elements
    /// touching it in painting order.
    origin: Vector2<f64>,
    cells: [usize; 2],
    start: Vec<u32>,
    items: Vec<u32>,
    background_mean: f64,
    background_octaves: Octaves,
    detail_octaves: Octaves,
}

impl Texture {
    /// The texture of a seed over `extent`, with a control target at each of `targets`.
    pub fn generate(seed: u64, extent: &Extent, targets: &[Vector2<f64>]) -> Texture {
        let mut rng = Rng::new(seed).fork(TEXTURE_SALT);
        let mut el = Vec::new();
        let area = (extent.xmax - extent.xmin) * (extent.ymax - extent.ymin);
        let count = |per_m2: f64| (area * per_m2).round() as usize;
        let at = |rng: &mut Rng| {
            Vector2::new(
                rng.range(extent.xmin, extent.xmax),
                rng.range(extent.ymin, extent.ymax),
            )
        };
        let rect = |c: Vector2<f64>, hu: f64, hv: f64, a: f64| {
            Shape::Rect(c, [hu, hv], [a.cos(), a.sin()])
        };
        for _ in 0..count(1.0 / 500.0) {
            let c = at(&mut rng);
            let (hu, hv, a) = (
                rng.range(5.0, 18.0),
                rng.range(5.0, 18.0),
                rng.range(0.0, 3.2),
            );
            el.push((rect(c, hu, hv, a), rng.range(70.0, 190.0)));
        }
        for _ in 0..count(1.0 / 15000.0).max(2) {
            roads(
                &mut el,
                at(&mut rng),
                rng.range(0.0, 3.2),
                rng.range(60.0, 150.0),
            );
        }
        for _ in 0..count(1.0 / 300.0) {
            let c = at(&mut rng);
            let (hu, hv, a) = (
                rng.range(1.5, 5.0),
                rng.range(1.5, 5.0),
                rng.range(0.0, 3.2),
            );
            let grey = rng.range(40.0, 230.0);
            el.push((rect(c, hu, hv, a), grey));
            // The gable's other half, lit differently.
            let half = c + Vector2::new(-a.sin(), a.cos()) * (hv / 2.0);
            let other = (grey + rng.range(30.0, 60.0) * if grey > 135.0 { -1.0 } else { 1.0 })
                .clamp(0.0, 255.0);
            el.push((rect(half, hu, hv / 2.0, a), other));
        }
        for _ in 0..count(1.0 / 25.0) {
            let c = at(&mut rng);
            let (hu, hv, a) = (
                rng.range(0.15, 0.9),
                rng.range(0.15, 0.9),
                rng.range(0.0, 3.2),
            );
            el.push((rect(c, hu, hv, a), rng.range(10.0, 245.0)));
        }
        for _ in 0..count(1.0 / 15.0) {
            let c = at(&mut rng);
            let r = rng.range(0.12, 1.0);
            el.push((Shape::Disc(c, r * r), rng.range(10.0, 245.0)));
        }
        for t in targets {
            el.push((rect(*t, 0.5, 0.5, 0.0), 15.0));
            el.push((Shape::Disc(*t, 0.25 * 0.25), 240.0));
        }
        let octaves = [(25.0, 30.0), (9.0, 18.0), (3.0, 10.0)];
        let detail = [(1.1, 8.0), (0.45, 6.0), (0.2, 4.0)];
        Texture::from_elements(seed, extent, el, 115.0, octaves, detail)
    }

    /// A black plane with white (255) discs of `radius` m centred at `centres` (east,
    /// north; m), without noise: the renderer's pixel-convention check.
    pub fn discs(centres: &[Vector2<f64>], radius: f64) -> Texture {
        if centres.is_empty() {
            return Texture::discs(&[Vector2::zeros()], 0.0);
        }
        let lo = centres
            .iter()
            .fold(Vector2::repeat(f64::INFINITY), |a, c| a.inf(c));
        let hi = centres
            .iter()
            .fold(Vector2::repeat(f64::NEG_INFINITY), |a, c| a.sup(c));
        let extent = Extent {
            xmin: lo.x - radius - CELL,
            xmax: hi.x + radius + CELL,
            ymin: lo.y - radius - CELL,
            ymax: hi.y + radius + CELL,
        };
        let el = centres
            .iter()
            .map(|c| (Shape::Disc(*c, radius * radius), 255.0))
            .collect();
        Texture::from_elements(0, &extent, el, 0.0, [(1.0, 0.0); 3], [(1.0, 0.0); 3])
    }

    fn from_elements(
        seed: u64,
        extent: &Extent,
        elements: Vec<(Shape, f64)>,
        background_mean: f64,
        background_octaves: Octaves,
        detail_octaves: Octaves,
    ) -> Texture {
        let origin = Vector2::new(extent.xmin, extent.ymin) - Vector2::repeat(CELL);
        let cells = [
            ((extent.xmax - extent.xmin) / CELL).ceil() as usize + 2,
            ((extent.ymax - extent.ymin) / CELL).ceil() as usize + 2,
        ];
        let range = |lo: f64, hi: f64, o: f64, n: usize| {
            let a = ((lo - o) / CELL).floor().max(0.0) as usize;
            let b = (((hi - o) / CELL).floor().max(-1.0) + 1.0) as usize;
            a.min(n)..b.min(n)
        };
        let mut lists = vec![Vec::new(); cells[0] * cells[1]];
        for (k, (shape, _)) in elements.iter().enumerate() {
            let (lo, hi) = shape.bbox();
            for j in range(lo.y, hi.y, origin.y, cells[1]) {
                for i in range(lo.x, hi.x, origin.x, cells[0]) {
                    lists[j * cells[0] + i].push(k as u32);
                }
            }
        }
        let mut start = Vec::with_capacity(lists.len() + 1);
        let mut items = Vec::new();
        for l in &lists {
            start.push(items.len() as u32);
            items.extend_from_slice(l);
        }
        start.push(items.len() as u32);
        Texture {
            seed,
            elements,
            origin,
            cells,
            start,
            items,
            background_mean,
            background_octaves,
            detail_octaves,
        }
    }

    /// The grey of the topmost element at `p` (east, north; m), if any.
    pub fn layer(&self, p: Vector2<f64>) -> Option<f64> {
        let q = (p - self.origin) / CELL;
        if !(q.x >= 0.0 && q.y >= 0.0) {
            return None;
        }
        let (i, j) = (q.x as usize, q.y as usize);
        if i >= self.cells[0] || j >= self.cells[1] {
            return None;
        }
        let c = j * self.cells[0] + i;
        let list = &self.items[self.start[c] as usize..self.start[c + 1] as usize];
        list.iter().rev().find_map(|&k| {
            let (shape, grey) = &self.elements[k as usize];
            shape.contains(p).then_some(*grey)
        })
    }

    /// The smooth background grey at `p` (where no element lies).
    pub fn background(&self, p: Vector2<f64>) -> f64 {
        self.background_mean + fbm(self.seed, 0, p, &self.background_octaves)
    }

    /// The fine noise added everywhere (grey levels, mean zero; finest wavelength 0.2 m).
    pub fn detail(&self, p: Vector2<f64>) -> f64 {
        fbm(self.seed, 3, p, &self.detail_octaves)
    }
}

/// A road of half-length `half` m through `c` at angle `a`: 5 m of asphalt with dashed
/// centre marks (1.5 m × 0.12 m, every 4 m).
fn roads(el: &mut Vec<(Shape, f64)>, c: Vector2<f64>, a: f64, half: f64) {
    let (co, si) = (a.cos(), a.sin());
    el.push((Shape::Rect(c, [half, 2.5], [co, si]), 85.0));
    let dir = Vector2::new(co, si);
    let n = (half / 4.0) as i64;
    for k in -n..=n {
        let m = c + dir * (4.0 * k as f64);
        el.push((Shape::Rect(m, [0.75, 0.06], [co, si]), 235.0));
    }
}

/// Fractal value noise: the sum over octaves of smoothly interpolated lattice values in
/// [−1, 1] times the octave's amplitude; `salt` separates independent fields.
fn fbm(seed: u64, salt: u64, p: Vector2<f64>, octaves: &Octaves) -> f64 {
    let mut sum = 0.0;
    for (k, &(wavelength, amp)) in octaves.iter().enumerate() {
        if amp != 0.0 {
            sum += amp * value_noise(seed, salt + k as u64, p / wavelength);
        }
    }
    sum
}

/// Value noise at `q` (lattice units): quintic-faded bilinear interpolation of hashed values.
fn value_noise(seed: u64, octave: u64, q: Vector2<f64>) -> f64 {
    let (fx, fy) = (q.x.floor(), q.y.floor());
    let (ix, iy) = (fx as i64, fy as i64);
    let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let (u, v) = (fade(q.x - fx), fade(q.y - fy));
    let h = |dx: i64, dy: i64| lattice(seed, octave, ix + dx, iy + dy);
    let a = h(0, 0) + u * (h(1, 0) - h(0, 0));
    let b = h(0, 1) + u * (h(1, 1) - h(0, 1));
    a + v * (b - a)
}

/// A random value in [−1, 1) for a lattice node (SplitMix64's finaliser on the mixed keys).
fn lattice(seed: u64, octave: u64, ix: i64, iy: i64) -> f64 {
    let mut z = seed
        ^ (ix as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (iy as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ octave.wrapping_mul(0x1656_67B1_9E37_79F9);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_lookup_finds_the_topmost_element_as_a_full_scan_does() {
        let ext = Extent {
            xmin: 0.0,
            xmax: 60.0,
            ymin: 0.0,
            ymax: 40.0,
        };
        let t = Texture::generate(3, &ext, &[Vector2::new(20.0, 20.0)]);
        let mut rng = Rng::new(1);
        let mut hits = 0;
        for _ in 0..20000 {
            let p = Vector2::new(rng.range(-5.0, 65.0), rng.range(-5.0, 45.0));
            let scan = t
                .elements
                .iter()
                .rev()
                .find_map(|(s, g)| s.contains(p).then_some(*g));
            let far = t.origin + Vector2::new(t.cells[0] as f64, t.cells[1] as f64) * CELL;
            let inside = p.x >= t.origin.x && p.y >= t.origin.y && p.x < far.x && p.y < far.y;
            if inside {
                assert_eq!(t.layer(p), scan, "{p}");
                hits += scan.is_some() as usize;
            }
        }
        assert!(hits > 10000, "{hits}");
        assert_eq!(t.layer(Vector2::new(20.0, 20.0)), Some(240.0));
    }
}
