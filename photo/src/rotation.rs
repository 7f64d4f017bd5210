//! Rotations: the exponential and logarithm of SO(3) (rotation vectors, as BAL's Rodrigues
//! parameters) and the skew-symmetric matrix.

use nalgebra::{Matrix3, Vector3};

/// [v]× such that [v]×·w = v × w.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Rotation matrix of a rotation vector (axis × angle).
pub fn exp_so3(w: &Vector3<f64>) -> Matrix3<f64> {
    let th2 = w.norm_squared();
    let k = skew(w);
    if th2 < 1e-16 {
        return Matrix3::identity() + k + k * k * 0.5;
    }
    let th = th2.sqrt();
    Matrix3::identity() + k * (th.sin() / th) + k * k * ((1.0 - th.cos()) / th2)
}

/// Rotation vector of a rotation matrix.
pub fn log_so3(r: &Matrix3<f64>) -> Vector3<f64> {
    let c = ((r.trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    let th = c.acos();
    let v = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    );
    if th < 1e-8 {
        return v * 0.5;
    }
    if std::f64::consts::PI - th < 1e-6 {
        // Near π: the axis from the largest diagonal element.
        let d = r.diagonal();
        let i = if d.x >= d.y && d.x >= d.z {
            0
        } else if d.y >= d.z {
            1
        } else {
            2
        };
        let mut axis = r.column(i) + Vector3::ith(i, 1.0);
        axis /= axis.norm();
        return axis * th;
    }
    v * (th / (2.0 * th.sin()))
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn exp_and_log_invert_each_other() {
        for w in [
            Vector3::new(0.1, -0.2, 0.3),
            Vector3::new(1e-9, 0.0, 2e-9),
            Vector3::new(0.0, 3.0, 0.0),
        ] {
            let r = exp_so3(&w);
            assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12);
            assert!((log_so3(&r) - w).norm() < 1e-9, "{w:?}");
        }
    }
}
