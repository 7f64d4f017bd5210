//! The problem: parameter blocks by [`Key`], factors with their noise, loss and group, and
//! what the solver keeps between calls (structure, symbolic factorisation, cofactors).

use super::factor::{Factor, FactorId, Group, Loss, Noise, Params};
use super::key::{Key, KeyKind};
use super::linear::SymbolicCache;
use super::stats::SharedCofactors;
use super::structure::Structure;
use super::value::Value;
use nalgebra::{DMatrixViewMut, DVector};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The most blocks one factor may touch.
pub const MAX_FACTOR_KEYS: usize = 8;

/// Solver settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Iterations of Levenberg–Marquardt (accepted or not).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction.
    pub function_tolerance: f64,
    /// Initial trust-region radius: the damping is 1/radius on the clamped diagonal.
    pub initial_radius: f64,
    /// Largest reduced system solved by dense Cholesky; larger ones go to faer's sparse
    /// Cholesky with the symbolic factorisation kept while the structure holds.
    pub dense_limit: usize,
    /// Kinds of blocks eliminated by the Schur complement (object points by default).
    pub eliminate: Vec<KeyKind>,
    /// Threads for faer's factorisations (`None`: rayon's pool). Results are bit-identical
    /// whatever the number.
    pub threads: Option<usize>,
    /// Require a unique solution: every free block determined by its own observations and
    /// the normals regular (a datum). Off for problems with a gauge freedom, such as BAL.
    pub unique: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            max_iterations: 50,
            function_tolerance: 1e-12,
            initial_radius: 1e4,
            dense_limit: 3000,
            eliminate: vec![KeyKind::Point],
            threads: None,
            unique: true,
        }
    }
}

/// Why a problem cannot be built as asked.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// The key is already taken by another block.
    #[error("{0} is added twice")]
    DuplicateKey(Key),
    /// A factor or a call names a block that was never added.
    #[error("{0} is not a block of the problem")]
    UnknownKey(Key),
    /// A factor names one block twice, or more than [`MAX_FACTOR_KEYS`].
    #[error("a factor must name between 1 and {MAX_FACTOR_KEYS} different blocks ({0})")]
    Keys(String),
    /// The noise model weights another number of components than the factor has.
    #[error("the noise model has {noise} components, the factor {factor}")]
    NoiseDimension {
        /// Components of the noise model.
        noise: usize,
        /// Components of the factor.
        factor: usize,
    },
}

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

/// A timed stage of the solver (for benchmarks).
#[derive(Clone, Debug, PartialEq)]
pub struct Timing {
    /// What was timed.
    pub what: &'static str,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// What is kept between calls.
#[derive(Default)]
pub(crate) struct Caches {
    pub structure: Mutex<Option<Arc<Structure>>>,
    pub symbolic: Mutex<Option<SymbolicCache>>,
    pub cofactors: Mutex<Option<(u64, SharedCofactors)>>,
    /// Structure hash for which the undamped normals were last found regular.
    pub regular_for: Mutex<Option<u64>>,
    pub timings: Mutex<Vec<Timing>>,
}

/// A least-squares problem over typed parameter blocks.
pub struct Problem {
    /// Solver settings.
    pub options: Options,
    pub(crate) keys: Vec<Key>,
    pub(crate) index: HashMap<Key, usize>,
    pub(crate) values: Vec<Value>,
    pub(crate) fixed: Vec<bool>,
    pub(crate) entries: Vec<Entry>,
    /// Variance factor (σ² multiplier) per group.
    pub(crate) group_scale: Vec<f64>,
    pub(crate) caches: Caches,
}

impl Problem {
    /// An empty problem.
    pub fn new(options: Options) -> Problem {
        Problem {
            options,
            keys: Vec::new(),
            index: HashMap::new(),
            values: Vec::new(),
            fixed: Vec::new(),
            entries: Vec::new(),
            group_scale: vec![1.0],
            caches: Caches::default(),
        }
    }

    /// Add a free block.
    pub fn add_block(&mut self, key: Key, value: Value) -> Result<(), BuildError> {
        if self.index.contains_key(&key) {
            return Err(BuildError::DuplicateKey(key));
        }
        self.index.insert(key, self.values.len());
        self.keys.push(key);
        self.values.push(value);
        self.fixed.push(false);
        Ok(())
    }

