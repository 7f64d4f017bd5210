//! Observation factors of a photogrammetric block on [`crate::lsq`]: image points (with or
//! without self-calibration), direct observations of a block (ground control, priors) and
//! distances between two points. Each keeps its own bookkeeping: its keys say which image,
//! point or camera it observes, `source` where the observation came from (file:line).

use crate::camera::{Camera, N_INTERIOR};
use crate::lsq::{CameraId, Factor, ImageId, Key, Params, PointId};
use nalgebra::{DMatrixViewMut, DVector, Vector2, Vector3};

/// An image measurement of an object point: r = projected − measured (image coordinates,
/// metres). With self-calibration, the interior parameters listed in `calib` (indices into f,
/// x0, y0, k1, k2, k3, p1, p2, b1, b2) form a third block, shared by every image of the camera;
/// the others stay at the camera's values.
#[derive(Clone, Debug)]
pub struct ImagePoint {
    /// The camera's interior orientation (start values when self-calibrating).
    pub camera: Camera,
    keys: Vec<Key>,
    /// Interior parameters estimated (empty: none).
    pub calib: Vec<usize>,
    /// Measured image coordinates.
    pub xy: Vector2<f64>,
    /// Where the measurement came from (file:line), empty when not known.
    pub source: String,
}

impl ImagePoint {
    /// A measurement `xy` of `point` in `image`, interior orientation fixed.
    pub fn new(camera: Camera, image: ImageId, point: PointId, xy: Vector2<f64>) -> Self {
        ImagePoint {
            camera,
            keys: vec![Key::Pose(image), Key::Point(point)],
            calib: Vec::new(),
            xy,
            source: String::new(),
        }
    }

    /// The same with the interior parameters `calib` estimated in block `Key::Camera(cam)`.
    pub fn self_calibrating(
        camera: Camera,
        image: ImageId,
        point: PointId,
        cam: CameraId,
        calib: Vec<usize>,
        xy: Vector2<f64>,
    ) -> Self {
        let mut f = ImagePoint::new(camera, image, point, xy);
        if !calib.is_empty() {
            f.keys.push(Key::Camera(cam));
            f.calib = calib;
        }
        f
    }

    /// With its source (file:line).
    pub fn with_source(mut self, source: String) -> Self {
        self.source = source;
        self
    }

    /// The image measured.
    pub fn image(&self) -> ImageId {
        match self.keys[0] {
            Key::Pose(i) => i,
            _ => unreachable!("the first key is the pose"),
        }
    }

    /// The point measured.
    pub fn point(&self) -> PointId {
        match self.keys[1] {
            Key::Point(p) => p,
            _ => unreachable!("the second key is the point"),
        }
    }

    /// The interior block's start values for a camera and a parameter selection.
    pub fn interior_start(camera: &Camera, calib: &[usize]) -> DVector<f64> {
        let all = camera.interior();
        DVector::from_iterator(calib.len(), calib.iter().map(|&i| all[i]))
    }
}

impl Factor for ImagePoint {
    crate::keys_in_field!();
    fn dim(&self) -> usize {
        2
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let (Some(pose), Some(pt)) = (x.pose(0), x.point(1)) else {
            return false;
        };
        let cam = if self.calib.is_empty() {
            self.camera
        } else {
            let Some(iv) = x.vector(2) else { return false };
            let mut all: [f64; N_INTERIOR] = self.camera.interior();
            for (k, &i) in self.calib.iter().enumerate() {
                all[i] = iv[k];
            }
            self.camera.with_interior(&all)
        };
        let Some((p, jac)) = cam.project_with_jacobians(pose, &pt) else {
            return false;
        };
        r.copy_from_slice((p - self.xy).as_slice());
        if let Some(m) = &mut j[0] {
            m.copy_from(&jac.pose);
        }
        if let Some(m) = &mut j[1] {
            m.copy_from(&jac.point);
        }
        if let Some(Some(m)) = j.get_mut(2) {
            for (c, &i) in self.calib.iter().enumerate() {
                m.set_column(c, &jac.interior.column(i));
            }
        }
        true
    }
}

/// A direct observation of a vector block: r = x − value (a ground control point, a measured
/// lever arm, any prior).
#[derive(Clone, Debug)]
pub struct Prior {
    keys: [Key; 1],
    /// The observed value.
    pub value: DVector<f64>,
    /// The components observed, in residual order (empty: all).
    axes: Vec<usize>,
    /// Where the observation came from, empty when not known.
    pub source: String,
}

impl Prior {
    /// Block `key` observed as `value`.
    pub fn new(key: Key, value: DVector<f64>) -> Prior {
        Prior {
            keys: [key],
            value,
            axes: Vec::new(),
            source: String::new(),
        }
    }

