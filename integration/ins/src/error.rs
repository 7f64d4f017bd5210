//! Errors of the INS crate: values that name the file, the line or key, and what to do.

use std::path::PathBuf;

/// What went wrong, with where.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read.
    #[error("{path}: cannot read: {cause}; check the path")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        cause: std::io::Error,
    },
    /// An output could not be written.
    #[error(transparent)]
    Write(#[from] common::atomic::Error),
    /// A GNSS-format output could not be written.
    #[error(transparent)]
    Gnss(#[from] gnss::Error),
    /// A file's content is not what it should be.
    #[error("{path}: {message}")]
    Input {
        /// The file.
        path: PathBuf,
        /// What is wrong there and what to do.
        message: String,
    },
}

/// The crate's result.
pub type Result<T> = std::result::Result<T, Error>;
