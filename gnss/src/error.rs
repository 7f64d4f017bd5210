//! Typed errors of the `gnss` crate. Every error names the file (and the line or epoch where
//! that applies) and says what the user can do about it.

use std::path::PathBuf;

/// Everything that can go wrong while reading GNSS files or positioning.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file could not be opened or read. (The system's error is part of the message, not
    /// a chained source, so that a report of the whole chain says it once.)
    #[error("{path}: cannot read: {}", read_advice(.cause))]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        cause: std::io::Error,
    },
    /// The output file could not be written.
    #[error("{path}: cannot write: {cause}; check that its folder exists and is writable")]
    Write {
        /// The file.
        path: PathBuf,
        /// What the system said.
        cause: std::io::Error,
    },
    /// A line of the file does not follow the format.
    #[error("{path}:{line}: {what}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong and what to do.
        what: String,
    },
    /// The file as a whole is not what was asked for (wrong kind, unknown version, empty …).
    #[error("{path}: {what}")]
    Input {
        /// The file.
        path: PathBuf,
        /// What is wrong and what to do.
        what: String,
    },
    /// Inputs that are each fine but cannot be used together, or leave nothing to compute.
    #[error("{0}")]
    NoData(String),
}

/// What the system said about a failed read, and what to do about it: a file that is there
/// but is not text gets no advice to check that it exists.
pub fn read_advice(e: &std::io::Error) -> String {
    use std::io::ErrorKind as K;
    match e.kind() {
        K::InvalidData => {
            "it is not text (not valid UTF-8): check that it is the file meant, not a binary \
             or compressed one"
                .into()
        }
        K::NotFound => format!("{e}; check the path"),
        K::PermissionDenied => format!("{e}; check that the file is readable"),
        K::IsADirectory => format!("{e}; give a file, not a folder"),
        _ => format!("{e}; check that the path exists and is readable"),
    }
}

/// A failed whole-output write (`common::atomic`) as the same variant, with the same message.
impl From<common::atomic::Error> for Error {
    fn from(e: common::atomic::Error) -> Self {
        match e {
            common::atomic::Error::Write { path, cause } => Error::Write { path, cause },
            common::atomic::Error::Input { path, what } => Error::Input { path, what },
        }
    }
}

/// A failed line read (`common::lines`, every text input of this crate) as the error the
/// readers gave before they shared it: I/O as [`Error::Io`], an overlong line as a parse error
/// naming the kinds of file read here.
impl From<common::lines::Error> for Error {
    fn from(e: common::lines::Error) -> Self {
        match e {
            common::lines::Error::Io { path, cause } => Error::Io { path, cause },
            common::lines::Error::TooLong { path, line } => Error::parse(
                &path,
                line,
                format!(
                    "line longer than {} KiB: not a text file of the expected kind (RINEX, SP3, \
                     clock or ANTEX); check that the right file was given",
                    common::lines::MAX_LINE >> 10
                ),
            ),
        }
    }
}

/// Result alias of the `gnss` crate.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// A [`Error::Parse`] at `line` of `path`.
    pub fn parse(path: &std::path::Path, line: usize, what: impl Into<String>) -> Self {
        Error::Parse {
            path: path.to_path_buf(),
            line,
            what: what.into(),
        }
    }
    /// A function turning an I/O failure on `path` into an [`Error::Io`] (for `map_err`).
    pub fn io(path: &std::path::Path) -> impl Fn(std::io::Error) -> Error + Copy + '_ {
        move |cause| Error::Io {
            path: path.to_path_buf(),
            cause,
        }
    }
    /// An [`Error::Input`] about `path`.
    pub fn input(path: &std::path::Path, what: impl Into<String>) -> Self {
        Error::Input {
            path: path.to_path_buf(),
            what: what.into(),
        }
    }
}
