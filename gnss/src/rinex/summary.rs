//! What `ppkat info` tells about an observation file: version, span, interval, systems and
//! signals, epoch and event counts, and anything suspicious.

use super::ObsFile;
use crate::sv::Constellation;
use crate::time::{diff_s, format_ymdhms};
use std::collections::BTreeMap;
use std::fmt;

/// A summary of an observation file.
#[derive(Clone, Debug)]
pub struct ObsSummary {
    /// Label and value, in print order.
    pub lines: Vec<(String, String)>,
    /// What looks wrong.
    pub warnings: Vec<String>,
}

impl ObsSummary {
    /// The summary of a file read.
    pub fn of(f: &ObsFile) -> Self {
        let mut lines = header_lines(f);
        let mut warnings: Vec<String> = Vec::new();
        lines.extend(span_and_interval(f, &mut warnings));
        lines.extend(content_lines(f));
        warnings.extend(ingest_warnings(f));
        ObsSummary { lines, warnings }
    }
}

fn line(k: &str, v: String) -> (String, String) {
    (k.to_string(), v)
}

/// File, format, marker, receiver, antenna and approximate position from the header.
fn header_lines(f: &ObsFile) -> Vec<(String, String)> {
    let h = &f.header;
    vec![
        line("file", f.path.display().to_string()),
        line(
            "format",
            match h.crinex {
                Some(c) => format!(
                    "RINEX {:.2} observation, Hatanaka-compressed (CRINEX {c:.1})",
                    h.version
                ),
                None => format!("RINEX {:.2} observation", h.version),
            },
        ),
        line(
            "marker",
            format!("{} {}", h.marker, h.marker_number)
                .trim()
                .to_string(),
        ),
        line("receiver", h.receiver.clone()),
        line("antenna", h.antenna.clone()),
        line(
            "antenna delta H/E/N",
            format!(
                "{:.4} {:.4} {:.4} m",
                h.antenna_delta.up, h.antenna_delta.east, h.antenna_delta.north
            ),
        ),
        line(
            "approx position",
            match h.approx_position {
                Some(p) => {
                    let g = p.to_geodetic();
                    format!(
                        "{:.4} {:.4} {:.4} m ECEF ({:.8}° {:.8}° {:.3} m)",
                        p.0.x,
                        p.0.y,
                        p.0.z,
                        g.lat.to_degrees(),
                        g.lon.to_degrees(),
                        g.h
                    )
                }
                None => "none".into(),
            },
        ),
    ]
}

/// Time span (GPST) and interval (the most common spacing, beside the header's); gaps longer
/// than 1.5 intervals go to `warnings`.
fn span_and_interval(f: &ObsFile, warnings: &mut Vec<String>) -> Vec<(String, String)> {
    let mut l = Vec::new();
    if let (Some(a), Some(b)) = (f.epochs.first(), f.epochs.last()) {
        l.push(line(
            "time span",
            format!(
                "{} – {} GPST ({:.1} h)",
                format_ymdhms(a.time),
                format_ymdhms(b.time),
                diff_s(b.time, a.time) / 3600.0
            ),
        ));
    }
    // Spacings in milliseconds and how often each occurs.
    let mut gaps: BTreeMap<i64, usize> = BTreeMap::new();
    for w in f.epochs.windows(2) {
        *gaps
            .entry((diff_s(w[1].time, w[0].time) * 1000.0).round() as i64)
            .or_default() += 1;
    }
    let modal = gaps
        .iter()
        .max_by_key(|(_, n)| **n)
        .map(|(g, _)| *g as f64 / 1000.0);
    l.push(line(
        "interval",
        match (f.header.interval, modal) {
            (Some(hi), Some(m)) => format!("{m} s (header: {hi} s)"),
            (None, Some(m)) => format!("{m} s"),
            (Some(hi), None) => format!("header: {hi} s"),
            _ => "unknown".into(),
        },
    ));
    if let Some(m) = modal {
        let big: usize = gaps
            .iter()
            .filter(|(g, _)| **g as f64 / 1000.0 > 1.5 * m)
            .map(|(_, n)| *n)
            .sum();
        if big > 0 {
            let longest = gaps.keys().next_back().copied().unwrap_or(0) as f64 / 1000.0;
            warnings.push(format!(
                "{big} gaps longer than 1.5 intervals (longest {longest} s)"
            ));
        }
    }
    l
}

/// Epoch and event counts, satellites and signals per system, satellites per epoch.
fn content_lines(f: &ObsFile) -> Vec<(String, String)> {
    let mut l = vec![line("epochs", f.epochs.len().to_string())];
    let ev5 = f.exposure_events().count();
    let other: usize = f.events.len() - ev5;
    l.push(line(
        "events",
        format!("{ev5} external events (flag 5, camera exposures); {other} other special records (flags 2–4)"),
    ));
    let mut sats: BTreeMap<Constellation, std::collections::BTreeSet<u8>> = BTreeMap::new();
    let mut nsat_sum = 0usize;
    for e in &f.epochs {
        nsat_sum += e.sats.len();
        for s in &e.sats {
            sats.entry(s.sv.sys).or_default().insert(s.sv.prn);
        }
    }
    for (sys, set) in &sats {
        let names: Vec<String> = f
            .header
            .types_of(*sys)
            .iter()
            .map(|t| t.to_string())
            .collect();
        l.push(line(
            &format!("system {}", sys.letter()),
            format!("{} satellites; signals {}", set.len(), names.join(" ")),
        ));
    }
    if !f.epochs.is_empty() {
        l.push(line(
            "satellites per epoch",
            format!("{:.1} on average", nsat_sum as f64 / f.epochs.len() as f64),
        ));
    }
    l
}

/// What reading noticed: flagged and disordered epochs, unreadable lines, header notes and
/// the reader's warnings with their lines.
fn ingest_warnings(f: &ObsFile) -> Vec<String> {
    let mut warnings = Vec::new();
    let s = &f.stats;
    if s.power_failures > 0 {
        warnings.push(format!(
            "{} epochs flagged as following a power failure (flag 1)",
            s.power_failures
        ));
    }
    if s.cycle_slip_records > 0 {
        warnings.push(format!(
            "{} cycle-slip records (flag 6) not used",
            s.cycle_slip_records
        ));
    }
    if s.non_increasing > 0 {
        warnings.push(format!(
            "{} epochs not after their predecessor",
            s.non_increasing
        ));
    }
    if s.skipped_lines > 0 || s.dropped_sat_records > 0 {
        warnings.push(format!(
            "{} unreadable lines skipped, {} satellite records dropped",
            s.skipped_lines, s.dropped_sat_records
        ));
    }
    if f.header.approx_position.is_none() {
        warnings.push("no approximate position in the header".into());
    }
    for n in &f.header.notes {
        warnings.push(n.clone());
    }
    for w in &f.warnings {
        warnings.push(format!("line {}: {}", w.line, w.what));
    }
    warnings
}

impl fmt::Display for ObsSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (k, v) in &self.lines {
            writeln!(f, "{k:<22}{v}")?;
        }
        if self.warnings.is_empty() {
            writeln!(f, "{:<22}none", "suspicious")?;
        } else {
            writeln!(f, "{:<22}{} item(s):", "suspicious", self.warnings.len())?;
            for w in self.warnings.iter().take(50) {
                writeln!(f, "  - {w}")?;
            }
            if self.warnings.len() > 50 {
                writeln!(f, "  … and {} more", self.warnings.len() - 50)?;
            }
        }
        Ok(())
    }
}
