//! The problem: parameter blocks by [`Key`], factors with their noise, loss and group, and
//! what the solver keeps between calls (structure, symbolic factorisation, cofactors).

use super::cofactor::Cofactors;
use super::factor::{Factor, FactorId, Group, Loss, Noise};
use super::key::Key;
use super::linear::SymbolicCache;
pub use super::model::MAX_FACTOR_KEYS;
use super::model::{Entry, Model};
pub use super::options::Options;
use super::structure::Structure;
use super::value::Value;
use nalgebra::DVector;
use std::sync::{Arc, Mutex};

/// Why a problem cannot be built as asked.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// The key is already taken by another block.
    #[error("{0} is added twice")]
    DuplicateKey(Key),
    /// A factor or a call names a block that was never added.
    #[error("{0} is not a block of the problem")]
    UnknownKey(Key),
    /// A new value does not match the block's kind or size.
    #[error("{0}: a value of another kind or size")]
    ValueShape(Key),
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
    pub cofactors: Mutex<Option<(u64, Arc<Cofactors>)>>,
    /// Structure hash for which the undamped normals were last found regular.
    pub regular_for: Mutex<Option<u64>>,
    /// The trust-region radius the last solve ended with: a problem solved again after
    /// snooping removed observations or variance components reweighted them starts there
    /// (a few Gauss–Newton steps) instead of climbing from the initial radius again (about
    /// ten steps each time). Forgotten when values, blocks or what is fixed change.
    pub radius: Mutex<Option<f64>>,
    pub timings: Mutex<Vec<Timing>>,
}

/// A step of the solver, told to an [`Observer`] as it happens (for a progress display).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolveStep {
    /// A Levenberg–Marquardt iteration begins: its number (from 1) and the most allowed.
    Iteration(usize, usize),
    /// A round of data snooping begins (from 1): one solve, then the worst residual tested.
    SnoopingRound(usize),
}

/// Told every [`SolveStep`]; it must not panic. Results do not depend on it.
pub type Observer = std::sync::Arc<dyn Fn(SolveStep) + Send + Sync>;

/// A least-squares problem over typed parameter blocks.
pub struct Problem {
    /// Solver settings.
    pub options: Options,
    pub(crate) model: Model,
    pub(crate) caches: Caches,
    observer: Option<Observer>,
}

impl Problem {
    /// An empty problem.
    pub fn new(options: Options) -> Problem {
        Problem {
            options,
            model: Model {
                group_scale: vec![1.0],
                ..Model::default()
            },
            caches: Caches::default(),
            observer: None,
        }
    }

    /// Watch the solver's iterations and snooping rounds (`None`: nobody watches).
    pub fn set_observer(&mut self, observer: Option<Observer>) {
        self.observer = observer;
    }

    /// Tell the observer, if any, of a step.
    pub(crate) fn notify(&self, step: SolveStep) {
        if let Some(o) = &self.observer {
            o(step);
        }
    }

    /// Add a free block.
    pub fn add_block(&mut self, key: Key, value: Value) -> Result<(), BuildError> {
        if self.model.index.contains_key(&key) {
            return Err(BuildError::DuplicateKey(key));
        }
        self.model.index.insert(key, self.model.values.len());
        self.model.keys.push(key);
        self.model.values.push(value);
        self.model.fixed.push(false);
        self.forget_radius();
        Ok(())
    }

    /// Hold a block at its value (`true`) or let it be estimated (`false`).
    pub fn set_fixed(&mut self, key: Key, fixed: bool) -> Result<(), BuildError> {
        let b = self.block(key)?;
        self.model.fixed[b] = fixed;
        self.forget_radius();
        Ok(())
    }

    /// Replace a block's value (of the same kind and size: an error otherwise), e.g. to hold
    /// it at an integer with [`Self::set_fixed`].
    pub fn set_value(&mut self, key: Key, value: Value) -> Result<(), BuildError> {
        let b = self.block(key)?;
        let old = &self.model.values[b];
        if std::mem::discriminant(old) != std::mem::discriminant(&value) || old.dim() != value.dim()
        {
            return Err(BuildError::ValueShape(key));
        }
        self.model.values[b] = value;
        self.forget_radius();
        Ok(())
    }

    /// The next solve starts from the initial trust-region radius.
    fn forget_radius(&mut self) {
        if let Ok(r) = self.caches.radius.get_mut() {
            *r = None;
        }
    }

