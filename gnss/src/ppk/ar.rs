//! Integer ambiguity resolution on the filter state: double-difference ambiguities per system
//! and frequency (reference = highest satellite), LAMBDA with a ratio test, wide-lane first
//! when the full set fails on dual-frequency data, partial fixing by dropping newly risen then
//! low satellites, and fix-and-hold feedback.

use super::filter::{Filter, Pair, IONO};
use super::lambda::lambda;
use crate::sv::{Constellation, Sv};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use std::collections::BTreeMap;

/// An ambiguity candidate: state index, satellite, slot, elevation, lock count.
type Cand = (usize, Sv, usize, f64, usize);

/// A fixed solution: position, covariance, ratio, number of fixed ambiguities, and the
/// difference operator and integers (for holding).
pub(super) type Fix = (
    Vector3<f64>,
    Matrix3<f64>,
    f64,
    usize,
    DMatrix<f64>,
    DVector<f64>,
);

/// Double-difference rows (ambiguity index, reference index) per system and slot.
fn dd_rows(cands: &[Cand], excluded: &[Sv], mature: usize) -> Vec<(usize, usize)> {
    let mut groups: BTreeMap<(Constellation, usize), Vec<&Cand>> = BTreeMap::new();
    for c in cands.iter().filter(|c| !excluded.contains(&c.1)) {
        groups.entry((c.1.sys, c.2)).or_default().push(c);
    }
    let mut rows = Vec::new();
    for g in groups.values().filter(|g| g.len() >= 2) {
        // Reference: the highest satellite among those locked for a while (a freshly reset
        // reference would make every double difference of its group uncertain).
        let Some(r) = g.iter().max_by(|a, b| {
            ((a.4 >= mature), a.3)
                .partial_cmp(&((b.4 >= mature), b.3))
                .unwrap_or(std::cmp::Ordering::Equal)
        }) else {
            continue;
        };
        rows.extend(g.iter().filter(|c| c.0 != r.0).map(|c| (c.0, r.0)));
    }
    rows
}

/// Constrain `x`, `p` to `d·x = z` with variance `var` (a Kalman update).
fn constrain(
    x: &mut DVector<f64>,
    p: &mut DMatrix<f64>,
    d: &DMatrix<f64>,
    z: &DVector<f64>,
    var: f64,
) -> bool {
    let v = z - d * &*x;
    let s = d * &*p * d.transpose() + DMatrix::identity(d.nrows(), d.nrows()) * var;
    let Some(ch) = s.cholesky() else { return false };
    let dp = d * &*p;
    let k = ch.solve(&dp).transpose();
    *x += &k * v;
    *p = &*p - &k * &dp;
    *p = (&*p + p.transpose()) * 0.5;
    true
}

