//! Levenberg–Marquardt with a trust region (as Ceres): the damping λ = 1/radius acts on the
//! clamped diagonal of the normals; a step is accepted when the cost falls by more than 10⁻³
//! of what the linear model promised, and the radius follows the gain ratio (Nielsen).
//! Iterations end when an accepted step gains less than `function_tolerance` of the cost, when
//! a step changes the cost by round-off only (a converged problem solved again stays bit for
//! bit where it was, so its statistics can be reused), or after `max_iterations`.

use super::error::SolveError;
use super::lin::{regular, Linearisation};
use super::linear::Linear;
use super::model::Model;
use super::problem::Problem;
use super::reduced::Reduced;
use super::selinv::FactorFailure;
use super::structure::Structure;
use nalgebra::DMatrix;

/// What an adjustment did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    /// Iterations (accepted or not).
    pub iterations: usize,
    /// Accepted steps.
    pub successful: usize,
    /// Cost ½Σρ before and after.
    pub initial_cost: f64,
    /// Cost ½Σρ at the solution.
    pub final_cost: f64,
    /// √(Σr²/(m − n)) of the whitened residuals (1 when there is no redundancy).
    pub sigma0: f64,
    /// m − n.
    pub redundancy: f64,
    /// Residual components m.
    pub observations: usize,
    /// Free unknowns n.
    pub unknowns: usize,
    /// Wall time, seconds.
    pub seconds: f64,
}

impl Problem {
    /// Adjust: Levenberg–Marquardt until convergence, then the checks that make the result
    /// meaningful (every block determined, the normals regular).
    pub fn solve(&mut self) -> Result<Summary, SolveError> {
        let t0 = std::time::Instant::now();
        let st = self.structure();
        let mut lins = Linearisation::default();
        let mut cost = self.model.linearise(&st, &self.model.values, &mut lins)?;
        if self.options.unique {
            self.model.check_determined(&st, &lins)?;
        }
        let linear = Linear::new(&self.options, &self.caches.symbolic);
        let mut s = Summary {
            initial_cost: cost.cost,
            ..Summary::default()
        };
        let mut red = Reduced::default();
        // The candidate is linearised at once: an accepted step (most of them) then needs no
        // second evaluation of its factors.
        let (mut cand, mut cand_lin) = (Vec::new(), Linearisation::default());
        // Warm: where the last solve of this problem ended, when nothing but its observations
        // changed since.
        let warm = self.caches.radius.lock().ok().and_then(|r| *r);
        let start = warm.map_or(self.options.initial_radius, |r| {
            r.clamp(self.options.initial_radius, 1e16)
        });
        let (mut radius, mut nu) = (start, 2.0);
        let mut t_it = std::time::Instant::now();
        while s.iterations < self.options.max_iterations {
            if s.iterations > 0 {
                self.time("iteration", t_it);
            }
            t_it = std::time::Instant::now();
            s.iterations += 1;
            self.notify(super::problem::SolveStep::Iteration(
                s.iterations,
                self.options.max_iterations,
            ));
            let reduced = Model::reduce(&st, &lins, 1.0 / radius, true, &mut red);
            self.time("reduce", t_it);
            let t_f = std::time::Instant::now();
            let step = reduced
                .then(|| linear.solve_reduced(&st, &red))
                .flatten()
                .map(|dc| Model::back_substitute(&st, &red, dc));
            self.time("factorise", t_f);
            let Some(step) = step else {
                (radius, nu) = (radius / nu, nu * 2.0);
                if radius < 1e-32 {
                    break;
                }
                continue;
            };
            self.model.apply_into(&st, &step, &mut cand);
            let new_cost = self.model.linearise(&st, &cand, &mut cand_lin);
            let new = new_cost.as_ref().map_or(f64::INFINITY, |c| c.cost);
            let model = Model::model_decrease(&st, &lins, &step);
            let rho = if model > 0.0 {
                (cost.cost - new) / model
            } else {
                -1.0
            };
            let change = (cost.cost - new) / cost.cost.max(f64::MIN_POSITIVE);
            if let (Ok(c), true) = (new_cost, new.is_finite() && rho > 1e-3 && change >= 1e-14) {
                std::mem::swap(&mut self.model.values, &mut cand);
                std::mem::swap(&mut lins, &mut cand_lin);
                s.successful += 1;
                cost = c;
                radius /= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                nu = 2.0;
                if change < self.options.function_tolerance {
                    break;
                }
            } else {
                // A step that changes the cost by round-off only: converged.
                if new.is_finite() && change.abs() <= 1e-12 {
                    break;
                }
                (radius, nu) = (radius / nu, nu * 2.0);
                if radius < 1e-32 {
                    break;
                }
            }
        }
        if s.iterations > 0 {
            self.time("iteration", t_it);
        }
        if let Ok(mut r) = self.caches.radius.lock() {
            *r = Some(radius);
        }
        let m = st.nres;
        if m < st.n {
            return Err(SolveError::Underdetermined(st.n, m));
        }
        if self.options.unique {
            self.check_regular(&st, &lins, &linear, &mut red)?;
        }
        s.final_cost = cost.cost;
        s.observations = m;
        s.unknowns = st.n;
        s.redundancy = (m - st.n) as f64;
        s.sigma0 = if m > st.n {
            (cost.squares / (m - st.n) as f64).sqrt()
        } else {
            1.0
        };
        s.seconds = t0.elapsed().as_secs_f64();
        self.time("solve", t0);
        Ok(s)
    }

