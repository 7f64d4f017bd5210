//! Automatic tie points between photographs: scale- and rotation-invariant features
//! ([`extract`]), descriptor matching with the ratio test and a mutual check
//! ([`matching`]), geometric verification by RANSAC on the fundamental matrix
//! ([`epipolar`]), guided matching once a pair's geometry is known ([`guided`]), tracks
//! across images ([`tracks`]) and their completion in the other photos that see them
//! ([`complete`]); a global descriptor per image for pairing photos without
//! positions ([`vlad`]).
//!
//! Enters: grey images (8-bit, any size, perhaps reduced from the photograph) and the factor
//! back to the photograph's pixels. Leaves: keypoints in the photograph's pixels (column
//! right, row down, origin at the top-left corner of the top-left pixel, as
//! [`crate::camera::Camera::pixel_to_image`]) with their descriptors; verified matches;
//! tracks. Nothing here reads files.
//!
//! The detector and descriptor are SIFT (Lowe 2004, as OpenCV computes it) from the
//! `sift-features` crate: pure Rust, no system library. Keypoints are spread over the image by
//! a grid: each cell keeps its strongest responses up to its share of the cap, and the rest of
//! the cap goes to the strongest remaining keypoints anywhere.

pub mod complete;
pub mod epipolar;
pub mod guided;
pub mod lsm;
pub mod matching;
mod near;
mod sampling;
pub mod tracks;
pub mod vlad;

/// An 8-bit grey image, row-major.
#[derive(Clone, Debug)]
pub struct GrayImage {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `width × height` grey values, row after row.
    pub data: Vec<u8>,
}

/// A keypoint in the photograph's pixels (origin at the top-left corner).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keypoint {
    /// Column, pixels.
    pub x: f64,
    /// Row, pixels.
    pub y: f64,
    /// Diameter of the feature's neighbourhood, photograph pixels.
    pub size: f64,
    /// Orientation, degrees.
    pub angle: f64,
    /// Detector response (contrast of the difference of Gaussians).
    pub response: f64,
}

/// Length of a descriptor.
pub const DESCRIPTOR_LEN: usize = 128;

/// A SIFT descriptor, quantised to bytes as OpenCV does.
pub type Descriptor = [u8; DESCRIPTOR_LEN];

/// The features of one image.
#[derive(Clone, Debug, Default)]
pub struct Features {
    /// Keypoints.
    pub keypoints: Vec<Keypoint>,
    /// Their descriptors, in the same order.
    pub descriptors: Vec<Descriptor>,
}

/// How features are extracted.
#[derive(Clone, Copy, Debug)]
pub struct FeatureOptions {
    /// Most keypoints kept per image.
    pub max_features: usize,
    /// Grid cells across the longer side of the image (the shorter side gets its share).
    pub grid: usize,
}

impl Default for FeatureOptions {
    fn default() -> Self {
        FeatureOptions {
            max_features: 8000,
            grid: 8,
        }
    }
}

/// SIFT features of `img`, keypoints scaled to the photograph by `scale` (photograph pixels per
/// image pixel) and spread by the grid; deterministic.
pub fn extract(img: &GrayImage, scale: f64, opts: &FeatureOptions) -> Features {
    let Some(buf) = image::GrayImage::from_raw(img.width, img.height, img.data.clone()) else {
        return Features::default();
    };
    if img.width < 16 || img.height < 16 {
        return Features::default();
    }
    let r = sift_features::sift_with_processing::<sampling::Consistent>(&buf, None);
    let kps: Vec<Keypoint> = r
        .keypoints
        .iter()
        .map(|k| Keypoint {
            // Pixel centres on integers (see `sampling`): +0.5 moves the origin to the corner.
            x: (k.x as f64 + 0.5) * scale,
            y: (k.y as f64 + 0.5) * scale,
            size: k.size as f64 * scale,
            angle: k.angle as f64,
            response: k.response as f64,
        })
        .collect();
    let keep = spread(
        &kps,
        img.width as f64 * scale,
        img.height as f64 * scale,
        opts,
    );
    let mut out = Features::default();
    for i in keep {
        let row = r.descriptors.row(i);
        let mut d = [0u8; DESCRIPTOR_LEN];
        for (o, v) in d.iter_mut().zip(row.iter()) {
            *o = *v;
        }
        out.keypoints.push(kps[i]);
        out.descriptors.push(d);
    }
    out
}

/// The `n` keypoints of `f` that seed matching (spread by the grid of `opts` as
/// extraction spreads them, strongest first within a cell), as their indices in `f` in
/// increasing order, with their features. All of them when `f` has no more than `n`.
/// `width` and `height` are the photograph's, pixels.
pub fn strongest(
    f: &Features,
    n: usize,
    width: f64,
    height: f64,
    opts: &FeatureOptions,
) -> (Vec<u32>, Features) {
    let o = FeatureOptions {
        max_features: n,
        ..*opts
    };
    let keep = spread(&f.keypoints, width, height, &o);
    let sub = Features {
        keypoints: keep.iter().map(|&i| f.keypoints[i]).collect(),
        descriptors: keep.iter().map(|&i| f.descriptors[i]).collect(),
    };
    (keep.into_iter().map(|i| i as u32).collect(), sub)
}

