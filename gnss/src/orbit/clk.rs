//! RINEX clock files (`.clk`, versions 2.x and 3.x; plain or gzip): the satellite clock
//! records (`AS`). Receiver (`AR`), calibration, discontinuity and monitor records are read
//! past. Interpolation, and the merging of several files, is
//! [`super::precise::PreciseOrbits`]'s.
//!
//! Record layouts: versions 2.x to 3.03 put the name in columns 4–7 and the date from column
//! 9; version 3.04 widened the name to nine characters (columns 4–12, date from column 14).
//! Each record is recognised by where its four-digit year stands, so a file whose version line
//! disagrees with its layout still reads. The first value (the clock bias, seconds) is the
//! one used; a record with more than two values continues on following lines.

use super::sp3::{nominal_step, time_scale};
use crate::error::{Error, Result};
use crate::rinex::body::make_epoch;
use crate::rinex::lines::{col_str, cols, label, parse_int, parse_real, trim, Lines};
use crate::sv::{Constellation, Sv};
use hifitime::{Epoch, TimeScale};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The satellite clocks of one RINEX clock file.
#[derive(Clone, Debug, Default)]
pub struct ClockFile {
    /// The file.
    pub path: PathBuf,
    /// Format version (e.g. 2.0, 3.0, 3.04).
    pub version: f64,
    /// Nominal interval of the satellite records, seconds (the most common step between a
    /// satellite's consecutive records).
    pub interval: f64,
    /// Per satellite: (epoch GPST, clock bias s), sorted by time, one value per epoch.
    pub sats: BTreeMap<Sv, Vec<(Epoch, f64)>>,
    /// Satellite (`AS`) records read.
    pub records: usize,
    /// `AS` records of systems ppkat does not know (not kept).
    pub unknown_system: usize,
}

impl ClockFile {
    /// Read a RINEX clock file. Every unreadable satellite record is an error naming the file
    /// and line.
    pub fn read(path: &Path) -> Result<ClockFile> {
        let mut src = Lines::open(path)?;
        let (version, scale) = read_header(&mut src)?;
        let mut f = ClockFile {
            path: path.to_path_buf(),
            version,
            ..ClockFile::default()
        };
        // Continuation lines still expected for the last record (more than two values).
        let mut pending = 0usize;
        loop {
            let ln = src.line_no + 1;
            let Some(line) = src.next_line()? else { break };
            if trim(line).is_empty() {
                continue;
            }
            if !is_record(line) {
                if pending == 0 {
                    return Err(Error::parse(
                        path,
                        ln,
                        "not a clock data record (a record starts with its type: AS, AR, CR, DR or MS)",
                    ));
                }
                pending -= 1;
                continue;
            }
            if !line.starts_with(b"AS ") {
                pending = other_record_continuations(line);
                continue;
            }
            let rec = satellite_record(line, scale).map_err(|what| Error::parse(path, ln, what))?;
            f.records += 1;
            pending = rec.values.saturating_sub(2).div_ceil(4);
            match rec.sv {
                Some(sv) => f.sats.entry(sv).or_default().push((rec.time, rec.bias)),
                None => f.unknown_system += 1,
            }
        }
        if pending > 0 {
            return Err(Error::parse(
                path,
                src.line_no,
                "the file ends inside a record (its continuation line is missing): the file is truncated",
            ));
        }
        if f.records == 0 {
            return Err(Error::input(
                path,
                "the file holds no satellite clock (AS) record",
            ));
        }
        let mut steps = Vec::new();
        for v in f.sats.values_mut() {
            // Files are in time order; sort anyway, and keep the last of repeated epochs.
            v.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap_or(std::cmp::Ordering::Equal));
            v.reverse();
            v.dedup_by(|b, a| a.0 == b.0);
            v.reverse();
            steps.extend(v.windows(2).map(|w| (w[1].0 - w[0].0).to_seconds()));
        }
        f.interval = nominal_step(&steps).unwrap_or(300.0);
        Ok(f)
    }

    /// First and last satellite record.
    pub fn span(&self) -> Option<(Epoch, Epoch)> {
        let mut it = self.sats.values().flat_map(|v| [v.first(), v.last()]);
        let first = it.next().flatten()?.0;
        Some(
            it.flatten()
                .fold((first, first), |(a, b), (t, _)| (a.min(*t), b.max(*t))),
        )
    }
}

