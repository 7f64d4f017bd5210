//! What an observation is to the solver: a [`Factor`] (keys, residual, Jacobians), a
//! [`Noise`] model that whitens it, a robust [`Loss`], and a [`Group`] for variance
//! components. The solver never knows what a factor means.
//!
//! Contract (as Ceres' `CostFunction`): the residual is r = h(x) − z, unwhitened; Jacobian
//! slot k is ∂r/∂δ_k, a column-major `dim × block_dim` matrix, with δ the block's tangent
//! step (see [`Value::plus`](super::Value::plus)). The noise model whitens r and J
//! (r_w = L⁻¹·r for a covariance Σ = L·Lᵀ); the loss ρ acts on s² = ‖r_w‖², the cost of the
//! factor being ½ρ(s²).

use super::key::Key;
use super::value::Value;
use crate::camera::Pose;
use nalgebra::{DMatrix, DMatrixViewMut, DVector, Matrix3, Vector3};
use std::any::Any;

/// An observation model: which blocks it touches, its residual and Jacobians.
pub trait Factor: Any + Send + Sync {
    /// The blocks it touches, in the order [`Factor::evaluate`] receives them (no key twice).
    fn keys(&self) -> &[Key];
    /// Number of residual components.
    fn dim(&self) -> usize;
    /// Write r = h(x) − z into `residual` and, for every `Some` slot of `jacobians`, ∂r/∂δ of
    /// that block — every entry of it: the buffers are not cleared beforehand (slots are
    /// `None` for fixed blocks and when only the cost is wanted).
    /// Returns `false` when the model cannot be evaluated there (a point behind its camera).
    fn evaluate(
        &self,
        x: &Params<'_>,
        residual: &mut [f64],
        jacobians: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool;
}

/// The [`Factor::keys`] of a factor that keeps its keys in a field `keys` (a `Vec<Key>`):
/// the one method every factor writes alike, written once. Use it inside the `impl Factor`:
/// `photo::keys_in_field!();`.
#[macro_export]
macro_rules! keys_in_field {
    () => {
        fn keys(&self) -> &[$crate::lsq::Key] {
            &self.keys
        }
    };
}

/// The values of a factor's blocks, in the order of its keys.
pub struct Params<'a> {
    values: &'a [Value],
    blocks: &'a [usize],
}

/// Indices 0, 1, 2 … for [`Params::in_order`].
const IN_ORDER: [usize; 16] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15];

impl<'a> Params<'a> {
    /// The blocks `blocks` (indices into `values`).
    pub fn new(values: &'a [Value], blocks: &'a [usize]) -> Params<'a> {
        Params { values, blocks }
    }

    /// `values` themselves, in order (at most 16): for evaluating a factor by hand.
    pub fn in_order(values: &'a [Value]) -> Params<'a> {
        Params {
            values,
            blocks: &IN_ORDER[..values.len()],
        }
    }

    /// The value of the factor's k-th block.
    pub fn get(&self, k: usize) -> &'a Value {
        &self.values[self.blocks[k]]
    }

    /// The k-th block as a pose.
    pub fn pose(&self, k: usize) -> Option<&'a Pose> {
        self.get(k).pose()
    }

    /// The k-th block as a vector.
    pub fn vector(&self, k: usize) -> Option<&'a DVector<f64>> {
        self.get(k).vector()
    }

    /// The k-th block as a 3-D point.
    pub fn point(&self, k: usize) -> Option<Vector3<f64>> {
        self.get(k).as_point()
    }

    /// The k-th block as a rotation and a vector.
    pub fn rotated(&self, k: usize) -> Option<(&'a Matrix3<f64>, &'a DVector<f64>)> {
        self.get(k).rotated()
    }
}

/// Identifies a factor of a problem (the order in which it was added).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FactorId(pub usize);

/// An observation group: factors whose variance factor is estimated together.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Group(pub usize);

/// How a factor's residual is weighted.
#[derive(Clone, Debug, PartialEq)]
pub enum Noise {
    /// σ = 1 for every component (unit weights, as in BAL).
    Unit,
    /// Independent components with these σ.
    Sigmas(DVector<f64>),
    /// Correlated components: `whiten` = L⁻¹ for the covariance Σ = L·Lᵀ; `sigmas` = √diag Σ.
    Covariance {
        /// L⁻¹ (lower triangular).
        whiten: DMatrix<f64>,
        /// √diag Σ.
        sigmas: DVector<f64>,
    },
}

