//! Text read line by line with a bound on every line, plain or gzip-compressed, into one
//! reused buffer: a file is streamed rather than held in memory, and a file of garbage (or a
//! binary file given by mistake) costs at most [`MAX_LINE`] bytes before it is refused.
//!
//! Enters: a path (or any reader). Leaves: lines without their end-of-line characters, with
//! their 1-based numbers; errors name the file (and the line) and are converted by each
//! reader into its own error type, with the file kind it expects in the message.

use flate2::read::MultiGzDecoder;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

/// The longest line read, end-of-line included (1 MiB). A RINEX 3 observation line with 999
/// types is 16 kB, a BAL or CSV line far less.
pub const MAX_LINE: usize = 1 << 20;

/// What can go wrong while reading lines. Shown as `path:line: reason` (`path: reason` without
/// a line); readers with their own error type take [`Error::line`] and [`Error::reason`].
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be opened or read.
    #[error("{}: {}", path.display(), self.reason())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system (or the gzip decoder) said.
        cause: std::io::Error,
    },
    /// A line is longer than [`MAX_LINE`]: not a text file of the kind expected.
    #[error("{}:{line}: {}", path.display(), self.reason())]
    TooLong {
        /// The file.
        path: PathBuf,
        /// 1-based number of the line.
        line: usize,
    },
}

impl Error {
    /// The line the error is at, when it is at one.
    pub fn line(&self) -> Option<usize> {
        match self {
            Error::Io { .. } => None,
            Error::TooLong { line, .. } => Some(*line),
        }
    }

    /// What is wrong and what to do, without the file and line.
    pub fn reason(&self) -> String {
        match self {
            Error::Io { cause, .. } => format!("cannot read: {cause}"),
            Error::TooLong { .. } => format!(
                "line longer than {} KiB: not a text file of the expected kind; check that the \
                 right file was given",
                MAX_LINE >> 10
            ),
        }
    }
}

/// A text file read line by line, transparently gunzipped when it starts with the gzip magic.
pub struct Lines {
    inner: Box<dyn BufRead + Send>,
    buf: Vec<u8>,
    /// 1-based number of the line last returned.
    pub line_no: usize,
    /// The file.
    pub path: PathBuf,
    /// Bytes of (decompressed) text read so far.
    pub bytes: u64,
}

impl Lines {
    /// Open a file (gzip detected by its magic bytes).
    pub fn open(path: &Path) -> Result<Self, Error> {
        let io = |cause| Error::Io {
            path: path.to_path_buf(),
            cause,
        };
        let mut file = File::open(path).map_err(io)?;
        let mut magic = [0u8; 2];
        let n = read_up_to(&mut file, &mut magic).map_err(io)?;
        let file = File::open(path).map_err(io)?;
        let inner: Box<dyn BufRead + Send> = if n == 2 && magic == [0x1f, 0x8b] {
            Box::new(BufReader::with_capacity(
                1 << 16,
                MultiGzDecoder::new(BufReader::new(file)),
            ))
        } else {
            Box::new(BufReader::with_capacity(1 << 16, file))
        };
        Ok(Lines {
            inner,
            buf: Vec::with_capacity(256),
            line_no: 0,
            path: path.to_path_buf(),
            bytes: 0,
        })
    }

    /// Lines from any reader (used by tests and by in-memory sources); `path` names it in
    /// errors.
    pub fn from_reader(path: &Path, r: impl Read + Send + 'static) -> Self {
        Lines {
            inner: Box::new(BufReader::new(r)),
            buf: Vec::with_capacity(256),
            line_no: 0,
            path: path.to_path_buf(),
            bytes: 0,
        }
    }

    /// The next line without its end-of-line characters, or `None` at the end of the file.
    /// A line longer than [`MAX_LINE`] is an error ([`Error::TooLong`]): reading on would hold
    /// a whole file of garbage (or of gzip) in one buffer.
    pub fn next_line(&mut self) -> Result<Option<&[u8]>, Error> {
        self.buf.clear();
        let n = (&mut self.inner)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut self.buf)
            .map_err(|cause| Error::Io {
                path: self.path.clone(),
                cause,
            })?;
        if n == 0 {
            return Ok(None);
        }
        self.bytes += n as u64;
        self.line_no += 1;
        if n > MAX_LINE {
            return Err(Error::TooLong {
                path: self.path.clone(),
                line: self.line_no,
            });
        }
        while matches!(self.buf.last(), Some(b'\n' | b'\r')) {
            self.buf.pop();
        }
        Ok(Some(&self.buf))
    }
}

/// Fill `buf` from `r` as far as the reader goes; the count read.
fn read_up_to(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn plain_and_gzip_lines_come_back_with_their_numbers() {
        let text = b"first\r\nsecond\n\nlast";
        let dir = testkit::scratch_dir("lines");
        let plain = dir.join("plain.txt");
        std::fs::write(&plain, text).unwrap();
        let gz = dir.join("text.gz");
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        enc.write_all(text).unwrap();
        std::fs::write(&gz, enc.finish().unwrap()).unwrap();
        for path in [&plain, &gz] {
            let mut src = Lines::open(path).unwrap();
            let mut got = Vec::new();
            while let Some(l) = src.next_line().unwrap() {
                let l = String::from_utf8(l.to_vec()).unwrap();
                got.push((src.line_no, l));
            }
            let want = [(1, "first"), (2, "second"), (3, ""), (4, "last")];
            let want: Vec<_> = want.iter().map(|(n, s)| (*n, s.to_string())).collect();
            assert_eq!(got, want, "{}", path.display());
            assert_eq!(src.bytes, text.len() as u64);
        }
    }

    #[test]
    fn a_line_over_the_bound_is_refused_with_its_number() {
        let mut text = b"short\n".to_vec();
        text.extend(std::iter::repeat_n(b'x', MAX_LINE + 10));
        let mut src = Lines::from_reader(Path::new("big.bin"), std::io::Cursor::new(text));
        assert_eq!(src.next_line().unwrap(), Some(&b"short"[..]));
        match src.next_line() {
            Err(e @ Error::TooLong { line: 2, .. }) => {
                let text = e.to_string();
                assert!(
                    text.starts_with("big.bin:2: line longer than 1024 KiB"),
                    "{text}"
                );
            }
            other => panic!("expected TooLong at line 2, got {:?}", other.map(|_| ())),
        }
        let e = Lines::open(Path::new("/nonexistent/lines.txt"))
            .err()
            .unwrap();
        assert!(
            e.to_string()
                .starts_with("/nonexistent/lines.txt: cannot read"),
            "{e}"
        );
    }
}