/// For every keypoint, the first keypoint at exactly the same position (SIFT gives a point one
/// keypoint per dominant orientation): matches are joined on these, so one image position is
/// one measurement.
pub fn same_position(kps: &[Keypoint]) -> Vec<u32> {
    let mut first: std::collections::HashMap<(u64, u64), u32> = Default::default();
    kps.iter()
        .enumerate()
        .map(|(i, k)| {
            *first
                .entry((k.x.to_bits(), k.y.to_bits()))
                .or_insert(i as u32)
        })
        .collect()
}

/// Indices of the keypoints kept: per grid cell the strongest up to an equal share of the
/// cap, then the strongest of the rest; in order of index.
fn spread(kps: &[Keypoint], width: f64, height: f64, opts: &FeatureOptions) -> Vec<usize> {
    let mut order: Vec<usize> = (0..kps.len()).collect();
    order.sort_by(|&a, &b| kps[b].response.total_cmp(&kps[a].response).then(a.cmp(&b)));
    if kps.len() <= opts.max_features {
        order.sort_unstable();
        return order;
    }
    let g = opts.grid.max(1) as f64;
    let cell = width.max(height) / g;
    let (nx, ny) = (
        (width / cell).ceil().max(1.0) as usize,
        (height / cell).ceil().max(1.0) as usize,
    );
    let share = opts.max_features.div_ceil(nx * ny);
    let mut used = vec![0usize; nx * ny];
    let mut taken = vec![false; kps.len()];
    let mut n = 0;
    for &i in &order {
        let cx = ((kps[i].x / cell) as usize).min(nx - 1);
        let cy = ((kps[i].y / cell) as usize).min(ny - 1);
        if used[cy * nx + cx] < share && n < opts.max_features {
            used[cy * nx + cx] += 1;
            taken[i] = true;
            n += 1;
        }
    }
    for &i in &order {
        if n >= opts.max_features {
            break;
        }
        if !taken[i] {
            taken[i] = true;
            n += 1;
        }
    }
    (0..kps.len()).filter(|&i| taken[i]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grey image of dark discs of several sizes on a lighter, smoothly varying background.
    pub(crate) fn discs(w: u32, h: u32, centres: &[(f64, f64, f64)]) -> GrayImage {
        let mut data = vec![0u8; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let mut v = 180.0 + 20.0 * (px * 0.01).sin() * (py * 0.013).cos();
                for &(cx, cy, r) in centres {
                    // Anti-aliased disc: coverage from the distance to the edge.
                    let d = ((px - cx).powi(2) + (py - cy).powi(2)).sqrt() - r;
                    let cover = (0.5 - d).clamp(0.0, 1.0);
                    v = v * (1.0 - cover) + 40.0 * cover;
                }
                data[(y * w + x) as usize] = v.round().clamp(0.0, 255.0) as u8;
            }
        }
        GrayImage {
            width: w,
            height: h,
            data,
        }
    }

    #[test]
    fn blob_keypoints_sit_on_the_disc_centres_in_corner_origin_pixels() {
        let centres = [(60.3, 50.7, 6.0), (150.6, 90.2, 9.0), (100.0, 140.5, 5.0)];
        let img = discs(220, 200, &centres);
        let f = extract(&img, 1.0, &FeatureOptions::default());
        assert_eq!(f.keypoints.len(), f.descriptors.len());
        for &(cx, cy, _) in &centres {
            let best = f
                .keypoints
                .iter()
                .map(|k| ((k.x - cx).powi(2) + (k.y - cy).powi(2)).sqrt())
                .fold(f64::INFINITY, f64::min);
            assert!(
                best < 0.15,
                "disc at ({cx}, {cy}): nearest keypoint {best} px"
            );
        }
        // Scaled: the same image as a half-size rendering of a photograph.
        let g = extract(&img, 2.0, &FeatureOptions::default());
        let k0 = f.keypoints[0];
        let k1 = g.keypoints[0];
        assert!((k1.x - 2.0 * k0.x).abs() < 1e-9 && (k1.y - 2.0 * k0.y).abs() < 1e-9);
    }

    #[test]
    fn the_grid_spreads_the_cap_over_the_image() {
        // 100 strong keypoints in one corner, 100 weak ones elsewhere.
        let mut kps = Vec::new();
        for i in 0..100 {
            kps.push(Keypoint {
                x: 5.0 + (i % 10) as f64,
                y: 5.0 + (i / 10) as f64,
                size: 2.0,
                angle: 0.0,
                response: 1.0 + i as f64,
            });
            kps.push(Keypoint {
                x: 20.0 + (i % 10) as f64 * 8.0,
                y: 20.0 + (i / 10) as f64 * 8.0,
                size: 2.0,
                angle: 0.0,
                response: 0.1,
            });
        }
        let opts = FeatureOptions {
            max_features: 50,
            grid: 4,
        };
        let keep = spread(&kps, 100.0, 100.0, &opts);
        assert_eq!(keep.len(), 50);
        let corner = keep
            .iter()
            .filter(|&&i| kps[i].x < 25.0 && kps[i].y < 25.0)
            .count();
        assert!(corner < 30, "{corner} of 50 in the crowded corner");
    }
}
