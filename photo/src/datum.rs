//! The datum of a free network: inner constraints over the image centres. Seven (or, with the
//! scale known from measured distances, six) condition equations keep the centres' mean, their
//! rotation about their centroid and their scale where the start values put them, in the
//! least-squares sense (the minimum-norm solution over the centres): written as one factor
//! with a tight σ, so the solver needs no special datum handling, image residuals and data
//! snooping are those of the free network, and the centres' σ are relative to their
//! centroid.
//!
//! What enters: the pose blocks and their start centres. What leaves: a [`Factor`] whose
//! residual is the translation, rotation and scale of the centres away from the start.

use crate::lsq::{Factor, ImageId, Key, Noise, Params};

/// σ of the inner constraints: they hold to the solver's precision (metres for the shift,
/// radians and parts for rotation and scale).
pub const SIGMA: f64 = 1e-6;
use nalgebra::{DMatrixViewMut, Vector3};

/// Inner constraints over image centres: r = (mean shift, Σ dᵢ × δᵢ / S, Σ dᵢ · δᵢ / S) with
/// dᵢ the start centre about the centroid, δᵢ the centre's change and S = Σ |dᵢ|².
#[derive(Clone, Debug)]
pub struct InnerConstraints {
    keys: Vec<Key>,
    start: Vec<Vector3<f64>>,
    centroid: Vector3<f64>,
    spread: f64,
    /// Whether the scale row is included (false: distances give the scale).
    pub scale: bool,
}

impl InnerConstraints {
    /// The constraints over `images` whose start centres are `start` (same order); `None`
    /// with fewer than two images or all at one place.
    pub fn new(images: &[ImageId], start: &[Vector3<f64>], scale: bool) -> Option<Self> {
        if images.len() < 2 || images.len() != start.len() {
            return None;
        }
        let centroid = start.iter().sum::<Vector3<f64>>() / start.len() as f64;
        let spread: f64 = start.iter().map(|c| (c - centroid).norm_squared()).sum();
        (spread > 0.0).then(|| InnerConstraints {
            keys: images.iter().map(|&i| Key::Pose(i)).collect(),
            start: start.to_vec(),
            centroid,
            spread,
            scale,
        })
    }
}

impl InnerConstraints {
    /// The noise model that makes the constraints hold ([`SIGMA`] on every row).
    pub fn noise(&self) -> Noise {
        Noise::isotropic(self.dim(), SIGMA)
    }
}

impl Factor for InnerConstraints {
    crate::keys_in_field!();
    fn dim(&self) -> usize {
        if self.scale {
            7
        } else {
            6
        }
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let n = self.start.len() as f64;
        r.fill(0.0);
        for (k, c0) in self.start.iter().enumerate() {
            let Some(pose) = x.pose(k) else {
                return false;
            };
            let (d, delta) = (c0 - self.centroid, pose.centre - c0);
            let rot = d.cross(&delta) / self.spread;
            for a in 0..3 {
                r[a] += delta[a] / n;
                r[3 + a] += rot[a];
            }
            if self.scale {
                r[6] += d.dot(&delta) / self.spread;
            }
            if let Some(m) = &mut j[k] {
                // The pose's tangent: rotation (0..3), centre (3..6).
                m.fill(0.0);
                for a in 0..3 {
                    m[(a, 3 + a)] = 1.0 / n;
                }
                // ∂(d × δ)/∂δ = [d]×.
                let s = 1.0 / self.spread;
                m[(3, 4)] = -d.z * s;
                m[(3, 5)] = d.y * s;
                m[(4, 3)] = d.z * s;
                m[(4, 5)] = -d.x * s;
                m[(5, 3)] = -d.y * s;
                m[(5, 4)] = d.x * s;
                if self.scale {
                    for a in 0..3 {
                        m[(6, 3 + a)] = d[a] * s;
                    }
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Pose;
    use crate::lsq::Value;
    use nalgebra::Matrix3;

    /// Zero at the start; a shift, a rotation about the centroid and a scale each show in
    /// their own rows; the Jacobian matches finite differences.
    #[test]
    fn residuals_and_jacobian() {
        let start = [
            Vector3::new(0.0, 0.0, 100.0),
            Vector3::new(50.0, 0.0, 101.0),
            Vector3::new(0.0, 40.0, 99.0),
        ];
        let ids: Vec<ImageId> = (0..3).map(ImageId).collect();
        let f = InnerConstraints::new(&ids, &start, true).unwrap();
        let poses = |centres: &[Vector3<f64>]| -> Vec<Value> {
            centres
                .iter()
                .map(|c| {
                    Value::Pose(Pose {
                        r: Matrix3::identity(),
                        centre: *c,
                    })
                })
                .collect()
        };
        let eval = |centres: &[Vector3<f64>]| {
            let vals = poses(centres);
            let mut r = vec![0.0; 7];
            assert!(f.evaluate(&Params::in_order(&vals), &mut r, &mut [None, None, None]));
            r
        };
        assert!(eval(&start).iter().all(|v| v.abs() < 1e-15));
        let shifted: Vec<_> = start
            .iter()
            .map(|c| c + Vector3::new(1.0, 0.0, 0.0))
            .collect();
        let r = eval(&shifted);
        assert!(
            (r[0] - 1.0).abs() < 1e-12 && r[3..].iter().all(|v| v.abs() < 1e-12),
            "{r:?}"
        );
        let c = start.iter().sum::<Vector3<f64>>() / 3.0;
        let scaled: Vec<_> = start.iter().map(|x| c + (x - c) * 1.01).collect();
        let r = eval(&scaled);
        assert!(
            (r[6] - 0.01).abs() < 1e-12 && r[..6].iter().all(|v| v.abs() < 1e-12),
            "{r:?}"
        );
        // Finite differences of the centre columns of image 1.
        let vals = poses(&start);
        let mut jm = nalgebra::DMatrix::zeros(7, 6);
        let mut r0 = vec![0.0; 7];
        {
            let mut js = [None, Some(jm.view_mut((0, 0), (7, 6))), None];
            f.evaluate(&Params::in_order(&vals), &mut r0, &mut js);
        }
        for a in 0..3 {
            let mut moved = start;
            moved[1][a] += 1e-6;
            let r1 = eval(&moved);
            for row in 0..7 {
                let fd = (r1[row] - r0[row]) / 1e-6;
                assert!((fd - jm[(row, 3 + a)]).abs() < 1e-6, "row {row} axis {a}");
            }
        }
    }
}
