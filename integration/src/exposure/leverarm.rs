//! The lever arm measured with a tape: D0 from the origin mark to the antenna, DX, DY, DZ from
//! marks at distance A along three orthogonal body axes. By the law of cosines
//! u = (D0² + A² − DX²)/(2A), and likewise v, w; precision by error propagation.

use nalgebra::{Matrix3, Vector3};

/// A measured lever arm with its covariance.
#[derive(Clone, Debug)]
pub struct TapeSolution {
    pub offset: Vector3<f64>,
    pub cov: Matrix3<f64>,
}

/// Why tape lengths cannot be solved.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TapeError {
    #[error("the ruler distance A must be positive")]
    Ruler,
    #[error("tape lengths must be positive")]
    Length,
    #[error("the lengths are inconsistent: u² + v² + w² = {sum:.4} m² but D0² = {d0sq:.4} m² (check the marks and the axes)")]
    Inconsistent { sum: f64, d0sq: f64 },
}

/// Solve (u, v, w) from D0, DX, DY, DZ and the ruler A, each length with sigma `sigma` (m).
pub fn solve(d0: f64, d: [f64; 3], a: f64, sigma: f64) -> Result<TapeSolution, TapeError> {
    let positive = |x: f64| x.is_finite() && x > 0.0;
    if !positive(a) {
        return Err(TapeError::Ruler);
    }
    if !positive(d0) || d.iter().any(|x| !positive(*x)) {
        return Err(TapeError::Length);
    }
    let c = |dx: f64| (d0 * d0 + a * a - dx * dx) / (2.0 * a);
    let off = Vector3::new(c(d[0]), c(d[1]), c(d[2]));
    // Consistency: the offset's length must be D0 (within what the tapes allow).
    let sum = off.norm_squared();
    if (sum - d0 * d0).abs() > 0.05 * d0 * d0 + 10.0 * sigma * d0 {
        return Err(TapeError::Inconsistent { sum, d0sq: d0 * d0 });
    }
    // Jacobian with respect to (D0, DX, DY, DZ).
    let mut j = nalgebra::Matrix3x4::zeros();
    for k in 0..3 {
        j[(k, 0)] = d0 / a;
        j[(k, k + 1)] = -d[k] / a;
    }
    let cov = j * j.transpose() * (sigma * sigma);
    Ok(TapeSolution { offset: off, cov })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_a_known_offset_from_its_four_lengths() {
        let truth = Vector3::new(0.449, 0.016, 1.785);
        let a = 1.0;
        let d0 = truth.norm();
        let d: [f64; 3] = std::array::from_fn(|k| (truth - Vector3::ith(k, a)).norm());
        let s = solve(d0, d, a, 0.002).unwrap();
        assert!((s.offset - truth).norm() < 1e-12, "{:?}", s.offset);
        // u depends on D0 and DX: sigma = 2 mm · √(D0² + DX²) / A.
        let su = 0.002 * (d0 * d0 + d[0] * d[0]).sqrt() / a;
        assert!((s.cov[(0, 0)].sqrt() - su).abs() < 1e-12);
        assert_eq!(solve(d0, d, 0.0, 0.002).unwrap_err(), TapeError::Ruler);
        assert!(matches!(
            solve(d0, [0.1, 0.1, 0.1], a, 0.002),
            Err(TapeError::Inconsistent { .. })
        ));
    }
}
