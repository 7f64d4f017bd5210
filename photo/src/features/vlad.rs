//! A global descriptor per image (VLAD, Jégou et al. 2010), so that photos without positions
//! are paired with the photos that look most alike instead of with every other: the work
//! then grows with the number of photos, not its square.
//!
//! The vocabulary is built from the block itself: k-means (Lloyd's iterations from evenly
//! chosen starting descriptors, so deterministic) over a sample of every image's strongest
//! descriptors. An image's VLAD sums, per word, the residuals of its descriptors assigned to
//! that word; each word's sum is normalised (intra-normalisation, so bursts of one texture do
//! not dominate), then the signed square root and the overall L2 norm. Two images are alike
//! as the dot product of their VLADs.

use super::{Descriptor, DESCRIPTOR_LEN};

/// How the vocabulary and the descriptors are made.
#[derive(Clone, Copy, Debug)]
pub struct VladOptions {
    /// Words of the vocabulary.
    pub words: usize,
    /// Descriptors per image taken into the vocabulary's sample.
    pub sample_per_image: usize,
    /// Lloyd iterations.
    pub iterations: usize,
}

impl Default for VladOptions {
    fn default() -> Self {
        VladOptions {
            words: 32,
            sample_per_image: 100,
            iterations: 12,
        }
    }
}

/// A vocabulary: `words` centres of 128 values.
#[derive(Clone, Debug)]
pub struct Vocabulary {
    centres: Vec<[f32; DESCRIPTOR_LEN]>,
}

fn to_f32(d: &Descriptor) -> [f32; DESCRIPTOR_LEN] {
    std::array::from_fn(|k| d[k] as f32)
}

fn dist2(a: &[f32; DESCRIPTOR_LEN], b: &[f32; DESCRIPTOR_LEN]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

impl Vocabulary {
    /// The vocabulary of `images` (each image's descriptors, strongest first or in any fixed
    /// order); None when there are fewer sampled descriptors than words.
    pub fn build(images: &[&[Descriptor]], o: &VladOptions) -> Option<Vocabulary> {
        let sample: Vec<[f32; DESCRIPTOR_LEN]> = images
            .iter()
            .flat_map(|d| {
                let step = (d.len() / o.sample_per_image.max(1)).max(1);
                d.iter().step_by(step).take(o.sample_per_image).map(to_f32)
            })
            .collect();
        if sample.len() < o.words.max(1) {
            return None;
        }
        let mut centres: Vec<[f32; DESCRIPTOR_LEN]> = (0..o.words)
            .map(|w| sample[w * sample.len() / o.words])
            .collect();
        let mut label = vec![0usize; sample.len()];
        for _ in 0..o.iterations {
            let v = Vocabulary { centres };
            for (l, s) in label.iter_mut().zip(&sample) {
                *l = v.word(s);
            }
            centres = v.centres;
            let mut sum = vec![[0f64; DESCRIPTOR_LEN]; o.words];
            let mut n = vec![0usize; o.words];
            for (l, s) in label.iter().zip(&sample) {
                n[*l] += 1;
                for (a, b) in sum[*l].iter_mut().zip(s) {
                    *a += *b as f64;
                }
            }
            for w in 0..o.words {
                // An empty word keeps its centre.
                if n[w] > 0 {
                    centres[w] = std::array::from_fn(|k| (sum[w][k] / n[w] as f64) as f32);
                }
            }
        }
        Some(Vocabulary { centres })
    }

    /// The nearest word of a descriptor (the first of equals).
    fn word(&self, d: &[f32; DESCRIPTOR_LEN]) -> usize {
        let mut best = (f32::INFINITY, 0);
        for (w, c) in self.centres.iter().enumerate() {
            let e = dist2(d, c);
            if e < best.0 {
                best = (e, w);
            }
        }
        best.1
    }

    /// The VLAD of an image's descriptors (unit length; zeros when it has none).
    pub fn vlad(&self, descriptors: &[Descriptor]) -> Vec<f32> {
        let k = self.centres.len();
        let mut v = vec![0f64; k * DESCRIPTOR_LEN];
        for d in descriptors {
            let x = to_f32(d);
            let w = self.word(&x);
            let c = &self.centres[w];
            for j in 0..DESCRIPTOR_LEN {
                v[w * DESCRIPTOR_LEN + j] += (x[j] - c[j]) as f64;
            }
        }
        for block in v.chunks_mut(DESCRIPTOR_LEN) {
            let n = block.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n > 0.0 {
                block.iter_mut().for_each(|x| *x /= n);
            }
        }
        v.iter_mut().for_each(|x| *x = x.signum() * x.abs().sqrt());
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.iter()
            .map(|x| if n > 0.0 { (x / n) as f32 } else { 0.0 })
            .collect()
    }
}

/// For each image, the `k` others whose VLADs are most alike (ties to the lower index).
pub fn most_alike(vlads: &[Vec<f32>], k: usize) -> Vec<Vec<usize>> {
    (0..vlads.len())
        .map(|i| {
            let mut s: Vec<(f32, usize)> = (0..vlads.len())
                .filter(|&j| j != i)
                .map(|j| {
                    let d: f32 = vlads[i].iter().zip(&vlads[j]).map(|(a, b)| a * b).sum();
                    (d, j)
                })
                .collect();
            s.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            s.into_iter().take(k).map(|(_, j)| j).collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small generator of pseudo-random numbers.
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> u32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 33) as u32
        }
        fn descriptor(&mut self) -> Descriptor {
            std::array::from_fn(|_| (self.next() % 120) as u8)
        }
    }

    /// A photo of a scene (its 300 features): 200 of them seen again with noise of ±3 grey
    /// levels, and 100 features of its own.
    fn photo(scene: &[Descriptor], rng: &mut Lcg) -> Vec<Descriptor> {
        let start = rng.next() as usize % 100;
        let mut v: Vec<Descriptor> = scene[start..start + 200]
            .iter()
            .map(|d| std::array::from_fn(|k| d[k] + (rng.next() % 7) as u8))
            .collect();
        v.extend((0..100).map(|_| rng.descriptor()));
        v
    }

    #[test]
    fn images_of_the_same_scene_are_most_alike() {
        // Six images: 0, 2, 4 of one scene, 1, 3, 5 of another.
        let mut rng = Lcg(7);
        let scenes: Vec<Vec<Descriptor>> = (0..2)
            .map(|_| (0..300).map(|_| rng.descriptor()).collect())
            .collect();
        let imgs: Vec<Vec<Descriptor>> = (0..6).map(|i| photo(&scenes[i % 2], &mut rng)).collect();
        let refs: Vec<&[Descriptor]> = imgs.iter().map(|v| v.as_slice()).collect();
        let voc = Vocabulary::build(&refs, &VladOptions::default()).unwrap();
        let vl: Vec<Vec<f32>> = imgs.iter().map(|d| voc.vlad(d)).collect();
        let near = most_alike(&vl, 2);
        for (i, n) in near.iter().enumerate() {
            assert!(n.iter().all(|j| j % 2 == i % 2), "{i}: {n:?}");
        }
        let unit: f32 = vl[0].iter().map(|x| x * x).sum();
        assert!((unit - 1.0).abs() < 1e-4);
    }
}
