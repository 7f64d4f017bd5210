//! The data of a problem, without its caches: parameter blocks by [`Key`] with their values
//! and fixings, and factors with their noise, loss, group and removal flag. Everything the
//! solver's arithmetic reads; the caches and the public API live in `problem`.

use super::factor::Factor;
use super::factor::{FactorId, Group, Loss, Noise, Params};
use super::key::Key;
use super::value::Value;
use nalgebra::{DMatrixViewMut, DVector};
use std::collections::HashMap;

/// The most blocks one factor may touch.
pub const MAX_FACTOR_KEYS: usize = 32;

/// One factor as the problem holds it.
pub(crate) struct Entry {
    pub factor: Box<dyn Factor>,
    /// Block indices, in the order of the factor's keys.
    pub blocks: Vec<usize>,
    pub noise: Noise,
    pub loss: Loss,
    pub group: Group,
    pub removed: bool,
}

/// Blocks and factors.
#[derive(Default)]
pub(crate) struct Model {
    pub keys: Vec<Key>,
    pub index: HashMap<Key, usize>,
    pub values: Vec<Value>,
    pub fixed: Vec<bool>,
    pub entries: Vec<Entry>,
    /// Variance factor (σ² multiplier) per group.
    pub group_scale: Vec<f64>,
    /// Factors data snooping would have removed but kept, because removing them would leave
    /// a block undetermined, with their |w|.
    pub kept: Vec<(super::factor::FactorId, f64)>,
}

impl Model {
    /// The unwhitened residual r = h(x) − z of a factor at the current values (`None` when it
    /// cannot be evaluated).
    pub fn residual(&self, id: FactorId) -> Option<DVector<f64>> {
        let e = &self.entries[id.0];
        let mut r = DVector::zeros(e.factor.dim());
        let mut none: [Option<DMatrixViewMut<f64>>; MAX_FACTOR_KEYS] = Default::default();
        let x = Params::new(&self.values, &e.blocks);
        let n = e.blocks.len();
        e.factor
            .evaluate(&x, r.as_mut_slice(), &mut none[..n])
            .then_some(r)
    }
}
