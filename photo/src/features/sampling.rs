//! The resampling and blurring SIFT runs on, with one pixel convention throughout: sample m
//! of an image at sampling distance δ sits at coordinate m·δ of the input (pixel centres on
//! integers). The 2× seed upsampling interpolates midway between input samples and the
//! octave halving keeps the even samples, so the keypoint coordinates that `sift-features`
//! computes under exactly this assumption are right. (Its default resizers sample
//! centre-aligned, which shifts keypoints by up to ~1.5 input pixels in coarse octaves.)
//! The blur is a separable Gaussian with mirrored borders.

use image::{ImageBuffer, Luma};
use sift_features::Processing;

type Img = ImageBuffer<Luma<f32>, Vec<f32>>;

/// The [`Processing`] of [`super::extract`].
pub struct Consistent;

/// Mirror an index into 0..n (reflect without repeating the edge sample).
#[inline]
fn mirror(i: isize, n: isize) -> usize {
    if n == 1 {
        return 0;
    }
    let p = 2 * (n - 1);
    let mut k = i.rem_euclid(p);
    if k >= n {
        k = p - k;
    }
    k as usize
}

fn kernel(sigma: f64) -> Vec<f32> {
    let r = (3.0 * sigma).ceil().max(1.0) as isize;
    let mut k: Vec<f64> = (-r..=r)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    k.into_iter().map(|v| v as f32).collect()
}

impl Processing for Consistent {
    fn gaussian_blur(img: &Img, sigma: f64) -> Img {
        let (w, h) = (img.width() as usize, img.height() as usize);
        if sigma <= 0.0 || w == 0 || h == 0 {
            return img.clone();
        }
        let k = kernel(sigma);
        let r = (k.len() / 2) as isize;
        let src = img.as_raw();
        // Rows: horizontal pass into `tmp`.
        let mut tmp = vec![0f32; w * h];
        let mut line = vec![0f32; w + 2 * r as usize];
        let ru = r as usize;
        for y in 0..h {
            let row = &src[y * w..(y + 1) * w];
            // Mirrored only at the two ends; the row itself is copied.
            for j in (0..ru).chain(ru + w..line.len()) {
                line[j] = row[mirror(j as isize - r, w as isize)];
            }
            line[ru..ru + w].copy_from_slice(row);
            // Tap after tap over the whole row (vectorised), each sample's sum in tap order.
            let out = &mut tmp[y * w..(y + 1) * w];
            for (o, v) in out.iter_mut().zip(&line[..w]) {
                *o = k[0] * v;
            }
            for (t, kv) in k.iter().enumerate().skip(1) {
                for (o, v) in out.iter_mut().zip(&line[t..t + w]) {
                    *o += kv * v;
                }
            }
        }
        // Columns: accumulate whole rows, so memory is read in order.
        let mut dst = vec![0f32; w * h];
        for y in 0..h {
            let out = &mut dst[y * w..(y + 1) * w];
            for (t, kv) in k.iter().enumerate() {
                let sy = mirror(y as isize + t as isize - r, h as isize);
                let row = &tmp[sy * w..(sy + 1) * w];
                for (o, v) in out.iter_mut().zip(row) {
                    *o += kv * v;
                }
            }
        }
        Img::from_raw(w as u32, h as u32, dst).unwrap_or_else(|| img.clone())
    }

    fn resize_linear(img: &Img, width: u32, height: u32) -> Img {
        // Only the 2× seed is asked for: output sample m at input coordinate m/2.
        let (w, h) = (img.width() as usize, img.height() as usize);
        let at = |m: usize, n: usize| -> (usize, usize, f32) {
            let i = (m / 2).min(n - 1);
            let j = if m % 2 == 1 { (i + 1).min(n - 1) } else { i };
            (i, j, if m % 2 == 1 { 0.5 } else { 0.0 })
        };
        let src = img.as_raw();
        let mut out = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height as usize {
            let (y0, y1, fy) = at(y, h);
            for x in 0..width as usize {
                let (x0, x1, fx) = at(x, w);
                let a = src[y0 * w + x0] * (1.0 - fx) + src[y0 * w + x1] * fx;
                let b = src[y1 * w + x0] * (1.0 - fx) + src[y1 * w + x1] * fx;
                out.push(a * (1.0 - fy) + b * fy);
            }
        }
        Img::from_raw(width, height, out).unwrap_or_else(|| img.clone())
    }

    fn resize_nearest(img: &Img, width: u32, height: u32) -> Img {
        // Halving: output sample m is input sample 2m.
        let w = img.width() as usize;
        let src = img.as_raw();
        let mut out = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height as usize {
            let sy = (2 * y).min(img.height() as usize - 1);
            for x in 0..width as usize {
                out.push(src[sy * w + (2 * x).min(w - 1)]);
            }
        }
        Img::from_raw(width, height, out).unwrap_or_else(|| img.clone())
    }
}