    /// Whether the block is held at its value.
    pub fn is_fixed(&self, key: Key) -> bool {
        self.model
            .index
            .get(&key)
            .is_some_and(|&b| self.model.fixed[b])
    }

    /// Whether the problem has this block.
    pub fn contains(&self, key: Key) -> bool {
        self.model.index.contains_key(&key)
    }

    /// The current value of a block.
    pub fn value(&self, key: Key) -> Option<&Value> {
        self.model.index.get(&key).map(|&b| &self.model.values[b])
    }

    /// Every block key, in the order added.
    pub fn keys(&self) -> &[Key] {
        &self.model.keys
    }

    pub(crate) fn block(&self, key: Key) -> Result<usize, BuildError> {
        self.model
            .index
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
        if group.0 >= self.model.group_scale.len() {
            self.model.group_scale.resize(group.0 + 1, 1.0);
        }
        self.model.entries.push(Entry {
            factor: Box::new(factor),
            blocks,
            noise,
            loss,
            group,
            removed: false,
        });
        Ok(FactorId(self.model.entries.len() - 1))
    }

    /// Number of factors (removed ones included).
    pub fn num_factors(&self) -> usize {
        self.model.entries.len()
    }

    /// Every factor with its id (removed ones included).
    pub fn factors(&self) -> impl Iterator<Item = (FactorId, &dyn Factor)> + '_ {
        self.model
            .entries
            .iter()
            .enumerate()
            .map(|(i, e)| (FactorId(i), e.factor.as_ref()))
    }

    /// A factor as its concrete type, when it is one.
    pub fn factor_as<T: Factor>(&self, id: FactorId) -> Option<&T> {
        let f: &dyn std::any::Any = self.model.entries.get(id.0)?.factor.as_ref();
        f.downcast_ref::<T>()
    }

    /// The factor's noise model.
    pub fn noise(&self, id: FactorId) -> &Noise {
        &self.model.entries[id.0].noise
    }

    /// The factor's group.
    pub fn group(&self, id: FactorId) -> Group {
        self.model.entries[id.0].group
    }

    /// Whether data snooping (or the caller) removed the factor.
    pub fn is_removed(&self, id: FactorId) -> bool {
        self.model.entries[id.0].removed
    }

    /// Leave a factor out of the adjustment (it stays listed).
    pub fn remove(&mut self, id: FactorId) {
        self.model.entries[id.0].removed = true;
    }

    /// The variance factor (σ² multiplier) of a group: 1 until variance components are
    /// estimated.
    pub fn group_scale(&self, g: Group) -> f64 {
        self.model.group_scale.get(g.0).copied().unwrap_or(1.0)
    }

    /// The unwhitened residual r = h(x) − z of a factor at the current values (`None` when it
    /// cannot be evaluated).
    pub fn residual(&self, id: FactorId) -> Option<DVector<f64>> {
        self.model.residual(id)
    }

    /// The structure for the current shape (cached).
    pub(crate) fn structure(&self) -> Arc<Structure> {
        let hash = self.model.shape_hash(&self.options.eliminate);
        if let Ok(mut c) = self.caches.structure.lock() {
            if let Some(s) = c.as_ref().filter(|s| s.hash == hash) {
                return s.clone();
            }
            let t = std::time::Instant::now();
            let s = Arc::new(self.model.build_structure(&self.options.eliminate, hash));
            *c = Some(s.clone());
            drop(c);
            self.time("structure", t);
            return s;
        }
        Arc::new(self.model.build_structure(&self.options.eliminate, hash))
    }

    /// The timed stages so far, emptied by the call: "structure" (the normal equations'
    /// shape), "iteration" (one Levenberg–Marquardt step), "solve" (its iterations and
    /// checks), "cofactors", "statistics" (cofactors when not cached, covariances and
    /// reliability), "snooping" (its solves and cofactors included), and the caller's
    /// [`Self::record_time`].
    pub fn take_timings(&self) -> Vec<Timing> {
        self.caches
            .timings
            .lock()
            .map(|mut t| std::mem::take(&mut *t))
            .unwrap_or_default()
    }

    /// Add a timed stage of the caller's (e.g. building the problem) to [`Self::take_timings`].
    pub fn record_time(&self, what: &'static str, seconds: f64) {
        if let Ok(mut t) = self.caches.timings.lock() {
            t.push(Timing { what, seconds });
        }
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
