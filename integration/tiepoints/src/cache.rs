//! Features kept on disk beside the project (`OUT/features/<photo file>.feat`), so a rerun on
//! the same folder, or on a folder with photos added, extracts only what it has not seen.
//!
//! A file holds one photo's keypoints and descriptors with the key they were made under: a
//! hash of the photo's image data (a JPEG's bytes but its metadata segments — EXIF, XMP,
//! ICC, comments — so that a photo geotagged or retagged since keeps its key; any other file
//! whole), the settings that shape extraction (largest image side, features per photo, grid)
//! and the format's version and code (a hash of the extraction's sources and the lock file,
//! made by `build.rs`). Besides the project's own folder a cache may be shared by several
//! projects ([`shared_path`]: files named by their key). A file whose key differs (the photo,
//! the settings or the code changed) or that does not read back whole is extracted again and
//! replaced. Values are stored as their exact bits, so a run from the cache writes the same
//! bytes as one without. Files are written whole (`common::atomic::write_atomic`); a cache
//! that cannot be written costs the next run time, never this run's result.

use photo::features::{Descriptor, FeatureOptions, Features, Keypoint, DESCRIPTOR_LEN};
use std::io::Read;
use std::path::{Path, PathBuf};

/// First bytes of a feature file.
const MAGIC: &[u8; 8] = b"PPKFEAT1";

/// Bumped whenever extraction changes what it returns for the same photo (or the key's
/// meaning changes: 2 leaves a JPEG's metadata out).
const EXTRACTION_VERSION: u64 = 2;

/// A hash of the code extraction runs and of the crate versions it uses (`build.rs`).
const EXTRACTION_SOURCE: u64 = include!(concat!(env!("OUT_DIR"), "/extraction_source.rs"));

/// Most keypoints a feature file may declare (a guard against a damaged file).
const MAX_KEYPOINTS: u64 = 1_000_000;

/// The features of one photo as the cache holds them.
#[derive(Clone, Debug)]
pub struct Cached {
    /// Photograph width and height, pixels.
    pub size: (u32, u32),
    /// Photograph pixels per pixel of the image features were extracted from.
    pub scale: f64,
    /// Keypoints and descriptors.
    pub features: Features,
}

