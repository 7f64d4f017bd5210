//! Photographs decoded to grey at a reduced size, within bounds: the declared size is checked
//! before anything is allocated, JPEG is reduced in the DCT domain while decoding (1/2, 1/4,
//! 1/8: cheap, and the full-size image is never held), other sizes by averaging k × k blocks.
//! A reduced pixel m covers photograph pixels k·m … k·m + k − 1, so a position u in the
//! reduced image (origin at the top-left corner) is k·u in the photograph.
//!
//! Enters: a file (JPEG or PNG, told by content). Leaves: [`Decoded`] or why not.

use photo::features::GrayImage;
use std::io::{BufReader, Read};
use std::path::Path;

/// Largest photograph decoded, pixels (a 200-megapixel photo is no drone camera's).
pub const MAX_PIXELS: u64 = 200_000_000;

/// Most memory a decoder may take for one photograph, bytes (800 MB).
const MAX_DECODE_BYTES: u64 = 4 * MAX_PIXELS;

/// A reduced grey image and how it relates to the photograph.
#[derive(Clone, Debug)]
pub struct Decoded {
    /// The grey image.
    pub gray: GrayImage,
    /// Photograph pixels per reduced pixel.
    pub scale: f64,
    /// The photograph's width and height, pixels.
    pub full: (u32, u32),
}

/// The smallest power-of-two factor (or any factor above 8) that brings the longer side to
/// `max_side` or below.
fn factor(w: u32, h: u32, max_side: u32) -> u32 {
    let long = w.max(h);
    let k = long.div_ceil(max_side.max(16));
    if k <= 1 {
        1
    } else if k <= 8 {
        k.next_power_of_two()
    } else {
        k
    }
}

fn check_size(w: u32, h: u32) -> Result<(), String> {
    if w == 0 || h == 0 {
        return Err("the image has no pixels".into());
    }
    if w as u64 * h as u64 > MAX_PIXELS {
        return Err(format!(
            "it declares {w} × {h} pixels, more than the {MAX_PIXELS} accepted"
        ));
    }
    Ok(())
}

/// Average k × k blocks (the last partial block averages what there is).
fn reduce(g: GrayImage, k: u32) -> GrayImage {
    if k <= 1 {
        return g;
    }
    let (w, h) = (g.width.div_ceil(k), g.height.div_ceil(k));
    let mut sum = vec![0u32; (w * h) as usize];
    let mut cnt = vec![0u32; (w * h) as usize];
    for y in 0..g.height {
        let row = &g.data[(y * g.width) as usize..((y + 1) * g.width) as usize];
        let oy = (y / k) * w;
        for (x, &v) in row.iter().enumerate() {
            let o = (oy + x as u32 / k) as usize;
            sum[o] += v as u32;
            cnt[o] += 1;
        }
    }
    let data = sum
        .iter()
        .zip(&cnt)
        .map(|(s, c)| ((s + c / 2) / c.max(&1)) as u8)
        .collect();
    GrayImage {
        width: w,
        height: h,
        data,
    }
}

fn luma(px: &[u8], format: jpeg_decoder::PixelFormat) -> Result<Vec<u8>, String> {
    use jpeg_decoder::PixelFormat as P;
    Ok(match format {
        P::L8 => px.to_vec(),
        P::L16 => px.chunks_exact(2).map(|c| c[0]).collect(),
        P::RGB24 => px
            .chunks_exact(3)
            .map(|c| ((77 * c[0] as u32 + 150 * c[1] as u32 + 29 * c[2] as u32 + 128) >> 8) as u8)
            .collect(),
        P::CMYK32 => px.chunks_exact(4).map(|c| 255 - c[3]).collect(),
    })
}