    /// Hold a block at its value (`true`) or let it be estimated (`false`).
    pub fn set_fixed(&mut self, key: Key, fixed: bool) -> Result<(), BuildError> {
        let b = self.block(key)?;
        self.fixed[b] = fixed;
        Ok(())
    }

    /// Whether the block is held at its value.
    pub fn is_fixed(&self, key: Key) -> bool {
        self.index.get(&key).is_some_and(|&b| self.fixed[b])
    }

    /// Whether the problem has this block.
    pub fn contains(&self, key: Key) -> bool {
        self.index.contains_key(&key)
    }

    /// The current value of a block.
    pub fn value(&self, key: Key) -> Option<&Value> {
        self.index.get(&key).map(|&b| &self.values[b])
    }

    /// Every block key, in the order added.
    pub fn keys(&self) -> &[Key] {
        &self.keys
    }

    pub(crate) fn block(&self, key: Key) -> Result<usize, BuildError> {
        self.index
            .get(&key)
            .copied()
            .ok_or(BuildError::UnknownKey(key))
    }

    /// Add a factor with its noise model, loss and group.
    pub fn add_factor(
        &mut self,
        factor: impl Factor,
        noise: Noise,
        loss: Loss,
        group: Group,
    ) -> Result<FactorId, BuildError> {
        let keys = factor.keys();
        let distinct = keys.iter().enumerate().all(|(i, k)| !keys[..i].contains(k));
        if keys.is_empty() || keys.len() > MAX_FACTOR_KEYS || !distinct {
            return Err(BuildError::Keys(format!("{keys:?}")));
        }
        if let Some(n) = noise.dim().filter(|n| *n != factor.dim()) {
            return Err(BuildError::NoiseDimension {
                noise: n,
                factor: factor.dim(),
            });
        }
        let blocks = keys
            .iter()
            .map(|k| self.block(*k))
            .collect::<Result<Vec<_>, _>>()?;
        if group.0 >= self.group_scale.len() {
            self.group_scale.resize(group.0 + 1, 1.0);
        }
        self.entries.push(Entry {
            factor: Box::new(factor),
            blocks,
            noise,
            loss,
            group,
            removed: false,
        });
        Ok(FactorId(self.entries.len() - 1))
    }

    /// Number of factors (removed ones included).
    pub fn num_factors(&self) -> usize {
        self.entries.len()
    }

    /// Every factor with its id (removed ones included).
    pub fn factors(&self) -> impl Iterator<Item = (FactorId, &dyn Factor)> + '_ {
        self.entries
            .iter()
            .enumerate()
            .map(|(i, e)| (FactorId(i), e.factor.as_ref()))
    }

    /// A factor as its concrete type, when it is one.
    pub fn factor_as<T: Factor>(&self, id: FactorId) -> Option<&T> {
        let f: &dyn std::any::Any = self.entries.get(id.0)?.factor.as_ref();
        f.downcast_ref::<T>()
    }

    /// The factor's noise model.
    pub fn noise(&self, id: FactorId) -> &Noise {
        &self.entries[id.0].noise
    }

    /// The factor's group.
    pub fn group(&self, id: FactorId) -> Group {
        self.entries[id.0].group
    }

    /// Whether data snooping (or the caller) removed the factor.
    pub fn is_removed(&self, id: FactorId) -> bool {
        self.entries[id.0].removed
    }

    /// Leave a factor out of the adjustment (it stays listed).
    pub fn remove(&mut self, id: FactorId) {
        self.entries[id.0].removed = true;
    }

    /// The variance factor (σ² multiplier) of a group: 1 until variance components are
    /// estimated.
    pub fn group_scale(&self, g: Group) -> f64 {
        self.group_scale.get(g.0).copied().unwrap_or(1.0)
    }

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

    /// The timed stages so far (solves, cofactor computations), emptied by the call.
    pub fn take_timings(&self) -> Vec<Timing> {
        self.caches
            .timings
            .lock()
            .map(|mut t| std::mem::take(&mut *t))
            .unwrap_or_default()
    }

    pub(crate) fn time(&self, what: &'static str, since: std::time::Instant) {
        if let Ok(mut t) = self.caches.timings.lock() {
            t.push(Timing {
                what,
                seconds: since.elapsed().as_secs_f64(),
            });
        }
    }
}
