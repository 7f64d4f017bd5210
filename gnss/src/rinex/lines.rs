//! Line sources: plain or gzip-compressed text read line by line into a reused buffer, so that
//! a file is streamed rather than held in memory.

use crate::error::{Error, Result};
use flate2::read::MultiGzDecoder;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

/// Cap on the warnings a reader stores, so that a file of garbage cannot exhaust memory; the
/// count goes on.
pub(super) const MAX_WARNINGS: usize = 1000;

/// The longest line read, end-of-line included (1 MiB). A RINEX 3 observation line with 999
/// types is 16 kB; Hatanaka lines are shorter.
pub const MAX_LINE: usize = 1 << 20;

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
    pub fn open(path: &Path) -> Result<Self> {
        let io = Error::io(path);
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

    /// Lines from any reader (used by tests and by in-memory sources).
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
    /// A line longer than [`MAX_LINE`] is an error: no text format read here has one, and
    /// reading on would hold a whole file of garbage (or of gzip) in one buffer.
    pub fn next_line(&mut self) -> Result<Option<&[u8]>> {
        self.buf.clear();
        let n = (&mut self.inner)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut self.buf)
            .map_err(Error::io(&self.path))?;
        if n == 0 {
            return Ok(None);
        }
        self.bytes += n as u64;
        self.line_no += 1;
        if n > MAX_LINE {
            return Err(Error::parse(
                &self.path,
                self.line_no,
                format!(
                    "line longer than {} KiB: not a text file of the expected kind (RINEX, SP3, \
                     clock or ANTEX); check that the right file was given",
                    MAX_LINE >> 10
                ),
            ));
        }
        while matches!(self.buf.last(), Some(b'\n' | b'\r')) {
            self.buf.pop();
        }
        Ok(Some(&self.buf))
    }
}

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

/// Columns `a..b` (0-based, end exclusive) of a line, clipped to its length.
pub fn cols(line: &[u8], a: usize, b: usize) -> &[u8] {
    let b = b.min(line.len());
    if a >= b {
        &[]
    } else {
        &line[a..b]
    }
}

/// Columns as trimmed text.
pub fn col_str(line: &[u8], a: usize, b: usize) -> String {
    String::from_utf8_lossy(cols(line, a, b)).trim().to_string()
}

/// The header label in columns 61–80.
pub fn label(line: &[u8]) -> &[u8] {
    let l = cols(line, 60, 80);
    let mut end = l.len();
    while end > 0 && l[end - 1] == b' ' {
        end -= 1;
    }
    &l[..end]
}

/// Parse a Fortran real (`F`, `E` or `D` exponent) from a fixed-width field.
/// Blank → `Ok(None)`; anything else unparseable, or not finite (`NaN`, `inf`, `1D+999`),
/// → `Err(())`.
#[allow(clippy::result_unit_err)]
pub fn parse_real(field: &[u8]) -> std::result::Result<Option<f64>, ()> {
    let s = trim(field);
    if s.is_empty() {
        return Ok(None);
    }
    // Fast path: plain fixed-point numbers, the vast majority in observation files.
    if let Some(v) = parse_fixed(s) {
        return Ok(Some(v));
    }
    let txt: String = s
        .iter()
        .map(|&c| {
            if c == b'D' || c == b'd' {
                'E'
            } else {
                c as char
            }
        })
        .collect();
    match txt.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        _ => Err(()),
    }
}

/// Fixed-point decimal without exponent, e.g. `-12345.678`, parsed exactly to the nearest f64.
fn parse_fixed(s: &[u8]) -> Option<f64> {
    let (neg, digits) = match s[0] {
        b'-' => (true, &s[1..]),
        b'+' => (false, &s[1..]),
        _ => (false, s),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut mant: u64 = 0;
    let mut frac_digits: i32 = -1;
    for &c in digits {
        match c {
            b'0'..=b'9' => {
                mant = mant * 10 + (c - b'0') as u64;
                if frac_digits >= 0 {
                    frac_digits += 1;
                }
            }
            b'.' if frac_digits < 0 => frac_digits = 0,
            _ => return None,
        }
    }
    const P10: [f64; 19] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18,
    ];
    let v = mant as f64 / P10[frac_digits.max(0) as usize];
    Some(if neg { -v } else { v })
}

/// Parse an integer field; blank → `Ok(None)`.
#[allow(clippy::result_unit_err)]
pub fn parse_int(field: &[u8]) -> std::result::Result<Option<i64>, ()> {
    let s = trim(field);
    if s.is_empty() {
        return Ok(None);
    }
    std::str::from_utf8(s)
        .ok()
        .and_then(|t| t.parse::<i64>().ok())
        .map(Some)
        .ok_or(())
}

/// `s` without leading and trailing ASCII whitespace.
pub fn trim(s: &[u8]) -> &[u8] {
    let mut a = 0;
    let mut b = s.len();
    while a < b && s[a].is_ascii_whitespace() {
        a += 1;
    }
    while b > a && s[b - 1].is_ascii_whitespace() {
        b -= 1;
    }
    &s[a..b]
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn reals() {
        assert_eq!(parse_real(b"  23619095.450"), Ok(Some(23619095.45)));
        assert_eq!(parse_real(b" -.123"), Ok(Some(-0.123)));
        assert_eq!(
            parse_real(b"-1.234567890123D-04"),
            Ok(Some(-1.234567890123e-4))
        );
        assert_eq!(parse_real(b"  .5E+01"), Ok(Some(5.0)));
        assert_eq!(parse_real(b"      "), Ok(None));
        assert_eq!(parse_real(b"  1.2x"), Err(()));
        assert_eq!(parse_int(b"  12"), Ok(Some(12)));
    }
}
