//! The error of the simulator: a scenario key and what is wrong with it, or a failure to
//! write or read back a file.
//!
//! What enters: the messages of the validation, `gnss` and `common::atomic` errors. What
//! leaves: [`SimError`], returned by every part of the simulator; this module uses none of
//! them.

/// Errors of the simulator: a scenario key and what is wrong with it, or an I/O failure.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The scenario is not valid TOML or does not fit the schema.
    #[error("scenario: {0}")]
    Parse(String),
    /// A scenario value is out of range.
    #[error("scenario key `{key}`: {what}")]
    Key {
        /// The key, e.g. `flight.speed`.
        key: &'static str,
        /// What is wrong with its value.
        what: String,
    },
    /// Writing or reading back a file failed.
    #[error(transparent)]
    Gnss(#[from] gnss::Error),
    /// A simulated file (a truth file read back, a rendered photo) could not be read, parsed
    /// or encoded.
    #[error("{path}: {what}")]
    File {
        /// The file.
        path: String,
        /// What went wrong, and what to do.
        what: String,
    },
}

/// A failed whole-output write, as the [`gnss::Error`] of the same message.
impl From<common::atomic::Error> for SimError {
    fn from(e: common::atomic::Error) -> Self {
        SimError::Gnss(e.into())
    }
}
