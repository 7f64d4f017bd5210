//! The text of a BAL file: its numbers one at a time, read line by line through
//! `common::lines` (plain or gzip, no line over 1 MiB, the text never held whole), and the
//! errors of reading and solving a BAL problem. Enters: a path. Leaves: numbers with the line
//! they are on, or an error naming the file and the line.

use std::path::Path;

/// Errors reading a BAL file (or solving its problem).
#[derive(Debug, thiserror::Error)]
pub enum BalError {
    /// The file cannot be read.
    #[error("{path}: cannot read: {}", if cause.kind() == std::io::ErrorKind::InvalidData {
        "it is not text (not valid UTF-8): check that it is the BAL file meant".to_string()
    } else {
        cause.to_string()
    })]
    Io {
        /// The file.
        path: String,
        /// Why (part of the message, not a chained source: a report says it once).
        cause: std::io::Error,
    },
    /// The file is not a BAL problem.
    #[error("{path}: {what}")]
    Format {
        /// The file and line, `path:line`.
        path: String,
        /// What is wrong.
        what: String,
    },
    /// The adjustment failed.
    #[error("the adjustment failed: {0}")]
    Solve(String),
}

/// The numbers of a BAL file one at a time, read line by line; `line` is the line of the
/// number last returned (errors name it).
pub(crate) struct Numbers {
    src: common::lines::Lines,
    /// The line being read, and the byte where its next number starts.
    text: String,
    at: usize,
    pub(crate) line: usize,
    /// The file's size in bytes (what the counts may reserve for).
    pub(crate) size: usize,
}

impl Numbers {
    pub(crate) fn open(path: &Path) -> Result<Numbers, BalError> {
        let src = common::lines::Lines::open(path).map_err(BalError::from_lines)?;
        let size = std::fs::metadata(path).map_or(0, |m| m.len() as usize);
        Ok(Numbers {
            src,
            text: String::new(),
            at: 0,
            line: 1,
            size,
        })
    }

    fn place(&self) -> String {
        format!("{}:{}", self.src.path.display(), self.line)
    }

    /// Where the next whitespace-separated word is in `text`, reading lines as needed; `None`
    /// at the end.
    fn word(&mut self) -> Result<Option<std::ops::Range<usize>>, BalError> {
        loop {
            let rest = &self.text[self.at..];
            let skip = rest.len()
                - rest
                    .trim_start_matches(|c: char| c.is_ascii_whitespace())
                    .len();
            self.at += skip;
            if self.at < self.text.len() {
                let rest = &self.text[self.at..];
                let len = rest
                    .find(|c: char| c.is_ascii_whitespace())
                    .unwrap_or(rest.len());
                let start = self.at;
                self.at += len;
                self.line = self.src.line_no;
                return Ok(Some(start..start + len));
            }
            let Some(l) = self.src.next_line().map_err(BalError::from_lines)? else {
                return Ok(None);
            };
            let Ok(l) = std::str::from_utf8(l) else {
                return Err(BalError::Format {
                    path: format!("{}:{}", self.src.path.display(), self.src.line_no),
                    what: "it is not text (not valid UTF-8): check that it is the BAL file meant"
                        .into(),
                });
            };
            self.text.clear();
            self.text.push_str(l);
            self.at = 0;
        }
    }

    /// The next number, finite; `what` names it in errors.
    pub(crate) fn next(&mut self, what: &str) -> Result<f64, BalError> {
        let Some(range) = self.word()? else {
            return Err(BalError::Format {
                path: self.place(),
                what: format!("the file ends before {what}"),
            });
        };
        let tok = &self.text[range];
        let v: f64 = tok.parse().map_err(|_| BalError::Format {
            path: self.place(),
            what: format!("'{tok}' is not a number ({what})"),
        })?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(BalError::Format {
                path: self.place(),
                what: format!("{what} is not finite"),
            })
        }
    }

    /// The next number as a count: whole, at most 10¹².
    pub(crate) fn count(&mut self, what: &str) -> Result<usize, BalError> {
        let v = self.next(what)?;
        if v < 0.0 || v.fract() != 0.0 || v > 1e12 {
            return Err(BalError::Format {
                path: self.place(),
                what: format!("{what} {v} is not a whole number of at most 10¹²"),
            });
        }
        Ok(v as usize)
    }
}

impl BalError {
    /// A line read's failure as the error of this reader.
    fn from_lines(e: common::lines::Error) -> BalError {
        match e {
            common::lines::Error::Io { path, cause } => BalError::Io {
                path: path.display().to_string(),
                cause,
            },
            common::lines::Error::TooLong { path, line } => BalError::Format {
                path: format!("{}:{line}", path.display()),
                what: format!(
                    "a line longer than {} KiB: BAL files have far shorter lines; check that the right file was given",
                    common::lines::MAX_LINE >> 10
                ),
            },
        }
    }
}