/// The header: version and time scale (`TIME SYSTEM ID`, GPS when absent).
fn read_header(src: &mut Lines) -> Result<(f64, TimeScale)> {
    let path = src.path.clone();
    let first = src
        .next_line()?
        .ok_or_else(|| Error::input(&path, "the file is empty"))?;
    let version = parse_real(cols(first, 0, 9)).ok().flatten();
    let (Some(version), true) = (
        version,
        cols(first, 20, 21) == b"C" && label_of(first).starts_with(b"RINEX VERSION / TYPE"),
    ) else {
        return Err(Error::input(
            &path,
            "not a RINEX clock file (the first line is not a RINEX VERSION / TYPE line of type C)",
        ));
    };
    if !(2.0..4.0).contains(&version) {
        return Err(Error::input(
            &path,
            format!("RINEX clock version {version} is not supported (2.x and 3.x are)"),
        ));
    }
    let mut scale = TimeScale::GPST;
    loop {
        let ln = src.line_no + 1;
        let Some(line) = src.next_line()? else {
            return Err(Error::input(
                &path,
                "no END OF HEADER line: the file is truncated or not a RINEX clock file",
            ));
        };
        let l = label_of(line);
        if l.starts_with(b"END OF HEADER") {
            return Ok((version, scale));
        }
        if l.starts_with(b"TIME SYSTEM ID") {
            scale = time_scale(cols(line, 0, 60)).ok_or_else(|| {
                Error::parse(
                    &path,
                    ln,
                    format!("unknown time system '{}'", col_str(line, 0, 60)),
                )
            })?;
        }
    }
}

/// The header label: columns 61–80, or from column 66 in version 3.04's wider lines.
fn label_of(line: &[u8]) -> &[u8] {
    let l = label(line);
    if l.is_empty() || l[0] == b' ' {
        trim(cols(line, 60, 85))
    } else {
        l
    }
}

/// A data record starts with its two-letter type and a blank.
fn is_record(line: &[u8]) -> bool {
    line.len() >= 3
        && line[0].is_ascii_uppercase()
        && line[1].is_ascii_uppercase()
        && line[2] == b' '
}

/// One satellite record.
struct SatRecord {
    /// The satellite (`None`: a system ppkat does not know).
    sv: Option<Sv>,
    time: Epoch,
    /// Clock bias, seconds.
    bias: f64,
    /// Number of values the record declares.
    values: usize,
}

/// Where the date starts: column 9 (versions 2.x–3.03) or 14 (3.04), found by the year.
fn date_start(line: &[u8]) -> Option<usize> {
    let year = |a: usize| {
        let c = cols(line, a, a + 4);
        c.len() == 4 && c.iter().all(u8::is_ascii_digit) && line.get(a - 1) == Some(&b' ')
    };
    [8, 13].into_iter().find(|&a| year(a))
}

/// Parse an `AS` record; the error says what is wrong.
fn satellite_record(line: &[u8], scale: TimeScale) -> std::result::Result<SatRecord, String> {
    let d = date_start(line).ok_or(
        "unreadable satellite clock record: no four-digit year in columns 9–12 (RINEX clock 2.x–3.03) or 14–17 (3.04)",
    )?;
    let name = trim(cols(line, 3, d));
    let sv = match Sv::parse(name) {
        Some(sv) => Some(sv),
        None if name.len() == 3
            && name[0].is_ascii_uppercase()
            && Constellation::from_letter(name[0]).is_none()
            && name[1..].iter().all(u8::is_ascii_digit) =>
        {
            None
        }
        None => {
            return Err(format!(
                "unreadable satellite name '{}'",
                String::from_utf8_lossy(name)
            ))
        }
    };
    let fields: Vec<(usize, &[u8])> = tokens(line, d).take(7).collect();
    if fields.len() < 7 {
        return Err("the record is truncated: date, time and number of values expected".into());
    }
    let int = |k: usize| parse_int(fields[k].1).ok().flatten();
    let (Some(y), Some(mo), Some(dd), Some(h), Some(mi)) = (int(0), int(1), int(2), int(3), int(4))
    else {
        return Err("unreadable date or time".into());
    };
    let time = make_epoch(y, mo, dd, h, mi, fields[5].1, scale)
        .ok_or_else(|| "unreadable or impossible date or time".to_string())?;
    let values = match int(6) {
        Some(n) if (1..=6).contains(&n) => n as usize,
        _ => return Err("the number of values is not 1 to 6".into()),
    };
    let after = fields[6].0 + fields[6].1.len();
    let bias = leading_real(cols(line, after, line.len()))
        .filter(|b| b.is_finite())
        .ok_or("the clock bias is missing or unreadable")?;
    Ok(SatRecord {
        sv,
        time,
        bias,
        values,
    })
}

