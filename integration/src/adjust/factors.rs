//! The GNSS projection-centre factor: the antenna observed by GNSS is the projection centre
//! plus the lever arm rotated by the camera attitude plus a drift,
//! `X_A,obs = X_S + R·(u, v, w) + a + b·(t − t0)`, weighted by the trajectory's full 3×3
//! covariance (the residual and Jacobians are whitened here, so the solver sees unit σ).

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use photo::rotation::skew;
use photo::solver::{Block, Factor};

/// Which drift terms a drift block holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DriftModel {
    /// a (3 parameters).
    Offset,
    /// a and b (6 parameters).
    Linear,
    /// b only (3 parameters): the drift is zero at t0.
    Rate,
}

impl DriftModel {
    pub fn dim(self) -> usize {
        match self {
            DriftModel::Linear => 6,
            _ => 3,
        }
    }
    /// The drift and its Jacobian with respect to the drift block at dt = t − t0.
    pub fn eval(self, p: &[f64], dt: f64) -> (Vector3<f64>, DMatrix<f64>) {
        let i = Matrix3::<f64>::identity();
        match self {
            DriftModel::Offset => (
                Vector3::new(p[0], p[1], p[2]),
                DMatrix::from_column_slice(3, 3, i.as_slice()),
            ),
            DriftModel::Rate => (
                Vector3::new(p[0], p[1], p[2]) * dt,
                DMatrix::from_column_slice(3, 3, (i * dt).as_slice()),
            ),
            DriftModel::Linear => {
                let mut j = DMatrix::zeros(3, 6);
                j.view_mut((0, 0), (3, 3)).copy_from(&i);
                j.view_mut((0, 3), (3, 3)).copy_from(&(i * dt));
                (
                    Vector3::new(p[0] + p[3] * dt, p[1] + p[4] * dt, p[2] + p[5] * dt),
                    j,
                )
            }
        }
    }
}

/// One GNSS antenna position at an exposure.
pub struct GnssCentre {
    /// [pose, lever arm] or [pose, lever arm, drift].
    blocks: Vec<usize>,
    antenna: Vector3<f64>,
    /// Inverse of the lower Cholesky factor of the covariance (whitening).
    whiten: Matrix3<f64>,
    /// The lower Cholesky factor itself: whitened residual → metres.
    unwhiten: Matrix3<f64>,
    drift: Option<(DriftModel, f64)>,
    ones: DVector<f64>,
    group: usize,
}

impl GnssCentre {
    /// `cov`: covariance of the antenna position in the adjustment frame, m². `None` when it
    /// is not positive definite.
    pub fn new(
        pose: usize,
        lever: usize,
        drift: Option<(usize, DriftModel, f64)>,
        antenna: Vector3<f64>,
        cov: &Matrix3<f64>,
        group: usize,
    ) -> Option<GnssCentre> {
        let l = cov.cholesky()?.l();
        let whiten = l.try_inverse()?;
        let mut blocks = vec![pose, lever];
        if let Some((b, _, _)) = drift {
            blocks.push(b);
        }
        Some(GnssCentre {
            blocks,
            antenna,
            whiten,
            unwhiten: l,
            drift: drift.map(|(_, m, dt)| (m, dt)),
            ones: DVector::from_element(3, 1.0),
            group,
        })
    }
}

impl GnssCentre {
    /// Maps the whitened residual back to predicted − observed antenna, metres.
    pub fn unwhiten(&self) -> Matrix3<f64> {
        self.unwhiten
    }
}

impl Factor for GnssCentre {
    fn blocks(&self) -> &[usize] {
        &self.blocks
    }
    fn evaluate(&self, b: &[&Block]) -> Option<(DVector<f64>, Vec<DMatrix<f64>>)> {
        let pose = b[0].pose()?;
        let l = b[1].vector()?;
        let rl = pose.r * Vector3::new(l[0], l[1], l[2]);
        let mut pred = pose.centre + rl;
        let mut jd = None;
        if let Some((model, dt)) = self.drift {
            let (d, j) = model.eval(b[2].vector()?.as_slice(), dt);
            pred += d;
            jd = Some(j);
        }
        let w = &self.whiten;
        let r = w * (pred - self.antenna);
        let mut jp = DMatrix::zeros(3, 6);
        jp.view_mut((0, 0), (3, 3)).copy_from(&(w * -skew(&rl)));
        jp.view_mut((0, 3), (3, 3)).copy_from(w);
        let wd = DMatrix::from_column_slice(3, 3, w.as_slice());
        let mut js = vec![
            jp,
            &wd * DMatrix::from_column_slice(3, 3, pose.r.as_slice()),
        ];
        if let Some(j) = jd {
            js.push(&wd * j);
        }
        Some((DVector::from_column_slice(r.as_slice()), js))
    }
    fn sigmas(&self) -> &DVector<f64> {
        &self.ones
    }
    fn group(&self) -> usize {
        self.group
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use photo::camera::Pose;
    use photo::rotation::{exp_so3, Angles};

    /// Analytic Jacobians against central differences, every block, every drift model.
    #[test]
    fn jacobians_match_finite_differences() {
        let pose = Pose {
            r: Angles::OmegaPhiKappa {
                omega: 0.03,
                phi: -0.02,
                kappa: 2.9,
            }
            .matrix(),
            centre: Vector3::new(10.0, -4.0, 1200.0),
        };
        let cov = Matrix3::new(25e-4, 5e-4, 7e-4, 5e-4, 25e-4, 2e-4, 7e-4, 2e-4, 36e-4);
        for model in [DriftModel::Offset, DriftModel::Linear, DriftModel::Rate] {
            let f = GnssCentre::new(
                0,
                1,
                Some((2, model, 37.5)),
                Vector3::new(10.2, -4.1, 1201.3),
                &cov,
                0,
            )
            .unwrap();
            let blocks = vec![
                Block::Pose(pose),
                Block::Vector(DVector::from_vec(vec![0.1, -0.05, 1.4])),
                Block::Vector(DVector::from_fn(model.dim(), |i, _| {
                    0.01 * (i as f64 + 1.0)
                })),
            ];
            let refs: Vec<&Block> = blocks.iter().collect();
            let (_, js) = f.evaluate(&refs).unwrap();
            for (bi, j) in js.iter().enumerate() {
                for c in 0..j.ncols() {
                    let h = 1e-6;
                    let shifted = |s: f64| {
                        let mut bl = blocks.clone();
                        match &mut bl[bi] {
                            Block::Pose(p) => {
                                if c < 3 {
                                    let mut d = Vector3::zeros();
                                    d[c] = s;
                                    p.r = exp_so3(&d) * p.r;
                                } else {
                                    p.centre[c - 3] += s;
                                }
                            }
                            Block::Vector(v) => v[c] += s,
                        }
                        let refs: Vec<&Block> = bl.iter().collect();
                        f.evaluate(&refs).unwrap().0
                    };
                    let num = (shifted(h) - shifted(-h)) / (2.0 * h);
                    assert!(
                        (&num - j.column(c)).norm() < 1e-5 * (1.0 + num.norm()),
                        "{model:?} block {bi} column {c}: {num} vs {}",
                        j.column(c)
                    );
                }
            }
        }
    }
}