/// FNV-1a, 64 bits, continued from `h`.
pub(crate) fn fnv(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The hash of a file's image data, continued from `h`: a JPEG's bytes to the end of its
/// image but its APP0–APP13 and COM segments (metadata: EXIF, XMP, ICC, Photoshop, comments;
/// APP14, Adobe's colour transform, and APP15 stay) and what follows the image (a preview
/// appended); any other file — or a JPEG whose segments do not add up — whole.
fn image_data_hash(h: u64, b: &[u8]) -> u64 {
    if !b.starts_with(&[0xFF, 0xD8]) {
        return fnv(h, b);
    }
    let mut out = fnv(h, &b[..2]);
    let mut i = 2;
    while i + 4 <= b.len() && b[i] == 0xFF {
        let marker = b[i + 1];
        if marker == 0xDA {
            // Start of scan: the entropy-coded data to the end of the image (the first
            // EOI: inside the scan a 0xFF byte is followed by 0x00 or a restart marker);
            // what a camera or a tagger appends after it (a preview image) is not decoded.
            let end = b[i..]
                .windows(2)
                .position(|w| w == [0xFF, 0xD9])
                .map_or(b.len(), |k| i + k + 2);
            return fnv(out, &b[i..end]);
        }
        let end = i + 2 + u16::from_be_bytes([b[i + 2], b[i + 3]]) as usize;
        if end > b.len() {
            break;
        }
        let metadata = (0xE0..=0xED).contains(&marker) || marker == 0xFE;
        if !metadata {
            out = fnv(out, &b[i..end]);
        }
        i = end;
    }
    fnv(h, b)
}

/// The key of a photo's features: its image data ([`image_data_hash`]) and the settings of
/// extraction.
pub fn key(photo: &Path, max_image_size: u32, opts: &FeatureOptions) -> std::io::Result<u64> {
    let mut bytes = Vec::new();
    std::fs::File::open(photo)?.read_to_end(&mut bytes)?;
    let mut h = image_data_hash(0xcbf2_9ce4_8422_2325u64, &bytes);
    for v in [
        EXTRACTION_VERSION,
        EXTRACTION_SOURCE,
        max_image_size as u64,
        opts.max_features as u64,
        opts.grid as u64,
    ] {
        h = fnv(h, &v.to_le_bytes());
    }
    Ok(h)
}

/// The file of a photo's features under `key` in a cache shared by several projects.
pub fn shared_path(dir: &Path, key: u64) -> PathBuf {
    dir.join(format!("{key:016x}.feat"))
}

/// The cache file of a photo.
pub fn path(dir: &Path, photo: &Path) -> PathBuf {
    let name = photo.file_name().unwrap_or_default().to_string_lossy();
    dir.join(format!("{name}.feat"))
}

/// The features cached under `key` in `file`; None when absent, made under another key, or
/// not whole.
pub fn load(file: &Path, key: u64) -> Option<Cached> {
    let bytes = std::fs::read(file).ok()?;
    let mut r = Reader { b: &bytes, at: 0 };
    if r.take(8)? != MAGIC || r.u64()? != key {
        return None;
    }
    let size = (r.u64()? as u32, r.u64()? as u32);
    let scale = f64::from_bits(r.u64()?);
    let n = r.u64()?;
    if n > MAX_KEYPOINTS || r.b.len() - r.at != n as usize * (5 * 8 + DESCRIPTOR_LEN) {
        return None;
    }
    let mut features = Features::default();
    for _ in 0..n {
        let mut v = [0.0; 5];
        for x in &mut v {
            *x = f64::from_bits(r.u64()?);
        }
        features.keypoints.push(Keypoint {
            x: v[0],
            y: v[1],
            size: v[2],
            angle: v[3],
            response: v[4],
        });
    }
    for _ in 0..n {
        let d: Descriptor = r.take(DESCRIPTOR_LEN)?.try_into().ok()?;
        features.descriptors.push(d);
    }
    Some(Cached {
        size,
        scale,
        features,
    })
}

/// Write `c` under `key` to `file`, whole or not at all (`common::atomic::write_atomic`).
pub fn store(file: &Path, key: u64, c: &Cached) -> Result<(), common::atomic::Error> {
    let f = &c.features;
    write_whole(file, |w| {
        w.write_all(MAGIC)?;
        for v in [
            key,
            c.size.0 as u64,
            c.size.1 as u64,
            c.scale.to_bits(),
            f.keypoints.len() as u64,
        ] {
            w.write_all(&v.to_le_bytes())?;
        }
        for k in &f.keypoints {
            for v in [k.x, k.y, k.size, k.angle, k.response] {
                w.write_all(&v.to_bits().to_le_bytes())?;
            }
        }
        for d in &f.descriptors {
            w.write_all(d)?;
        }
        Ok(())
    })
}

/// Write `file` whole or not at all (`common::atomic::write_atomic`), its folder made first.
pub(crate) fn write_whole(
    file: &Path,
    body: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> Result<(), common::atomic::Error> {
    if let Some(dir) = file.parent() {
        std::fs::create_dir_all(dir).map_err(|cause| common::atomic::Error::Write {
            path: dir.to_path_buf(),
            cause,
        })?;
    }
    common::atomic::write_atomic(file, body)
}

/// Little-endian values read from the front of a byte slice; None past its end.
pub(crate) struct Reader<'a> {
    pub(crate) b: &'a [u8],
    pub(crate) at: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.b.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }

    pub(crate) fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }

    pub(crate) fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A JPEG's segments: SOI, the given (marker, payload) pairs, SOS and its data, EOI.
    fn jpeg(segments: &[(u8, &[u8])], scan: &[u8]) -> Vec<u8> {
        let mut b = vec![0xFF, 0xD8];
        for (m, payload) in segments {
            b.extend_from_slice(&[0xFF, *m]);
            b.extend_from_slice(&((payload.len() + 2) as u16).to_be_bytes());
            b.extend_from_slice(payload);
        }
        b.extend_from_slice(&[0xFF, 0xDA, 0x00, 0x02]);
        b.extend_from_slice(scan);
        b.extend_from_slice(&[0xFF, 0xD9]);
        b
    }

    #[test]
    fn a_photos_key_ignores_its_metadata_but_not_its_image_data() {
        let h = |b: &[u8]| image_data_hash(0xcbf2_9ce4_8422_2325, b);
        let tables: (u8, &[u8]) = (0xDB, b"quantisation");
        let a = jpeg(&[(0xE1, b"Exif model A"), tables], b"scan");
        // Another EXIF, an XMP packet and a comment added: the same key.
        let b = jpeg(
            &[
                (0xE1, b"Exif model B, geotagged"),
                (0xE1, b"xmp"),
                (0xFE, b"note"),
                tables,
            ],
            b"scan",
        );
        assert_eq!(h(&a), h(&b));
        // A preview appended after the image: the same key.
        let mut c = a.clone();
        c.extend_from_slice(&[0xFF, 0xD8, 1, 2, 3, 0xFF, 0xD9]);
        assert_eq!(h(&a), h(&c));
        // Other pixels, other tables or another colour transform (APP14): another key.
        assert_ne!(h(&a), h(&jpeg(&[(0xE1, b"Exif model A"), tables], b"scam")));
        assert_ne!(
            h(&a),
            h(&jpeg(&[(0xE1, b"Exif model A"), (0xDB, b"other")], b"scan"))
        );
        let adobe = jpeg(
            &[(0xE1, b"Exif model A"), (0xEE, b"Adobe"), tables],
            b"scan",
        );
        assert_ne!(h(&a), h(&adobe));
        // Not a JPEG, or segments that run past the end: the whole file.
        assert_eq!(h(b"PNG data"), fnv(0xcbf2_9ce4_8422_2325, b"PNG data"));
        let cut = &a[..8];
        assert_eq!(h(cut), fnv(0xcbf2_9ce4_8422_2325, cut));
    }

    #[test]
    fn features_come_back_bit_for_bit_and_a_changed_key_or_damage_is_refused() {
        let dir = testkit::scratch_path("feature-cache");
        let file = dir.join("a.jpg.feat");
        let mut features = Features::default();
        for i in 0..3 {
            features.keypoints.push(Keypoint {
                x: 0.1 + i as f64,
                y: std::f64::consts::PI * i as f64,
                size: 3.5,
                angle: -12.25,
                response: 1e-3 / 3.0,
            });
            features.descriptors.push([i as u8 * 7; DESCRIPTOR_LEN]);
        }
        let c = Cached {
            size: (4000, 2250),
            scale: 2.0,
            features,
        };
        store(&file, 42, &c).unwrap();
        let back = load(&file, 42).unwrap();
        assert_eq!(back.size, c.size);
        assert_eq!(back.scale.to_bits(), c.scale.to_bits());
        assert_eq!(back.features.keypoints, c.features.keypoints);
        assert_eq!(back.features.descriptors, c.features.descriptors);
        assert!(load(&file, 43).is_none(), "another key");
        let bytes = std::fs::read(&file).unwrap();
        std::fs::write(&file, &bytes[..bytes.len() - 1]).unwrap();
        assert!(load(&file, 42).is_none(), "a file cut short");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