impl Noise {
    /// `n` components with the same σ.
    pub fn isotropic(n: usize, sigma: f64) -> Noise {
        Noise::Sigmas(DVector::from_element(n, sigma))
    }

    /// Independent components.
    pub fn sigmas(s: &[f64]) -> Noise {
        Noise::Sigmas(DVector::from_column_slice(s))
    }

    /// A full covariance; `None` when it is not positive definite.
    pub fn covariance(c: &DMatrix<f64>) -> Option<Noise> {
        let l = c.clone().cholesky()?.l();
        let whiten = l.try_inverse()?;
        let sigmas = DVector::from_iterator(c.nrows(), (0..c.nrows()).map(|i| c[(i, i)].sqrt()));
        Some(Noise::Covariance { whiten, sigmas })
    }

    /// The same weighting with every σ multiplied by `f` (`dim` components for [`Noise::Unit`]).
    pub fn scaled(&self, f: f64, dim: usize) -> Noise {
        match self {
            Noise::Unit => Noise::isotropic(dim, f),
            Noise::Sigmas(s) => Noise::Sigmas(s * f),
            Noise::Covariance { whiten, sigmas } => Noise::Covariance {
                whiten: whiten / f,
                sigmas: sigmas * f,
            },
        }
    }

    /// The number of components it weights (`None`: any).
    pub fn dim(&self) -> Option<usize> {
        match self {
            Noise::Unit => None,
            Noise::Sigmas(s) => Some(s.len()),
            Noise::Covariance { sigmas, .. } => Some(sigmas.len()),
        }
    }

    /// σ of component `i` (for correlated components: √Σᵢᵢ).
    pub fn sigma(&self, i: usize) -> f64 {
        match self {
            Noise::Unit => 1.0,
            Noise::Sigmas(s) => s[i],
            Noise::Covariance { sigmas, .. } => sigmas[i],
        }
    }

    /// Whiten a residual and its Jacobian columns in place, with every variance multiplied by
    /// `scale` (the group's variance factor). `j` holds `cols` columns of `r.len()` rows.
    #[inline]
    pub(crate) fn whiten(&self, scale: f64, r: &mut [f64], j: &mut [f64]) {
        let m = r.len();
        let s = 1.0 / scale.sqrt();
        match self {
            Noise::Unit => {
                if scale != 1.0 {
                    r.iter_mut().chain(j.iter_mut()).for_each(|x| *x *= s);
                }
            }
            Noise::Sigmas(sig) => {
                for (i, x) in r.iter_mut().enumerate() {
                    *x /= sig[i] * scale.sqrt();
                }
                for col in j.chunks_exact_mut(m) {
                    for (i, x) in col.iter_mut().enumerate() {
                        *x /= sig[i] * scale.sqrt();
                    }
                }
            }
            Noise::Covariance { whiten, .. } => {
                let mut tmp = vec![0.0; m];
                let mut apply = |v: &mut [f64]| {
                    for (i, t) in tmp.iter_mut().enumerate() {
                        *t = (0..=i).map(|k| whiten[(i, k)] * v[k]).sum::<f64>() * s;
                    }
                    v.copy_from_slice(&tmp);
                };
                apply(r);
                j.chunks_exact_mut(m).for_each(apply);
            }
        }
    }
}

/// A robust loss ρ on the squared whitened residual norm s² (in units of σ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Loss {
    /// ρ(s²) = s²: plain least squares.
    Trivial,
    /// Quadratic up to s = k, linear beyond.
    Huber(f64),
    /// ρ(s²) = c²·ln(1 + s²/c²).
    Cauchy(f64),
}

impl Loss {
    /// ρ′(s²) at the whitened norm s: the weight of iteratively reweighted least squares.
    pub fn weight(self, s: f64) -> f64 {
        match self {
            Loss::Trivial => 1.0,
            Loss::Huber(k) if s <= k => 1.0,
            Loss::Huber(k) => k / s,
            Loss::Cauchy(c) => 1.0 / (1.0 + (s / c).powi(2)),
        }
    }

    /// The factor's cost ½ρ(s²) for the squared whitened norm `s2`.
    pub fn cost(self, s2: f64) -> f64 {
        match self {
            Loss::Trivial => 0.5 * s2,
            Loss::Huber(k) if s2 <= k * k => 0.5 * s2,
            Loss::Huber(k) => k * s2.sqrt() - 0.5 * k * k,
            Loss::Cauchy(c) => 0.5 * c * c * (s2 / (c * c)).ln_1p(),
        }
    }
}
