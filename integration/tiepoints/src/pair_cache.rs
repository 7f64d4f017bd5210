//! Pair matches kept on disk beside the project (`OUT/features/pairs.match`), so a rerun on
//! the same folder matches only the pairs it has not seen.
//!
//! Each pair is held under the feature keys of its two photos ([`super::cache::key`]: their
//! bytes and the extraction settings) and a key of the matching settings and the pair's
//! RANSAC seed, so a pair whose photos or settings changed is matched again. The seed is the
//! pair's places in the folder's name order, so a pair is reused where a fresh run would
//! match it the same: on a rerun, and for the photos before the first added by name.
//! (Seeding by the photos' names instead made one test block's free network end singular:
//! its start is sensitive to which matches RANSAC keeps, not yet understood.) Values are stored as their exact bits; the file is written
//! whole (`common::atomic::write_atomic`) and one that does not read back whole is ignored.

use super::cache::{fnv, write_whole, Reader};
use super::job::{MatchJob, PairResult, COHERENCE_NEIGHBOURS, GUIDED_RADIUS};
use photo::features::matching::Match;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// First bytes of a pair file.
const MAGIC: &[u8; 8] = b"PPKPAIR1";

/// Bumped whenever matching changes what it returns for the same features and settings.
const MATCHING_VERSION: u64 = 1;

/// Most pairs, and most matches of one pair, a file may declare (guards against damage).
const MAX_PAIRS: u64 = 50_000_000;
const MAX_MATCHES: u64 = 10_000_000;

/// A pair's key: the feature keys of its two photos and the matching settings' key.
pub type PairKey = (u64, u64, u64);

/// A pair's result as the cache holds it.
#[derive(Clone, Debug)]
pub struct Stored {
    putative: u64,
    f: Option<[u64; 9]>,
    verified: Vec<Match>,
}

impl Stored {
    /// The pair result of images `a` and `b`.
    pub fn result(&self, a: usize, b: usize) -> PairResult {
        PairResult {
            a,
            b,
            putative: self.putative as usize,
            verified: self.verified.clone(),
            f: self
                .f
                .map(|f| nalgebra::Matrix3::from_iterator(f.iter().map(|&x| f64::from_bits(x)))),
        }
    }
}

/// The key of the settings that shape a pair's matches, with its RANSAC `seed`.
pub fn settings(job: &MatchJob, seed: u64) -> u64 {
    [
        MATCHING_VERSION,
        seed,
        job.seed_features as u64,
        job.ratio.to_bits(),
        job.ransac_px.to_bits(),
        job.min_matches as u64,
        job.guided_ratio.to_bits(),
        GUIDED_RADIUS.to_bits(),
        COHERENCE_NEIGHBOURS as u64,
    ]
    .iter()
    .fold(0xcbf2_9ce4_8422_2325, |h, v| fnv(h, &v.to_le_bytes()))
}

/// The RANSAC seed of the pair of the images `a` and `b` (places in name order).
pub fn seed(a: usize, b: usize) -> u64 {
    (a as u64) << 32 | b as u64
}

/// The pair file of a cache folder.
pub fn path(dir: &Path) -> PathBuf {
    dir.join("pairs.match")
}

/// The pairs held in `file`; empty when it is absent or does not read back whole.
pub fn load(file: &Path) -> HashMap<PairKey, Stored> {
    let Ok(bytes) = std::fs::read(file) else {
        return HashMap::new();
    };
    read(&bytes).unwrap_or_default()
}

fn read(bytes: &[u8]) -> Option<HashMap<PairKey, Stored>> {
    let mut r = Reader { b: bytes, at: 0 };
    if r.take(8)? != MAGIC {
        return None;
    }
    let n = r.u64()?;
    if n > MAX_PAIRS {
        return None;
    }
    let mut out = HashMap::new();
    for _ in 0..n {
        let key = (r.u64()?, r.u64()?, r.u64()?);
        let putative = r.u64()?;
        let has_f = r.u64()?;
        let mut f = [0u64; 9];
        for x in &mut f {
            *x = r.u64()?;
        }
        let m = r.u64()?;
        if has_f > 1 || m > MAX_MATCHES || r.b.len() - r.at < m as usize * 8 {
            return None;
        }
        let verified = (0..m)
            .map(|_| Some((r.u32()?, r.u32()?)))
            .collect::<Option<Vec<Match>>>()?;
        let f = (has_f == 1).then_some(f);
        out.insert(
            key,
            Stored {
                putative,
                f,
                verified,
            },
        );
    }
    (r.at == r.b.len()).then_some(out)
}

/// Write the pairs `results` under their keys to `file`, whole or not at all.
pub fn store<'a>(
    file: &Path,
    results: impl Iterator<Item = (PairKey, &'a PairResult)>,
) -> Result<(), common::atomic::Error> {
    let results: Vec<(PairKey, &PairResult)> = results.collect();
    write_whole(file, |w| {
        w.write_all(MAGIC)?;
        w.write_all(&(results.len() as u64).to_le_bytes())?;
        for ((ka, kb, ks), p) in &results {
            let f: [u64; 9] = match p.f {
                Some(f) => std::array::from_fn(|i| f.as_slice()[i].to_bits()),
                None => [0; 9],
            };
            for v in [*ka, *kb, *ks, p.putative as u64, p.f.is_some() as u64]
                .into_iter()
                .chain(f)
                .chain([p.verified.len() as u64])
            {
                w.write_all(&v.to_le_bytes())?;
            }
            for &(i, j) in &p.verified {
                w.write_all(&i.to_le_bytes())?;
                w.write_all(&j.to_le_bytes())?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_come_back_bit_for_bit_and_damage_is_refused() {
        let dir = testkit::scratch_path("pair-cache");
        let file = path(&dir);
        let f = nalgebra::Matrix3::new(0.1, -0.2, 1.0 / 3.0, 4.0, 5e-9, 6.0, 7.0, 8.0, 9.0);
        let verified = PairResult {
            a: 0,
            b: 1,
            putative: 40,
            verified: vec![(1, 2), (7, 3)],
            f: Some(f),
        };
        let failed = PairResult {
            a: 0,
            b: 2,
            putative: 3,
            verified: Vec::new(),
            f: None,
        };
        store(
            &file,
            [((1, 2, 9), &verified), ((1, 3, 9), &failed)].into_iter(),
        )
        .unwrap();
        let back = load(&file);
        assert_eq!(back.len(), 2);
        let v = back[&(1, 2, 9)].result(5, 6);
        assert_eq!((v.a, v.b, v.putative), (5, 6, 40));
        assert_eq!(v.verified, verified.verified);
        let fb = v.f.unwrap();
        assert!(fb
            .iter()
            .zip(f.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits()));
        let w = back[&(1, 3, 9)].result(0, 2);
        assert!(w.f.is_none() && w.verified.is_empty() && w.putative == 3);
        let bytes = std::fs::read(&file).unwrap();
        std::fs::write(&file, &bytes[..bytes.len() - 1]).unwrap();
        assert!(load(&file).is_empty(), "a file cut short");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
