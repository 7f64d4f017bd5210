//! Line sources and fixed-column fields: the files are read by `common::lines` (plain or
//! gzip-compressed text, line by line into a reused buffer, every line bounded), re-exported
//! here; its errors become `crate::error::Error`s naming the kinds of file read here.

pub use common::lines::{Lines, MAX_LINE};

/// Cap on the warnings a reader stores, so that a file of garbage cannot exhaust memory; the
/// count goes on.
pub(super) const MAX_WARNINGS: usize = 1000;

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
