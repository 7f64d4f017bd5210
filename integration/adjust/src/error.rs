//! Why an adjustment cannot be done: every message names the file, line or element.

/// Why an adjustment cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum AdjustError {
    /// The project file or a table it names, as a whole.
    #[error("{path}: {what}")]
    Project {
        /// The file.
        path: String,
        /// What is wrong and what to do.
        what: String,
    },
    /// One line of a table.
    #[error("{path}, line {line}: {what}")]
    Input {
        /// The file.
        path: String,
        /// The line (from 1).
        line: usize,
        /// What is wrong and what to do.
        what: String,
    },
    /// The inputs do not make an adjustable problem (ids named).
    #[error("{0}")]
    Problem(String),
    /// The solver failed (blocks named with the project's ids).
    #[error("the adjustment failed: {0}")]
    Solve(String),
    /// An output could not be written.
    #[error("{path}: cannot write: {what}")]
    Write {
        /// The file.
        path: String,
        /// Why.
        what: String,
    },
}

impl From<photo::lsq::SolveError> for AdjustError {
    fn from(e: photo::lsq::SolveError) -> Self {
        AdjustError::Solve(e.to_string())
    }
}

/// The inputs do not make an adjustable problem.
pub(super) fn problem_err(what: String) -> AdjustError {
    AdjustError::Problem(what)
}
