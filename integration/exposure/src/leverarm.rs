//! The lever arm measured with a tape: D0 from the origin mark to the antenna, DX, DY, DZ from
//! marks at distance A along three orthogonal body axes. By the law of cosines
//! u = (D0² + A² − DX²)/(2A), and likewise v, w; precision by error propagation.
//!
//! [`Tapes`] parses the four lengths from text ("D0,DX,DY,DZ"), [`solve`] gives the
//! [`TapeSolution`], whose `Display` is the two lines `ppkat leverarm` prints.

use nalgebra::{Matrix3, Vector3};
use std::fmt;
use std::str::FromStr;

/// A measured lever arm with its covariance.
#[derive(Clone, Debug)]
pub struct TapeSolution {
    /// (u, v, w): the antenna in the camera (body) frame, metres.
    pub offset: Vector3<f64>,
    /// Covariance of (u, v, w), m².
    pub cov: Matrix3<f64>,
}

impl fmt::Display for TapeSolution {
    /// Two lines (no trailing newline): the lever arm and its sigmas, metres, 4 decimals.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let o = &self.offset;
        writeln!(
            f,
            "lever arm (u v w, metres): {:.4} {:.4} {:.4}",
            o.x, o.y, o.z
        )?;
        write!(
            f,
            "sigma     (u v w, metres): {:.4} {:.4} {:.4}",
            self.cov[(0, 0)].sqrt(),
            self.cov[(1, 1)].sqrt(),
            self.cov[(2, 2)].sqrt()
        )
    }
}

/// The four tape lengths, metres: D0 from the origin mark to the antenna, and DX, DY, DZ
/// from the marks on the x, y and z axes to the antenna.
///
/// Parsed from "D0,DX,DY,DZ" (four numbers separated by commas, blanks allowed):
/// ```
/// # use exposure::leverarm::Tapes;
/// let t: Tapes = "1.84, 1.87, 2.09, 0.90".parse().unwrap();
/// assert_eq!((t.d0, t.d), (1.84, [1.87, 2.09, 0.90]));
/// assert!("1.0,0.5,0.5".parse::<Tapes>().is_err());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tapes {
    /// Origin mark → antenna, metres.
    pub d0: f64,
    /// x, y and z marks → antenna, metres.
    pub d: [f64; 3],
}

impl FromStr for Tapes {
    type Err = TapeError;

    fn from_str(s: &str) -> Result<Tapes, TapeError> {
        let bad = || TapeError::Parse(s.to_string());
        let v: Vec<f64> = s
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad())?;
        match v[..] {
            [d0, dx, dy, dz] => Ok(Tapes {
                d0,
                d: [dx, dy, dz],
            }),
            _ => Err(bad()),
        }
    }
}

impl Tapes {
    /// [`solve`] these lengths with the ruler distance `a` and the sigma of one length, metres.
    pub fn solve(&self, a: f64, sigma: f64) -> Result<TapeSolution, TapeError> {
        solve(self.d0, self.d, a, sigma)
    }
}

/// Why tape lengths cannot be read or solved.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TapeError {
    /// The text is not four numbers separated by commas.
    #[error("'{0}': four lengths D0,DX,DY,DZ in metres expected, separated by commas")]
    Parse(String),
    /// A is not a positive number.
    #[error("the ruler distance A must be positive")]
    Ruler,
    /// A length is not a positive number.
    #[error("tape lengths must be positive")]
    Length,
    /// The sigma of a length is not a finite number ≥ 0.
    #[error("the sigma of a tape length must be a finite number of metres, 0 or more")]
    Sigma,
    /// The lengths do not form a triangle consistent with orthogonal axes.
    #[error("the lengths are inconsistent: u² + v² + w² = {sum:.4} m² but D0² = {d0sq:.4} m² (check the marks and the axes)")]
    Inconsistent {
        /// u² + v² + w², m².
        sum: f64,
        /// D0², m².
        d0sq: f64,
    },
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
    if !(sigma.is_finite() && sigma >= 0.0) {
        return Err(TapeError::Sigma);
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

    #[test]
    fn parses_four_lengths_and_refuses_anything_else() {
        let t: Tapes = "1.840674,1.868176, 2.087123 ,0.904479".parse().unwrap();
        assert_eq!(t.d0, 1.840674);
        assert_eq!(t.d, [1.868176, 2.087123, 0.904479]);
        for bad in ["1.0,0.5,0.5", "1,2,3,4,5", "1,2,x,4", "", "1;2;3;4"] {
            assert_eq!(
                bad.parse::<Tapes>(),
                Err(TapeError::Parse(bad.to_string())),
                "{bad}"
            );
        }
        let e = "1,2".parse::<Tapes>().unwrap_err().to_string();
        assert!(
            e.contains("'1,2'") && e.contains("four lengths D0,DX,DY,DZ"),
            "{e}"
        );
    }

    #[test]
    fn prints_the_offset_and_its_sigmas() {
        let s = "1.840674,1.868176,2.087123,0.904479"
            .parse::<Tapes>()
            .unwrap()
            .solve(1.0, 0.002)
            .unwrap();
        let text = s.to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2, "{text}");
        assert_eq!(lines[0], "lever arm (u v w, metres): 0.4490 0.0160 1.7850");
        assert!(
            lines[1].starts_with("sigma     (u v w, metres): 0.00"),
            "{text}"
        );
    }
}