    /// The undamped normals must be regular, otherwise there is a datum defect (no control,
    /// nothing fixed). Checked once per structure (a dense factorisation of the reduced system
    /// when small, a sparse one when large).
    fn check_regular(
        &self,
        st: &Structure,
        lins: &Linearisation,
        linear: &Linear,
        red: &mut Reduced,
    ) -> Result<(), SolveError> {
        if self
            .caches
            .regular_for
            .lock()
            .is_ok_and(|r| *r == Some(st.hash))
        {
            return Ok(());
        }
        let singular = || {
            SolveError::Singular(format!(
                "{} unknowns: a datum defect (no control points, nothing fixed)",
                st.n
            ))
        };
        if !Model::reduce(st, lins, 0.0, false, red) {
            return Err(singular());
        }
        if st.nr > 0 {
            let dependent = |col: usize| {
                let c = st.coff.partition_point(|&o| o <= col) - 1;
                SolveError::Dependent(self.model.keys[st.cblocks[c]])
            };
            match linear.regularity(st, red) {
                Ok(None) => {}
                Ok(Some(col)) | Err(FactorFailure::Pivot(col)) => return Err(dependent(col)),
                Err(FactorFailure::Resources(what)) => return Err(SolveError::TooLarge(what)),
            }
        }
        if let Ok(mut r) = self.caches.regular_for.lock() {
            *r = Some(st.hash);
        }
        Ok(())
    }
}

impl Problem {
    /// Every free block that its own observations do not determine, at the current values
    /// (see `Model::undetermined_blocks`); the caller may leave them out and solve the rest.
    pub fn undetermined(&mut self) -> Result<Vec<super::key::Key>, SolveError> {
        let st = self.structure();
        let mut lins = Linearisation::default();
        self.model.linearise(&st, &self.model.values, &mut lins)?;
        Ok(self
            .model
            .undetermined_blocks(&st, &lins)
            .into_iter()
            .map(|b| self.model.keys[b])
            .collect())
    }
}

impl Model {
    /// The free blocks not determined by their own observations (a point seen by one ray, a
    /// camera without points): their diagonal block of the normals is singular after
    /// scaling (see [`regular`]), as block indices.
    pub(crate) fn undetermined_blocks(&self, st: &Structure, lin: &Linearisation) -> Vec<usize> {
        let mut out = Vec::new();
        let mut cm: Vec<DMatrix<f64>> = st.cdim.iter().map(|&d| DMatrix::zeros(d, d)).collect();
        for g in &st.grads {
            let j = &lin.j[g.ja..g.ja + g.m * g.da];
            super::lin::add_atb(1.0, j, j, g.m, cm[g.c].as_mut_slice(), g.da);
        }
        for (c, m) in cm.into_iter().enumerate() {
            if !regular(m) {
                out.push(st.cblocks[c]);
            }
        }
        for eb in &st.eblocks {
            let mut m = DMatrix::<f64>::zeros(eb.dim, eb.dim);
            for t in st.terms(eb) {
                let j = &lin.j[t.jo..t.jo + t.m * eb.dim];
                super::lin::add_atb(1.0, j, j, t.m, m.as_mut_slice(), eb.dim);
            }
            if !regular(m) {
                out.push(eb.block);
            }
        }
        out
    }

    /// Every free block must be determined by its own observations: the first that is not
    /// is the error.
    pub(crate) fn check_determined(
        &self,
        st: &Structure,
        lin: &Linearisation,
    ) -> Result<(), SolveError> {
        match self.undetermined_blocks(st, lin).first() {
            Some(&b) => Err(SolveError::Undetermined(self.keys[b])),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::lin::regular;
    use nalgebra::DMatrix;

    /// Units do not decide: a pose whose angles weigh 10¹² (image rays) and whose centre
    /// weighs 0.04 (GNSS at 5 m) is determined; a rank-deficient block is not, whatever its
    /// scale; a parameter without weight is not.
    #[test]
    fn regularity_ignores_units() {
        let m = DMatrix::from_row_slice(2, 2, &[1e12, 1e4, 1e4, 0.04]);
        assert!(regular(m.clone()));
        // The unscaled test (λmin > 1e-10 λmax) would have refused it.
        let e = m.symmetric_eigenvalues();
        assert!(e.min() < 1e-10 * e.max());
        let sing = DMatrix::from_row_slice(2, 2, &[1e12, 1e6 * 2e-1, 1e6 * 2e-1, 0.04]);
        assert!(!regular(sing));
        assert!(!regular(DMatrix::from_row_slice(
            2,
            2,
            &[1.0, 0.0, 0.0, 0.0]
        )));
    }
}
