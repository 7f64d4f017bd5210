//! Honest σ for PPP. The filter treats every epoch's errors as independent, but what is
//! left after the models (interpolated satellite clocks, the products' own errors,
//! multipath, unmodelled loading) is correlated over minutes to hours: left alone, the
//! filter's σ of a day's static coordinate is millimetres while the error is centimetres.
//!
//! The post-fit phase residuals tell how large and how correlated those errors are: their
//! normalised mean square gives a variance factor, and their lag-one correlation ρ the
//! factor (1 + ρ)/(1 − ρ) by which a mean of correlated samples is less certain than one of
//! independent ones. Both scale the filter's covariance; a floor for what residuals cannot
//! show (errors common to all satellites: loading, antenna calibration, frame) is added.

use crate::frame::{enu_rotation, Ecef};
use crate::sv::Sv;
use nalgebra::Matrix3;
use std::collections::BTreeMap;

/// σ east/north and up (m) of errors the residuals cannot show, added to every position's
/// covariance: the day-to-day repeatability of float PPP with final products, and the frame of the
/// orbits against ITRF (a centimetre for older products).
pub const FLOOR: (f64, f64) = (0.010, 0.015);

/// Running statistics of normalised post-fit phase residuals.
#[derive(Clone, Debug, Default)]
pub struct Consistency {
    /// Count and sum of squares of the normalised residuals.
    n: usize,
    sum2: f64,
    /// Sums over consecutive residuals of one arc: x(t)·x(t−1) and x(t−1)².
    lag: f64,
    lag2: f64,
    /// Last normalised residual per satellite and the epoch counter it belongs to.
    last: BTreeMap<Sv, (usize, f64)>,
}

impl Consistency {
    /// Record the normalised residual `x` of `sv` at solved epoch `k`.
    pub fn add(&mut self, sv: Sv, k: usize, x: f64) {
        self.n += 1;
        self.sum2 += x * x;
        if let Some(&(j, prev)) = self.last.get(&sv) {
            if j + 1 == k {
                self.lag += x * prev;
                self.lag2 += prev * prev;
            }
        }
        self.last.insert(sv, (k, x));
    }

    /// The satellite's arc restarted: its next residual does not follow the last one.
    pub fn restart(&mut self, sv: Sv) {
        self.last.remove(&sv);
    }

    /// Variance factor (at least 1) of the residuals.
    pub fn variance_factor(&self) -> f64 {
        if self.n < 30 {
            return 1.0;
        }
        (self.sum2 / self.n as f64).max(1.0)
    }

    /// Lag-one correlation of the residuals, in [0, 0.98].
    pub fn correlation(&self) -> f64 {
        if self.lag2 <= 0.0 {
            return 0.0;
        }
        (self.lag / self.lag2).clamp(0.0, 0.98)
    }

    /// (1 + ρ)/(1 − ρ): how much less certain a mean of the correlated residuals is than
    /// one of as many independent ones.
    pub fn correlation_factor(&self) -> f64 {
        let rho = self.correlation();
        (1.0 + rho) / (1.0 - rho)
    }

    /// The factor that scales the covariance of a static coordinate.
    pub fn inflation(&self) -> f64 {
        self.variance_factor() * self.correlation_factor()
    }
}

/// The covariance of `pos` scaled by `k` with the floor added.
pub fn honest_cov(pos: &Ecef, cov: &Matrix3<f64>, k: f64) -> Matrix3<f64> {
    let r = enu_rotation(&pos.to_geodetic());
    let floor = Matrix3::from_diagonal(&nalgebra::Vector3::new(
        FLOOR.0 * FLOOR.0,
        FLOOR.0 * FLOOR.0,
        FLOOR.1 * FLOOR.1,
    ));
    cov * k + r.transpose() * floor * r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sv::Constellation;

    #[test]
    fn correlated_residuals_inflate_more_than_white_ones() {
        let sv = Sv::new(Constellation::Gps, 1);
        let mut white = Consistency::default();
        let mut slow = Consistency::default();
        let mut state: u64 = 7;
        let mut ar = 0.0;
        for k in 0..5000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0;
            let x = u * 3f64.sqrt(); // unit variance
            white.add(sv, k, x);
            ar = 0.9 * ar + (1.0 - 0.81f64).sqrt() * x;
            slow.add(sv, k, ar);
        }
        assert!(white.correlation() < 0.05);
        assert!((white.inflation() - 1.0).abs() < 0.15);
        assert!((slow.correlation() - 0.9).abs() < 0.03);
        assert!(slow.inflation() > 15.0 && slow.inflation() < 23.0);
    }
}
