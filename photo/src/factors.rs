//! Observation factors of a photogrammetric block: image points (with or without
//! self-calibration) and direct observations of a block (ground control, priors).

use crate::camera::{Camera, N_INTERIOR};
use crate::solver::{Block, Factor};
use nalgebra::{DMatrix, DVector, Vector2, Vector3};

/// An image measurement of an object point by a camera at a pose (interior fixed).
pub struct ImagePoint {
    pub camera: Camera,
    /// [pose block, point block]
    pub blocks: [usize; 2],
    pub xy: Vector2<f64>,
    pub sigmas: DVector<f64>,
    pub group: usize,
}

impl ImagePoint {
    pub fn new(
        camera: Camera,
        pose: usize,
        point: usize,
        xy: Vector2<f64>,
        sigma: f64,
        group: usize,
    ) -> Self {
        ImagePoint {
            camera,
            blocks: [pose, point],
            xy,
            sigmas: DVector::from_element(2, sigma),
            group,
        }
    }
}

impl Factor for ImagePoint {
    fn blocks(&self) -> &[usize] {
        &self.blocks
    }
    fn evaluate(&self, b: &[&Block]) -> Option<(DVector<f64>, Vec<DMatrix<f64>>)> {
        let pose = b[0].pose()?;
        let x = b[1].vector()?;
        let (p, j) = self
            .camera
            .project_with_jacobians(pose, &Vector3::new(x[0], x[1], x[2]))?;
        let r = DVector::from_column_slice((p - self.xy).as_slice());
        Some((
            r,
            vec![
                DMatrix::from_column_slice(2, 6, j.pose.as_slice()),
                DMatrix::from_column_slice(2, 3, j.point.as_slice()),
            ],
        ))
    }
    fn sigmas(&self) -> &DVector<f64> {
        &self.sigmas
    }
    fn group(&self) -> usize {
        self.group
    }
}

/// A direct observation of a vector block, σ per component: a ground control point (the
/// point block observed), a measured lever arm, any prior.
pub struct Prior {
    blocks: [usize; 1],
    value: DVector<f64>,
    sigmas: DVector<f64>,
    group: usize,
}

impl Prior {
    pub fn new(block: usize, value: DVector<f64>, sigmas: DVector<f64>, group: usize) -> Prior {
        Prior {
            blocks: [block],
            value,
            sigmas,
            group,
        }
    }

    /// A ground control point: the point block observed with σ per axis.
    pub fn point(point: usize, xyz: Vector3<f64>, sigma_xyz: [f64; 3], group: usize) -> Prior {
        Prior::new(
            point,
            DVector::from_column_slice(xyz.as_slice()),
            DVector::from_column_slice(&sigma_xyz),
            group,
        )
    }
}

impl Factor for Prior {
    fn blocks(&self) -> &[usize] {
        &self.blocks
    }
    fn evaluate(&self, b: &[&Block]) -> Option<(DVector<f64>, Vec<DMatrix<f64>>)> {
        let x = b[0].vector()?;
        let n = self.value.len();
        Some((x - &self.value, vec![DMatrix::identity(n, n)]))
    }
    fn sigmas(&self) -> &DVector<f64> {
        &self.sigmas
    }
    fn group(&self) -> usize {
        self.group
    }
}

/// An image measurement with self-calibration: the interior parameters listed in `calib`
/// (indices into f, x0, y0, k1, k2, k3, p1, p2, b1, b2) form a third block shared by every
/// image of the camera; the others stay at the camera's values.
pub struct SelfCalibratingPoint {
    pub camera: Camera,
    /// [pose block, point block, interior block]
    pub blocks: [usize; 3],
    pub calib: Vec<usize>,
    pub xy: Vector2<f64>,
    pub sigmas: DVector<f64>,
    pub group: usize,
}

impl SelfCalibratingPoint {
    /// The interior block's start values for a camera and a parameter selection.
    pub fn start(camera: &Camera, calib: &[usize]) -> DVector<f64> {
        let all = camera.interior();
        DVector::from_iterator(calib.len(), calib.iter().map(|&i| all[i]))
    }
}

impl Factor for SelfCalibratingPoint {
    fn blocks(&self) -> &[usize] {
        &self.blocks
    }
    fn evaluate(&self, b: &[&Block]) -> Option<(DVector<f64>, Vec<DMatrix<f64>>)> {
        let pose = b[0].pose()?;
        let x = b[1].vector()?;
        let iv = b[2].vector()?;
        let mut all: [f64; N_INTERIOR] = self.camera.interior();
        for (k, &i) in self.calib.iter().enumerate() {
            all[i] = iv[k];
        }
        let cam = self.camera.with_interior(&all);
        let (p, j) = cam.project_with_jacobians(pose, &Vector3::new(x[0], x[1], x[2]))?;
        let r = DVector::from_column_slice((p - self.xy).as_slice());
        let ji = DMatrix::from_fn(2, self.calib.len(), |r, c| j.interior[(r, self.calib[c])]);
        Some((
            r,
            vec![
                DMatrix::from_column_slice(2, 6, j.pose.as_slice()),
                DMatrix::from_column_slice(2, 3, j.point.as_slice()),
                ji,
            ],
        ))
    }
    fn sigmas(&self) -> &DVector<f64> {
        &self.sigmas
    }
    fn group(&self) -> usize {
        self.group
    }
}