/// Continuation lines of a record that is not read (its number of values, when readable).
fn other_record_continuations(line: &[u8]) -> usize {
    let Some(d) = date_start(line) else { return 0 };
    tokens(line, d)
        .nth(6)
        .and_then(|(_, t)| parse_int(t).ok().flatten())
        .map(|n| (n.clamp(0, 6) as usize).saturating_sub(2).div_ceil(4))
        .unwrap_or(0)
}

/// Blank-separated fields of `line` from column `from`, with their start columns.
fn tokens(line: &[u8], from: usize) -> impl Iterator<Item = (usize, &[u8])> {
    let mut i = from.min(line.len());
    std::iter::from_fn(move || {
        while i < line.len() && line[i].is_ascii_whitespace() {
            i += 1;
        }
        if i >= line.len() {
            return None;
        }
        let a = i;
        while i < line.len() && !line[i].is_ascii_whitespace() {
            i += 1;
        }
        Some((a, &line[a..i]))
    })
}

/// The first number of a field list whose values may touch (`1.0E-04-2.0E-11`): optional
/// sign, digits with a point, an optional `E`/`D` exponent.
fn leading_real(s: &[u8]) -> Option<f64> {
    let s = &s[s.iter().position(|c| !c.is_ascii_whitespace())?..];
    let mut i = usize::from(matches!(s.first(), Some(b'+' | b'-')));
    let digits = |i: &mut usize| {
        let a = *i;
        while s.get(*i).is_some_and(u8::is_ascii_digit) {
            *i += 1;
        }
        *i > a
    };
    let mut any = digits(&mut i);
    if s.get(i) == Some(&b'.') {
        i += 1;
        any |= digits(&mut i);
    }
    if !any {
        return None;
    }
    if matches!(s.get(i), Some(b'E' | b'e' | b'D' | b'd')) {
        let mut j = i + 1 + usize::from(matches!(s.get(i + 1), Some(b'+' | b'-')));
        if !digits(&mut j) {
            return None;
        }
        i = j;
    }
    // What follows is a blank, the end, or the sign of a touching next value.
    if !matches!(s.get(i), None | Some(b' ' | b'\t' | b'+' | b'-')) {
        return None;
    }
    parse_real(&s[..i]).ok().flatten()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn touching_values_are_split() {
        assert_eq!(leading_real(b"  -1.5E-04-2.0E-11"), Some(-1.5e-4));
        assert_eq!(
            leading_real(b"   0.280381686059E-03 "),
            Some(0.280381686059e-3)
        );
        assert_eq!(leading_real(b" .5D+01"), Some(5.0));
        assert_eq!(leading_real(b" 1.0E"), None);
        assert_eq!(leading_real(b"  x"), None);
        assert_eq!(leading_real(b""), None);
    }

    #[test]
    fn both_layouts_are_recognised() {
        let v2 = b"AS G02  2010 07 01 00 00  0.000000  2    2.691084288582e-04  1.507490528240e-11";
        let v304 = b"AS G01       2024 01 15 00 00 30.000000  1   -1.234567890123E-04";
        let r = satellite_record(v2, TimeScale::GPST).unwrap();
        assert_eq!(r.sv, Some(Sv::new(Constellation::Gps, 2)));
        assert_eq!((r.bias, r.values), (2.691084288582e-4, 2));
        let r = satellite_record(v304, TimeScale::GPST).unwrap();
        assert_eq!(r.sv, Some(Sv::new(Constellation::Gps, 1)));
        assert_eq!(r.bias, -1.234567890123e-4);
        assert!(satellite_record(
            b"AS L51  2010 07 01 00 00  0.000000  1    1.0E-04",
            TimeScale::GPST
        )
        .unwrap()
        .sv
        .is_none());
        for bad in [
            &b"AS G02  2010 07 01 00 00  0.000000  1"[..],
            b"AS G02  2010 07 01 00",
            b"AS G02  2010 13 01 00 00  0.000000  1    1.0E-04",
            b"AS G0x  2010 07 01 00 00  0.000000  1    1.0E-04",
            b"AS G02  2010 07 01 00 00  0.000000  1    1.0X-04",
        ] {
            assert!(
                satellite_record(bad, TimeScale::GPST).is_err(),
                "{}",
                String::from_utf8_lossy(bad)
            );
        }
    }
}