    /// Observing only the components `axes` of the block (e.g. [0, 1]: a planimetric
    /// control point, \[2\]: a height); the residual has one row per axis, in that order.
    pub fn on_axes(mut self, axes: &[usize]) -> Self {
        self.axes = axes.to_vec();
        self
    }

    /// The components observed, in residual order.
    pub fn axes(&self) -> Vec<usize> {
        if self.axes.is_empty() {
            (0..self.value.len()).collect()
        } else {
            self.axes.clone()
        }
    }

    /// A ground control point: the point block observed.
    pub fn point(point: PointId, xyz: Vector3<f64>) -> Prior {
        Prior::new(
            Key::Point(point),
            DVector::from_column_slice(xyz.as_slice()),
        )
    }

    /// With its source (file:line).
    pub fn with_source(mut self, source: String) -> Self {
        self.source = source;
        self
    }

    /// The block observed.
    pub fn key(&self) -> Key {
        self.keys[0]
    }
}

impl Factor for Prior {
    crate::keys_in_field!();
    fn dim(&self) -> usize {
        if self.axes.is_empty() {
            self.value.len()
        } else {
            self.axes.len()
        }
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let Some(v) = x.vector(0).filter(|v| v.len() == self.value.len()) else {
            return false;
        };
        if self.axes.is_empty() {
            for (i, ri) in r.iter_mut().enumerate() {
                *ri = v[i] - self.value[i];
            }
            if let Some(m) = &mut j[0] {
                m.fill_with_identity();
            }
            return true;
        }
        for (i, &a) in self.axes.iter().enumerate() {
            r[i] = v[a] - self.value[a];
        }
        if let Some(m) = &mut j[0] {
            m.fill(0.0);
            for (i, &a) in self.axes.iter().enumerate() {
                m[(i, a)] = 1.0;
            }
        }
        true
    }
}

/// A measured distance between two points: r = ‖a − b‖ − d.
#[derive(Clone, Debug)]
pub struct Distance {
    keys: [Key; 2],
    /// The measured distance (metres).
    pub distance: f64,
    /// Where the measurement came from, empty when not known.
    pub source: String,
}

impl Distance {
    /// The distance `d` between points `a` and `b`.
    pub fn new(a: PointId, b: PointId, d: f64) -> Distance {
        Distance {
            keys: [Key::Point(a), Key::Point(b)],
            distance: d,
            source: String::new(),
        }
    }

    /// With its source (file:line).
    pub fn with_source(mut self, source: String) -> Self {
        self.source = source;
        self
    }

    /// The two points.
    pub fn points(&self) -> [Key; 2] {
        self.keys
    }
}

impl Factor for Distance {
    crate::keys_in_field!();
    fn dim(&self) -> usize {
        1
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let (Some(a), Some(b)) = (x.point(0), x.point(1)) else {
            return false;
        };
        let d = a - b;
        let n = d.norm();
        if n == 0.0 {
            return false;
        }
        r[0] = n - self.distance;
        let u = d / n;
        if let Some(m) = &mut j[0] {
            m.copy_from(&u.transpose());
        }
        if let Some(m) = &mut j[1] {
            m.copy_from(&(-u.transpose()));
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lsq::Value;

    /// Every analytic Jacobian of the distance factor against central differences.
    #[test]
    fn distance_jacobians_match_finite_differences() {
        let f = Distance::new(PointId(0), PointId(1), 10.0);
        let a = Vector3::new(3.0, -1.0, 2.0);
        let b = Vector3::new(-4.0, 2.5, 0.5);
        let eval = |a: &Vector3<f64>, b: &Vector3<f64>| {
            let v = [Value::point(a), Value::point(b)];
            let mut r = [0.0];
            let mut j = [
                Some(nalgebra::DMatrix::zeros(1, 3)),
                Some(nalgebra::DMatrix::zeros(1, 3)),
            ];
            let mut views: Vec<Option<DMatrixViewMut<f64>>> = j
                .iter_mut()
                .map(|m| m.as_mut().map(|m| m.as_view_mut()))
                .collect();
            assert!(f.evaluate(&Params::in_order(&v), &mut r, &mut views));
            drop(views);
            (r[0], j)
        };
        let (r0, j) = eval(&a, &b);
        assert!((r0 - ((a - b).norm() - 10.0)).abs() < 1e-12);
        let h = 1e-6;
        for k in 0..3 {
            let e = Vector3::ith(k, h);
            let na = (eval(&(a + e), &b).0 - eval(&(a - e), &b).0) / (2.0 * h);
            let nb = (eval(&a, &(b + e)).0 - eval(&a, &(b - e)).0) / (2.0 * h);
            let (ja, jb) = (j[0].as_ref().unwrap(), j[1].as_ref().unwrap());
            assert!((na - ja[(0, k)]).abs() < 1e-8, "a {k}");
            assert!((nb - jb[(0, k)]).abs() < 1e-8, "b {k}");
        }
    }
}
