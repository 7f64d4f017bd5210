//! Rotations: the exponential and logarithm of SO(3) (rotation vectors, as BAL's Rodrigues
//! parameters) and the skew-symmetric matrix.

use nalgebra::{Matrix3, Vector3};

/// The skew-symmetric matrix \[v\]× such that \[v\]×·w = v × w.
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

/// Rotation by `a` radians about x (right-handed, active).
pub fn rot_x(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// Rotation by `a` radians about y (right-handed, active).
pub fn rot_y(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}
/// Rotation by `a` radians about z (right-handed, active).
pub fn rot_z(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// Angles of a rotation R (camera → object frame), each with its convention, radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Angles {
    /// ω-φ-κ: R = Rω·Rφ·Rκ (the usual western definition).
    OmegaPhiKappa {
        /// ω (about x).
        omega: f64,
        /// φ (about y).
        phi: f64,
        /// κ (about z).
        kappa: f64,
    },
    /// φ-ω-κ: R = Rφ·Rω·Rκ with Rφ = `[[cφ,0,−sφ],[0,1,0],[sφ,0,cφ]]` (Y primary axis, as in
    /// Chinese photogrammetry texts).
    PhiOmegaKappa {
        /// φ (about y, primary).
        phi: f64,
        /// ω (about x).
        omega: f64,
        /// κ (about z).
        kappa: f64,
    },
    /// Yaw (from north, clockwise), pitch (nose up), roll (right wing down) of a NED body whose
    /// camera looks down with its x axis forward; the object frame is ENU.
    YawPitchRoll {
        /// Yaw from north, clockwise.
        yaw: f64,
        /// Pitch, nose up.
        pitch: f64,
        /// Roll, right wing down.
        roll: f64,
    },
}

impl Angles {
    /// The rotation matrix camera → object frame.
    pub fn matrix(&self) -> Matrix3<f64> {
        match *self {
            Angles::OmegaPhiKappa { omega, phi, kappa } => rot_x(omega) * rot_y(phi) * rot_z(kappa),
            Angles::PhiOmegaKappa { phi, omega, kappa } => {
                rot_y(-phi) * rot_x(omega) * rot_z(kappa)
            }
            Angles::YawPitchRoll { yaw, pitch, roll } => {
                let ned_to_enu = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
                let cam_to_body = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
                ned_to_enu * rot_z(yaw) * rot_y(pitch) * rot_x(roll) * cam_to_body
            }
        }
    }

    /// ω-φ-κ of a rotation matrix.
    pub fn omega_phi_kappa(r: &Matrix3<f64>) -> Angles {
        Angles::OmegaPhiKappa {
            omega: (-r[(1, 2)]).atan2(r[(2, 2)]),
            phi: r[(0, 2)].clamp(-1.0, 1.0).asin(),
            kappa: (-r[(0, 1)]).atan2(r[(0, 0)]),
        }
    }

    /// φ-ω-κ of a rotation matrix (R = Rφ·Rω·Rκ: `R[1][2] = −sω`, `R[0][2] = −sφ·cω`,
    /// `R[2][2] = cφ·cω`).
    pub fn phi_omega_kappa(r: &Matrix3<f64>) -> Angles {
        let omega = (-r[(1, 2)]).clamp(-1.0, 1.0).asin();
        Angles::PhiOmegaKappa {
            phi: (-r[(0, 2)]).atan2(r[(2, 2)]),
            omega,
            kappa: r[(1, 0)].atan2(r[(1, 1)]),
        }
    }

    /// Yaw, pitch, roll of a rotation matrix (inverse of the downward mounting).
    pub fn yaw_pitch_roll(r: &Matrix3<f64>) -> Angles {
        let ned = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0)
            * r
            * Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
        Angles::YawPitchRoll {
            yaw: ned[(1, 0)].atan2(ned[(0, 0)]),
            pitch: (-ned[(2, 0)]).clamp(-1.0, 1.0).asin(),
            roll: ned[(2, 1)].atan2(ned[(2, 2)]),
        }
    }
}

#[cfg(test)]
mod convention_tests {
    use super::*;

    #[test]
    fn every_convention_round_trips_through_the_matrix() {
        let r = Angles::YawPitchRoll {
            yaw: 0.7,
            pitch: 0.03,
            roll: -0.05,
        }
        .matrix();
        for a in [
            Angles::omega_phi_kappa(&r),
            Angles::phi_omega_kappa(&r),
            Angles::yaw_pitch_roll(&r),
        ] {
            assert!((a.matrix() - r).norm() < 1e-12, "{a:?}");
        }
        // The φ-ω-κ textbook matrix elements.
        let (phi, omega, kappa) = (0.1f64, 0.2f64, 0.3f64);
        let m = Angles::PhiOmegaKappa { phi, omega, kappa }.matrix();
        let a1 = phi.cos() * kappa.cos() - phi.sin() * omega.sin() * kappa.sin();
        let c3 = phi.cos() * omega.cos();
        assert!((m[(0, 0)] - a1).abs() < 1e-12 && (m[(2, 2)] - c3).abs() < 1e-12);
        // Level, heading north: camera x → north, z → up.
        let r0 = Angles::YawPitchRoll {
            yaw: 0.0,
            pitch: 0.0,
            roll: 0.0,
        }
        .matrix();
        assert!(
            (r0 * Vector3::x() - Vector3::y()).norm() < 1e-12
                && (r0 * Vector3::z() - Vector3::z()).norm() < 1e-12
        );
    }
}
