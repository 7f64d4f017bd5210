//! Why an adjustment fails.

use super::factor::FactorId;
use super::key::Key;

/// Why an adjustment fails.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// The normal equations could not be factorised.
    #[error("the normal equations are singular: {0}")]
    Singular(String),
    /// A block's own observations do not determine it.
    #[error(
        "{0} is not determined by its observations (observed too few times, or only along one ray)"
    )]
    Undetermined(Key),
    /// A block's unknowns depend on the others'.
    #[error("the normal equations are singular at {0}: a datum defect (no control, nothing fixed) or unknowns that cannot be told apart")]
    Dependent(Key),
    /// More unknowns than residual components.
    #[error("more unknowns ({0}) than observations ({1})")]
    Underdetermined(usize, usize),
    /// The normal equations do not fit in memory (or in the index range).
    #[error("the normal equations are too large to factorise: {0}")]
    TooLarge(String),
    /// A factor cannot be evaluated at the current values.
    #[error("factor {} cannot be evaluated (a point behind its camera?)", .0.0)]
    Evaluation(FactorId),
}
