//! Parameter block values and how a solver step updates them (the manifold).
//!
//! A step δ is applied as `x ⊞ δ`: vectors add; a rotation R is updated by a left perturbation
//! `R ← exp([δ₀ δ₁ δ₂]×)·R` and the vector part after it adds (a pose: rotation, then the
//! projection centre; a BAL camera: rotation, then translation, f, k1, k2).

use crate::camera::Pose;
use crate::rotation::exp_so3;
use nalgebra::{DVector, Matrix3, Vector3};
use std::hash::{Hash, Hasher};

/// The value of one parameter block.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// Any vector (object point, interior parameters, lever arm, drift …).
    Vector(DVector<f64>),
    /// Exterior orientation: rotation camera → object and projection centre (6 unknowns).
    Pose(Pose),
    /// A rotation followed by a vector (3 + n unknowns), e.g. a BAL camera.
    Rotated {
        /// The rotation.
        r: Matrix3<f64>,
        /// The vector part.
        v: DVector<f64>,
    },
}

impl Value {
    /// A 3-vector block (an object point).
    pub fn point(x: &Vector3<f64>) -> Value {
        Value::Vector(DVector::from_column_slice(x.as_slice()))
    }

    /// Number of unknowns (the tangent-space dimension).
    pub fn dim(&self) -> usize {
        match self {
            Value::Vector(v) => v.len(),
            Value::Pose(_) => 6,
            Value::Rotated { v, .. } => 3 + v.len(),
        }
    }

    /// The vector, when this is a vector block.
    pub fn vector(&self) -> Option<&DVector<f64>> {
        match self {
            Value::Vector(v) => Some(v),
            _ => None,
        }
    }

    /// The first three components of a vector block as a point.
    pub fn as_point(&self) -> Option<Vector3<f64>> {
        self.vector()
            .filter(|v| v.len() >= 3)
            .map(|v| Vector3::new(v[0], v[1], v[2]))
    }

    /// The pose, when this is a pose block.
    pub fn pose(&self) -> Option<&Pose> {
        match self {
            Value::Pose(p) => Some(p),
            _ => None,
        }
    }

    /// Rotation and vector part, when this is a rotated block.
    pub fn rotated(&self) -> Option<(&Matrix3<f64>, &DVector<f64>)> {
        match self {
            Value::Rotated { r, v } => Some((r, v)),
            _ => None,
        }
    }

    /// Apply a step: `self ← self ⊞ d` (`d.len() == self.dim()`).
    pub fn plus(&mut self, d: &[f64]) {
        let rot = |r: &mut Matrix3<f64>| *r = exp_so3(&Vector3::new(d[0], d[1], d[2])) * *r;
        match self {
            Value::Vector(v) => v.iter_mut().zip(d).for_each(|(x, dx)| *x += dx),
            Value::Pose(p) => {
                rot(&mut p.r);
                p.centre += Vector3::new(d[3], d[4], d[5]);
            }
            Value::Rotated { r, v } => {
                rot(r);
                v.iter_mut().zip(&d[3..]).for_each(|(x, dx)| *x += dx);
            }
        }
    }

    /// Become a copy of `other`, reusing this value's storage when the shapes agree.
    pub(crate) fn assign(&mut self, other: &Value) {
        match (self, other) {
            (Value::Vector(a), Value::Vector(b)) if a.len() == b.len() => a.copy_from(b),
            (Value::Pose(a), Value::Pose(b)) => *a = *b,
            (Value::Rotated { r, v }, Value::Rotated { r: rb, v: vb }) if v.len() == vb.len() => {
                *r = *rb;
                v.copy_from(vb);
            }
            (s, o) => *s = o.clone(),
        }
    }

    /// Feed the exact bits of the value to a hasher (cache keys).
    pub(crate) fn hash_bits<H: Hasher>(&self, h: &mut H) {
        let bits = |it: &mut dyn Iterator<Item = &f64>, h: &mut H| {
            it.for_each(|x| x.to_bits().hash(h));
        };
        match self {
            Value::Vector(v) => bits(&mut v.iter(), h),
            Value::Pose(p) => bits(&mut p.r.iter().chain(p.centre.iter()), h),
            Value::Rotated { r, v } => bits(&mut r.iter().chain(v.iter()), h),
        }
    }
}
