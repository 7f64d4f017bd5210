//! Solver settings.

use super::key::KeyKind;

/// Solver settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Iterations of Levenberg–Marquardt (accepted or not).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction.
    pub function_tolerance: f64,
    /// Initial trust-region radius: the damping is 1/radius on the clamped diagonal.
    pub initial_radius: f64,
    /// Largest reduced system solved by dense Cholesky (and inverted densely for
    /// statistics); larger ones go to faer's sparse Cholesky with the symbolic factorisation
    /// kept while the structure holds, and their statistics to the selected inverse.
    pub dense_limit: usize,
    /// Kinds of blocks eliminated by the Schur complement (object points by default).
    pub eliminate: Vec<KeyKind>,
    /// Threads the solver runs on (`None`: rayon's pool), as reported; the work runs on the
    /// current rayon pool, which the caller sizes. Results are bit-identical whatever the
    /// number (faer is always given one degree of parallelism).
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