impl Filter<'_> {
    fn candidates(&self, pairs: &[Pair]) -> Vec<Cand> {
        let o = self.opts;
        let mut cands = Vec::new();
        for (k, a) in self.ambs.iter().enumerate() {
            if a.f == IONO || a.sv.sys == Constellation::Glonass || a.lock < o.min_lock {
                continue;
            }
            let Some(p) = pairs
                .iter()
                .find(|p| p.r.sv == a.sv && p.r.l[a.f].is_finite() && p.b.l[a.f].is_finite())
            else {
                continue;
            };
            if p.el >= o.ar_elev_mask {
                cands.push((3 + k, a.sv, a.f, p.el, a.lock));
            }
        }
        cands
    }

    /// LAMBDA on the rows; the fix when the ratio test passes. Records the best ratio seen.
    fn try_fix(
        &mut self,
        x: &DVector<f64>,
        p: &DMatrix<f64>,
        rows: &[(usize, usize)],
    ) -> Option<Fix> {
        let m = rows.len();
        let mut d = DMatrix::zeros(m, x.len());
        for (i, (a, r)) in rows.iter().enumerate() {
            d[(i, *a)] = 1.0;
            d[(i, *r)] = -1.0;
        }
        let a = &d * x;
        let q = &d * p * d.transpose();
        let q = (&q + q.transpose()) * 0.5;
        let c = lambda(a.as_slice(), q.as_slice(), 2)?;
        let ratio = c.ratio().min(999.9);
        self.last_ratio = Some(self.last_ratio.map_or(ratio, |r: f64| r.max(ratio)));
        if ratio < self.opts.ratio_threshold {
            return None;
        }
        let fix = DVector::from_vec(c.fixes[0].clone());
        let qxa = p.rows(0, 3) * d.transpose();
        let ch = q.cholesky()?;
        let pos = x.rows(0, 3) - &qxa * ch.solve(&(&a - &fix));
        let cov = p.view((0, 0), (3, 3)) - &qxa * ch.solve(&qxa.transpose());
        Some((
            Vector3::new(pos[0], pos[1], pos[2]),
            Matrix3::from_fn(|i, j| cov[(i, j)]),
            ratio,
            m,
            d,
            fix,
        ))
    }

    /// Wide-lane (slot 1 − slot 2) double differences fixed on a copy of the state.
    fn widelane(&mut self, cands: &[Cand]) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let n = self.x.len();
        let mut rows: Vec<[(usize, f64); 4]> = Vec::new();
        for sys in Constellation::ALL {
            // Satellites of this system with both slot-1 and slot-2 ambiguities.
            let both: Vec<(usize, usize, f64)> = cands
                .iter()
                .filter(|c| c.1.sys == sys && c.2 == 0)
                .filter_map(|c1| {
                    cands
                        .iter()
                        .find(|c2| c2.1 == c1.1 && c2.2 == 1)
                        .map(|c2| (c1.0, c2.0, c1.3))
                })
                .collect();
            let Some(r) = both
                .iter()
                .max_by(|a, b| a.2.partial_cmp(&b.2).unwrap_or(std::cmp::Ordering::Equal))
            else {
                continue;
            };
            for s in both.iter().filter(|s| s.0 != r.0) {
                rows.push([(s.0, 1.0), (s.1, -1.0), (r.0, -1.0), (r.1, 1.0)]);
            }
        }
        if rows.len() < self.opts.min_fix_ambiguities {
            return None;
        }
        let mut d = DMatrix::zeros(rows.len(), n);
        for (i, row) in rows.iter().enumerate() {
            for (k, v) in row {
                d[(i, *k)] = *v;
            }
        }
        let a = &d * &self.x;
        let q = &d * &self.p * d.transpose();
        let q = (&q + q.transpose()) * 0.5;
        let c = lambda(a.as_slice(), q.as_slice(), 2)?;
        if c.ratio() < self.opts.ratio_threshold {
            return None;
        }
        let (mut x, mut p) = (self.x.clone(), self.p.clone());
        let z = DVector::from_vec(c.fixes[0].clone());
        constrain(&mut x, &mut p, &d, &z, self.opts.hold_variance).then_some((x, p))
    }

    pub(super) fn resolve(&mut self, pairs: &[Pair]) -> Option<Fix> {
        let o = self.opts;
        let cands = self.candidates(pairs);
        let (mut x, mut p) = (self.x.clone(), self.p.clone());
        let mut excluded: Vec<Sv> = Vec::new();
        let mut widelane_tried = o.nf < 2;
        self.last_ratio = None;
        let mut attempt = 0;
        while attempt <= o.max_partial_drops {
            let rows = dd_rows(&cands, &excluded, o.mature_lock);
            if rows.len() < o.min_fix_ambiguities {
                return None;
            }
            if let Some(f) = self.try_fix(&x, &p, &rows) {
                // A partial fix that leaves the position at several centimetres is no fix:
                // the solution stays float rather than claim what it does not have.
                if !excluded.is_empty() && f.1.trace().sqrt() > o.max_partial_fix_sigma {
                    return None;
                }
                return Some(f);
            }
            if !widelane_tried {
                widelane_tried = true;
                if let Some((xw, pw)) = self.widelane(&cands) {
                    (x, p) = (xw, pw);
                    continue;
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
            attempt += 1;
        }
        None
    }

    /// Fix-and-hold: constrain the float ambiguities to the fixed integers.
    pub(super) fn hold(&mut self, d: &DMatrix<f64>, fix: &DVector<f64>) {
        let var = self.opts.hold_variance;
        constrain(&mut self.x, &mut self.p, d, fix, var);
    }
}
