//! Integer ambiguity resolution on the filter state: double-difference ambiguities per system
//! and frequency (reference = highest satellite), LAMBDA with a ratio test, partial fixing by
//! dropping newly risen then low satellites, and fix-and-hold feedback.

use super::filter::{Filter, Pair};
use super::lambda::lambda;
use crate::sv::{Constellation, Sv};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// A fixed solution: position, covariance, ratio, number of fixed ambiguities, and the
/// difference operator and integers (for holding).
/// An ambiguity candidate: state index, satellite, slot, elevation, lock count.
type Cand = (usize, Sv, usize, f64, usize);

pub(super) type Fix = (
    Vector3<f64>,
    Matrix3<f64>,
    f64,
    usize,
    DMatrix<f64>,
    DVector<f64>,
);

impl Filter<'_> {
    pub(super) fn resolve(&mut self, pairs: &[Pair]) -> Option<Fix> {
        let o = self.opts;
        // Candidates: (state index, satellite, slot, elevation, lock).
        let mut cands: Vec<Cand> = Vec::new();
        for (k, a) in self.ambs.iter().enumerate() {
            if a.f == super::filter::IONO
                || a.sv.sys == Constellation::Glonass
                || a.lock < o.min_lock
            {
                continue;
            }
            let Some(p) = pairs
                .iter()
                .find(|p| p.r.sv == a.sv && p.r.l[a.f].is_finite() && p.b.l[a.f].is_finite())
            else {
                continue;
            };
            if p.el < o.ar_elev_mask {
                continue;
            }
            cands.push((3 + k, a.sv, a.f, p.el, a.lock));
        }
        let n = self.x.len();
        let mut excluded: Vec<Sv> = Vec::new();
        self.last_ratio = None;
        for _attempt in 0..=o.max_partial_drops {
            // Difference operator.
            let mut rows: Vec<(usize, usize)> = Vec::new();
            let mut groups: std::collections::BTreeMap<(Constellation, usize), Vec<&Cand>> =
                Default::default();
            for c in cands.iter().filter(|c| !excluded.contains(&c.1)) {
                groups.entry((c.1.sys, c.2)).or_default().push(c);
            }
            for g in groups.values() {
                if g.len() < 2 {
                    continue;
                }
                let r = g
                    .iter()
                    .max_by(|a, b| a.3.partial_cmp(&b.3).unwrap_or(std::cmp::Ordering::Equal))?;
                for c in g {
                    if c.0 != r.0 {
                        rows.push((c.0, r.0));
                    }
                }
            }
            let m = rows.len();
            if m < o.min_fix_ambiguities {
                return None;
            }
            let mut d = DMatrix::zeros(m, n);
            for (i, (a, r)) in rows.iter().enumerate() {
                d[(i, *a)] = 1.0;
                d[(i, *r)] = -1.0;
            }
            let a = &d * &self.x;
            let q = &d * &self.p * d.transpose();
            let q = (&q + q.transpose()) * 0.5;
            let qxa = self.p.rows(0, 3) * d.transpose();
            if let Some(c) = lambda(a.as_slice(), q.as_slice(), 2) {
                let ratio = c.ratio().min(999.9);
                self.last_ratio = Some(self.last_ratio.map_or(ratio, |r: f64| r.max(ratio)));
                if ratio >= o.ratio_threshold {
                    let fix = DVector::from_vec(c.fixes[0].clone());
                    let ch = q.clone().cholesky()?;
                    let pos = self.x.rows(0, 3) - &qxa * ch.solve(&(&a - &fix));
                    let cov = self.p.view((0, 0), (3, 3)) - &qxa * ch.solve(&qxa.transpose());
                    return Some((
                        Vector3::new(pos[0], pos[1], pos[2]),
                        Matrix3::from_fn(|i, j| cov[(i, j)]),
                        ratio,
                        m,
                        d,
                        fix,
                    ));
                }
            }
            // Partial fixing: drop the newest, then the lowest satellite.
            let worst = cands
                .iter()
                .filter(|c| !excluded.contains(&c.1))
                .min_by(|a, b| {
                    let ka = (a.4 >= o.mature_lock, a.3);
                    let kb = (b.4 >= o.mature_lock, b.3);
                    ka.partial_cmp(&kb).unwrap_or(std::cmp::Ordering::Equal)
                })?;
            excluded.push(worst.1);
        }
        None
    }

    /// Fix-and-hold: constrain the float ambiguities to the fixed integers.
    pub(super) fn hold(&mut self, d: &DMatrix<f64>, fix: &DVector<f64>) {
        let v = fix - d * &self.x;
        let s = d * &self.p * d.transpose()
            + DMatrix::identity(d.nrows(), d.nrows()) * self.opts.hold_variance;
        let Some(ch) = s.cholesky() else { return };
        let dp = d * &self.p;
        let k = ch.solve(&dp).transpose();
        self.x += &k * v;
        self.p = &self.p - &k * &dp;
        self.p = (&self.p + self.p.transpose()) * 0.5;
    }
}
