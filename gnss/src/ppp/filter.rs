//! The Kalman filter of precise point positioning: receiver position, receiver clock (white
//! noise, re-estimated every epoch), zenith wet delay (random walk) and one float
//! ionosphere-free ambiguity per satellite arc, updated with all rows of an epoch at once
//! (Joseph form, so that the covariance stays symmetric and positive over a day).

use crate::sv::Sv;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// Index of the receiver clock (metres) in the state.
pub const CLK: usize = 3;
/// Index of the zenith wet delay correction (metres) in the state.
pub const ZWD: usize = 4;
/// Number of states before the ambiguities.
const CORE: usize = 5;

/// One row of an epoch's measurement model: residual (observed − computed), partial
/// derivatives by position, clock and zenith wet delay, the ambiguity it carries (phase
/// rows) and its variance.
#[derive(Clone, Debug)]
pub struct Row {
    /// The satellite.
    pub sv: Sv,
    /// Whether the row is a carrier phase (else code).
    pub phase: bool,
    /// Observed minus computed, metres.
    pub v: f64,
    /// ∂/∂position: minus the unit vector receiver→satellite.
    pub dpos: Vector3<f64>,
    /// ∂/∂zenith wet delay: the wet mapping function.
    pub dzwd: f64,
    /// Variance, m².
    pub var: f64,
}

/// The filter state: values, covariance and which satellite owns each ambiguity state.
#[derive(Clone, Debug)]
pub struct State {
    /// Position (ECEF m), clock (m), zenith wet delay (m), ambiguities (m).
    pub x: DVector<f64>,
    /// Covariance.
    pub p: DMatrix<f64>,
    /// The satellite of ambiguity `CORE + k`.
    pub amb: Vec<Sv>,
}

impl State {
    /// A state at `pos` with σ `sigma_pos` (m), the clock `clock` with σ 300 km, and the zenith
    /// wet delay correction 0 with σ `sigma_zwd`.
    pub fn new(pos: Vector3<f64>, sigma_pos: f64, clock: f64, sigma_zwd: f64) -> State {
        let mut x = DVector::zeros(CORE);
        x.fixed_rows_mut::<3>(0).copy_from(&pos);
        x[CLK] = clock;
        let mut p = DMatrix::zeros(CORE, CORE);
        for i in 0..3 {
            p[(i, i)] = sigma_pos * sigma_pos;
        }
        p[(CLK, CLK)] = 9.0e10;
        p[(ZWD, ZWD)] = sigma_zwd * sigma_zwd;
        State {
            x,
            p,
            amb: Vec::new(),
        }
    }

    /// Position, ECEF metres.
    pub fn pos(&self) -> Vector3<f64> {
        self.x.fixed_rows::<3>(0).into_owned()
    }

    /// Covariance of the position, m².
    pub fn pos_cov(&self) -> Matrix3<f64> {
        self.p.fixed_view::<3, 3>(0, 0).into_owned()
    }

    /// Index of the ambiguity of `sv`, if it has one.
    pub fn amb_index(&self, sv: Sv) -> Option<usize> {
        self.amb.iter().position(|s| *s == sv).map(|k| CORE + k)
    }

    /// Forget the ambiguity of `sv` (a slip, or the satellite set).
    pub fn drop_amb(&mut self, sv: Sv) {
        if let Some(i) = self.amb_index(sv) {
            self.x = self.x.clone().remove_row(i);
            self.p = self.p.clone().remove_row(i).remove_column(i);
            self.amb.remove(i - CORE);
        }
    }

    /// Start a new ambiguity of `sv` at `value` with variance `var` (replacing any).
    pub fn add_amb(&mut self, sv: Sv, value: f64, var: f64) {
        self.drop_amb(sv);
        let n = self.x.len();
        self.x = self.x.clone().insert_row(n, value);
        self.p = self.p.clone().insert_row(n, 0.0).insert_column(n, 0.0);
        self.p[(n, n)] = var;
        self.amb.push(sv);
    }

    /// Make a state white noise: value `value`, variance `var`, no correlation.
    pub fn reset(&mut self, i: usize, value: f64, var: f64) {
        self.x[i] = value;
        self.p.row_mut(i).fill(0.0);
        self.p.column_mut(i).fill(0.0);
        self.p[(i, i)] = var;
    }

    /// The design row of `r`.
    fn design(&self, r: &Row) -> DVector<f64> {
        let mut h = DVector::zeros(self.x.len());
        h.fixed_rows_mut::<3>(0).copy_from(&r.dpos);
        h[CLK] = 1.0;
        h[ZWD] = r.dzwd;
        if r.phase {
            if let Some(i) = self.amb_index(r.sv) {
                h[i] = 1.0;
            }
        }
        h
    }

    /// Innovation variances of the rows (H P Hᵀ + R diagonal).
    pub fn innovation_var(&self, rows: &[Row]) -> Vec<f64> {
        rows.iter()
            .map(|r| {
                let h = self.design(r);
                (h.transpose() * &self.p * &h)[(0, 0)] + r.var
            })
            .collect()
    }

    /// Update with all rows at once; returns the state change, or None when the innovation
    /// covariance is not positive definite (nothing changed then).
    pub fn update(&mut self, rows: &[Row]) -> Option<DVector<f64>> {
        let n = self.x.len();
        let m = rows.len();
        if m == 0 {
            return Some(DVector::zeros(n));
        }
        let mut h = DMatrix::zeros(m, n);
        let mut v = DVector::zeros(m);
        let mut r = DMatrix::zeros(m, m);
        for (k, row) in rows.iter().enumerate() {
            h.row_mut(k).copy_from(&self.design(row).transpose());
            v[k] = row.v;
            r[(k, k)] = row.var;
        }
        let ph = &self.p * h.transpose();
        let s = &h * &ph + &r;
        let chol = s.cholesky()?;
        let k = ph * chol.inverse();
        let dx = &k * v;
        self.x += &dx;
        let ikh = DMatrix::identity(n, n) - &k * &h;
        let p = &ikh * &self.p * ikh.transpose() + &k * r * k.transpose();
        self.p = (&p + p.transpose()) * 0.5;
        Some(dx)
    }

    /// The residual of `r` after a state change `dx` (linearised).
    pub fn after(&self, r: &Row, dx: &DVector<f64>) -> f64 {
        r.v - (self.design(r).transpose() * dx)[(0, 0)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sv::Constellation;

    #[test]
    fn ambiguities_come_and_go_and_update_moves_toward_the_data() {
        let mut s = State::new(Vector3::new(1.0, 2.0, 3.0), 10.0, 0.0, 0.3);
        let (a, b) = (
            Sv::new(Constellation::Gps, 1),
            Sv::new(Constellation::Gps, 2),
        );
        s.add_amb(a, 5.0, 100.0);
        s.add_amb(b, 7.0, 100.0);
        s.drop_amb(a);
        assert_eq!(s.amb, vec![b]);
        assert_eq!(s.x.len(), CORE + 1);
        assert_eq!(s.x[CORE], 7.0);
        let row = Row {
            sv: b,
            phase: true,
            v: 1.0,
            dpos: Vector3::zeros(),
            dzwd: 0.0,
            var: 1e-6,
        };
        s.reset(CLK, 0.0, 1e-12);
        let dx = s.update(std::slice::from_ref(&row)).unwrap();
        assert!(
            (s.x[CORE] - 8.0).abs() < 1e-6,
            "the ambiguity takes the residual"
        );
        assert!(s.after(&row, &dx).abs() < 1e-6);
    }
}
