//! The GNSS projection-centre factor: the antenna observed by GNSS is the projection centre
//! plus the lever arm rotated by the camera attitude plus a drift,
//! `X_A,obs = X_S + R·(u, v, w) + a + b·(t − t0)`; r = predicted − observed antenna (metres,
//! adjustment frame), weighted by the trajectory's full 3×3 covariance (its noise model).
//! With a latency δ (see `super::latency`) the observed antenna is moved along its velocity
//! v to the exposure: r = X_S + R·(u, v, w) + drift − (X_A,obs + v·δ).

use nalgebra::{DMatrix, DMatrixViewMut, Matrix3, Vector3};
use photo::lever::LeverArm;
use photo::lsq::{CameraId, DriftId, Factor, ImageId, Key, LatencyId, Params};
use photo::rotation::skew;

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
    /// Number of parameters.
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
    keys: Vec<Key>,
    /// The observed antenna position (adjustment frame).
    pub antenna: Vector3<f64>,
    drift: Option<(DriftModel, f64)>,
    /// The antenna record it comes from (index into the project's antennas).
    pub record: usize,
    /// With a latency: the index of its key and the antenna velocity (adjustment frame, m/s).
    latency: Option<(usize, Vector3<f64>)>,
}

impl GnssCentre {
    /// The antenna of `image` (camera `camera`) observed at `antenna`; with a drift group, its
    /// model and the time since the group's t0 (s).
    pub fn new(
        image: ImageId,
        camera: CameraId,
        drift: Option<(DriftId, DriftModel, f64)>,
        antenna: Vector3<f64>,
        record: usize,
    ) -> GnssCentre {
        let mut keys = vec![Key::Pose(image), Key::LeverArm(camera)];
        if let Some((d, _, _)) = drift {
            keys.push(Key::Drift(d));
        }
        GnssCentre {
            keys,
            antenna,
            drift: drift.map(|(_, m, dt)| (m, dt)),
            record,
            latency: None,
        }
    }

    /// The same factor with the latency of group `l`, the antenna moving at `velocity`
    /// (adjustment frame, m/s): its last key is `Latency(l)`.
    pub fn with_latency(mut self, l: LatencyId, velocity: Vector3<f64>) -> GnssCentre {
        self.latency = Some((self.keys.len(), velocity));
        self.keys.push(Key::Latency(l));
        self
    }

    /// The image whose projection centre it observes.
    pub fn image(&self) -> ImageId {
        match self.keys[0] {
            Key::Pose(i) => i,
            _ => unreachable!("the first key is the pose"),
        }
    }
}

impl Factor for GnssCentre {
    photo::keys_in_field!();
    fn dim(&self) -> usize {
        3
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let (Some(pose), Some(l)) = (x.pose(0), x.point(1)) else {
            return false;
        };
        let rl = LeverArm::new(l).offset(&pose.r);
        let mut pred = pose.centre + rl;
        let mut jd = None;
        if let Some((model, dt)) = self.drift {
            let Some(d) = x.vector(2) else { return false };
            let (v, jac) = model.eval(d.as_slice(), dt);
            pred += v;
            jd = Some(jac);
        }
        let mut observed = self.antenna;
        if let Some((k, v)) = self.latency {
            let Some(d) = x.vector(k) else { return false };
            observed += v * d[0];
            if let Some(Some(m)) = j.get_mut(k) {
                m.copy_from(&(-v));
            }
        }
        r.copy_from_slice((pred - observed).as_slice());
        if let Some(m) = &mut j[0] {
            m.view_mut((0, 0), (3, 3)).copy_from(&(-skew(&rl)));
            m.view_mut((0, 3), (3, 3)).copy_from(&Matrix3::identity());
        }
        if let Some(m) = &mut j[1] {
            m.copy_from(&pose.r);
        }
        if let (Some(Some(m)), Some(jd)) = (j.get_mut(2), jd) {
            m.copy_from(&jd);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use photo::camera::Pose;
    use photo::lsq::Value;
    use photo::rotation::{exp_so3, Angles};

    /// Evaluate with every Jacobian.
    fn eval(f: &GnssCentre, v: &[Value]) -> (Vec<f64>, Vec<DMatrix<f64>>) {
        let mut r = vec![0.0; 3];
        let mut js: Vec<DMatrix<f64>> = v.iter().map(|b| DMatrix::zeros(3, b.dim())).collect();
        let mut views: Vec<Option<DMatrixViewMut<f64>>> =
            js.iter_mut().map(|m| Some(m.as_view_mut())).collect();
        assert!(f.evaluate(&Params::in_order(v), &mut r, &mut views));
        drop(views);
        (r, js)
    }

    /// Analytic Jacobians against central differences, every block (latency included), every
    /// drift model.
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
        for model in [DriftModel::Offset, DriftModel::Linear, DriftModel::Rate] {
            let f = GnssCentre::new(
                ImageId(0),
                CameraId(0),
                Some((DriftId(0), model, 37.5)),
                Vector3::new(10.2, -4.1, 1201.3),
                0,
            )
            .with_latency(LatencyId(0), Vector3::new(-61.0, 4.5, 0.3));
            let blocks = vec![
                Value::Pose(pose),
                Value::Vector(nalgebra::DVector::from_vec(vec![0.1, -0.05, 1.4])),
                Value::Vector(nalgebra::DVector::from_fn(model.dim(), |i, _| {
                    0.01 * (i as f64 + 1.0)
                })),
                Value::Vector(nalgebra::DVector::from_element(1, 0.8)),
            ];
            let (_, js) = eval(&f, &blocks);
            for (bi, j) in js.iter().enumerate() {
                for c in 0..j.ncols() {
                    let h = 1e-6;
                    let shifted = |s: f64| {
                        let mut bl = blocks.clone();
                        match &mut bl[bi] {
                            Value::Pose(p) => {
                                if c < 3 {
                                    let mut d = Vector3::zeros();
                                    d[c] = s;
                                    p.r = exp_so3(&d) * p.r;
                                } else {
                                    p.centre[c - 3] += s;
                                }
                            }
                            Value::Vector(v) => v[c] += s,
                            Value::Rotated { .. } => unreachable!(),
                        }
                        nalgebra::DVector::from_vec(eval(&f, &bl).0)
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