fn jpeg(path: &Path, max_side: u32) -> Result<Decoded, String> {
    let f = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let mut d = jpeg_decoder::Decoder::new(BufReader::new(f));
    d.read_info()
        .map_err(|e| format!("not a readable JPEG ({e})"))?;
    let info = d.info().ok_or("not a readable JPEG (no header)")?;
    let (w, h) = (info.width as u32, info.height as u32);
    check_size(w, h)?;
    // A progressive JPEG is decoded from coefficients of the full image (2 bytes a component
    // and pixel) whatever the reduction: held to the PNG decoder's 800 MB.
    if info.coding_process == jpeg_decoder::CodingProcess::DctProgressive {
        let comps = match info.pixel_format {
            jpeg_decoder::PixelFormat::L8 | jpeg_decoder::PixelFormat::L16 => 1,
            jpeg_decoder::PixelFormat::RGB24 => 3,
            jpeg_decoder::PixelFormat::CMYK32 => 4,
        };
        let bytes = 2 * comps * w as u64 * h as u64;
        if bytes > MAX_DECODE_BYTES {
            return Err(format!(
                "a progressive JPEG of {w} × {h} pixels needs {} MB to decode, more than the {} MB accepted",
                bytes / 1_000_000,
                MAX_DECODE_BYTES / 1_000_000
            ));
        }
    }
    let k = factor(w, h, max_side);
    let dct = k.min(8);
    let got = d
        .scale(w.div_ceil(dct) as u16, h.div_ceil(dct) as u16)
        .map_err(|e| format!("cannot reduce the JPEG ({e})"))?;
    let px = d.decode().map_err(|e| format!("damaged JPEG data ({e})"))?;
    let info = d.info().ok_or("not a readable JPEG")?;
    let gray = GrayImage {
        width: got.0 as u32,
        height: got.1 as u32,
        data: luma(&px, info.pixel_format)?,
    };
    if gray.data.len() != (gray.width * gray.height) as usize {
        return Err("the decoded JPEG has the wrong number of pixels".into());
    }
    let done = (w / gray.width.max(1)).max(1);
    let rest = k / done;
    Ok(Decoded {
        gray: reduce(gray, rest),
        scale: (done * rest.max(1)) as f64,
        full: (w, h),
    })
}

fn other(path: &Path, max_side: u32) -> Result<Decoded, String> {
    let mut r = image::ImageReader::open(path)
        .map_err(|e| format!("cannot open: {e}"))?
        .with_guessed_format()
        .map_err(|e| format!("cannot read: {e}"))?;
    let mut lim = image::Limits::default();
    lim.max_alloc = Some(MAX_DECODE_BYTES);
    r.limits(lim);
    let (w, h) = r
        .into_dimensions()
        .map_err(|e| format!("not a readable image ({e})"))?;
    check_size(w, h)?;
    let img = image::ImageReader::open(path)
        .map_err(|e| format!("cannot open: {e}"))?
        .with_guessed_format()
        .map_err(|e| format!("cannot read: {e}"))?
        .decode()
        .map_err(|e| format!("damaged image data ({e})"))?
        .into_luma8();
    let k = factor(w, h, max_side);
    let g = GrayImage {
        width: img.width(),
        height: img.height(),
        data: img.into_raw(),
    };
    Ok(Decoded {
        gray: reduce(g, k),
        scale: k as f64,
        full: (w, h),
    })
}

/// A photograph decoded to grey with its longer side at most `max_side` (by a whole factor).
pub fn decode(path: &Path, max_side: u32) -> Result<Decoded, String> {
    let mut magic = [0u8; 8];
    let n = std::fs::File::open(path)
        .and_then(|mut f| f.read(&mut magic))
        .map_err(|e| format!("cannot open: {e}"))?;
    match &magic[..n.min(8)] {
        [0xFF, 0xD8, ..] => jpeg(path, max_side),
        [0x89, b'P', b'N', b'G', ..] => other(path, max_side),
        _ => Err("not a JPEG or PNG image".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_progressive_jpeg_too_large_to_decode_is_refused_from_its_header() {
        // SOI, then a progressive frame header (SOF2) of 20000 × 9000 pixels, 3 components:
        // 1.08 GB of coefficients for a file of 21 bytes.
        let mut b = vec![0xFF, 0xD8, 0xFF, 0xC2, 0x00, 0x11, 8];
        b.extend_from_slice(&9000u16.to_be_bytes());
        b.extend_from_slice(&20000u16.to_be_bytes());
        b.push(3);
        for id in 1..=3u8 {
            b.extend_from_slice(&[id, 0x11, 0]);
        }
        b.extend_from_slice(&[0xFF, 0xD9]);
        let p = testkit::scratch_path("progressive.jpg");
        std::fs::write(&p, &b).unwrap();
        let e = jpeg(&p, 1000).unwrap_err();
        assert!(e.contains("progressive") && e.contains("1080 MB"), "{e}");
    }

    #[test]
    fn factors_are_powers_of_two_up_to_eight() {
        assert_eq!(factor(4000, 2250, 2000), 2);
        assert_eq!(factor(4000, 2250, 4000), 1);
        assert_eq!(factor(4000, 2250, 1500), 4);
        assert_eq!(factor(8000, 6000, 600), 14);
    }

    #[test]
    fn block_averages_keep_the_corner_origin() {
        let g = GrayImage {
            width: 5,
            height: 2,
            data: vec![0, 2, 4, 6, 8, 10, 12, 14, 16, 18],
        };
        let r = reduce(g, 2);
        assert_eq!((r.width, r.height), (3, 1));
        assert_eq!(r.data, vec![6, 10, 13]);
    }
}
