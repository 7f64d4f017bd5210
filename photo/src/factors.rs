//! Observation factors of a photogrammetric block: image points and ground control.

use crate::camera::Camera;
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

/// A ground control point: the point block observed directly, σ per axis.
pub struct ControlPoint {
    pub blocks: [usize; 1],
    pub xyz: Vector3<f64>,
    pub sigmas: DVector<f64>,
    pub group: usize,
}

impl ControlPoint {
    pub fn new(point: usize, xyz: Vector3<f64>, sigma_xyz: [f64; 3], group: usize) -> Self {
        ControlPoint {
            blocks: [point],
            xyz,
            sigmas: DVector::from_column_slice(&sigma_xyz),
            group,
        }
    }
}

impl Factor for ControlPoint {
    fn blocks(&self) -> &[usize] {
        &self.blocks
    }
    fn evaluate(&self, b: &[&Block]) -> Option<(DVector<f64>, Vec<DMatrix<f64>>)> {
        let x = b[0].vector()?;
        let r = DVector::from_iterator(3, (0..3).map(|i| x[i] - self.xyz[i]));
        Some((r, vec![DMatrix::identity(3, 3)]))
    }
    fn sigmas(&self) -> &DVector<f64> {
        &self.sigmas
    }
    fn group(&self) -> usize {
        self.group
    }
}
