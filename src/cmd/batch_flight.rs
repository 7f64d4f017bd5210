//! One flight of `ppkat batch`: its `ppk` and `exposures` command lines, built from what
//! its folder holds and its options files, parsed as the `ppkat` command line is parsed,
//! and run; and the verdict and table over many flights.

use super::config;
use anyhow::{bail, Context, Result};
use clap::{CommandFactory, Parser};
use common::progress::NoProgress;
use integration::batch::{self, Flight, Outcome, SummaryRow};
use integration::pipeline;
use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::Path;

/// What one flight's run gave: its summary row and its report text.
pub struct Done {
    /// The summary row.
    pub row: SummaryRow,
    /// The report text.
    pub text: String,
}

/// Exit 0 when all flights are done, 3 naming the ones that failed or skipped inputs, 1 when
/// none gave a trajectory.
pub fn verdict(rows: &[SummaryRow]) -> Result<()> {
    if rows
        .iter()
        .all(|r| matches!(r.outcome, Outcome::Failed | Outcome::NotRun))
    {
        bail!("no flight gave a trajectory (see summary.csv)");
    }
    super::complete(
        rows.iter()
            .filter(|r| r.outcome != Outcome::Done)
            .map(|r| {
                format!(
                    "flight {}: {}: {}",
                    r.flight,
                    batch::outcome_word(r.outcome),
                    r.message
                )
            })
            .collect(),
    )
}

/// The summary table on standard output.
pub fn print_table(rows: &[SummaryRow], seconds: f64, path: &Path) {
    let count = |o| rows.iter().filter(|r| r.outcome == o).count();
    println!(
        "batch: {} flights, {} done, {} with skipped inputs, {} failed in {seconds:.1} s → {}",
        rows.len(),
        count(Outcome::Done),
        count(Outcome::Skipped),
        count(Outcome::Failed),
        path.display()
    );
    println!(
        "  {:<20} {:<15} {:>7} {:>7} {:>6} {:>9} {:>9} {:>8}",
        "flight", "outcome", "epochs", "solved", "fix %", "σ3D (m)", "exposures", "warnings"
    );
    for r in rows {
        println!(
            "  {:<20} {:<15} {:>7} {:>7} {:>6.1} {:>9} {:>9} {:>8}",
            r.flight,
            batch::outcome_word(r.outcome),
            r.epochs,
            r.solved,
            r.fix_percent(),
            if r.sigma_3d.is_finite() {
                format!("{:.3}", r.sigma_3d)
            } else {
                "–".into()
            },
            r.exposures.map_or("–".into(), |n| n.to_string()),
            r.warnings
        );
    }
}

/// One flight: PPK, then the exposures when it has exposure times.
pub fn run_flight(f: &Flight, out: &Path) -> Done {
    let mut row = SummaryRow::empty(&f.name, Outcome::Failed, String::new());
    let mut text = format!("── flight {} ──\n", f.name);
    if let Err(e) = flight_steps(f, out, &mut row, &mut text) {
        row.outcome = Outcome::Failed;
        row.message = format!("{e:#}").replace('\n', " ");
        text.push_str(&format!("error: {}\n", row.message));
    }
    Done { row, text }
}

/// The keys of a flight's two options files, once its open questions are settled by them.
pub fn settled_keys(f: &Flight) -> Result<(BTreeSet<String>, BTreeSet<String>)> {
    let ppk_keys = config_keys(f.ppk_config.as_deref())?;
    let exp_keys = config_keys(f.exposures_config.as_deref())?;
    for p in &f.problems {
        let settled = ppk_keys.contains(p.option) || exp_keys.contains(p.option);
        if !settled {
            bail!("{}: {}", f.dir.display(), p.text);
        }
    }
    Ok((ppk_keys, exp_keys))
}

/// The `ppkat ppk` command line of a flight whose outputs go to `dir`.
pub fn ppk_argv(f: &Flight, keys: &BTreeSet<String>, dir: &Path) -> Vec<OsString> {
    let mut argv = start("ppk", f.ppk_config.as_deref());
    let found = [("rover", &f.rover), ("base", &f.base)];
    for (key, path) in found {
        if let (false, Some(p)) = (keys.contains(key), path) {
            push(&mut argv, key, p);
        }
    }
    if !keys.contains("nav") {
        f.nav.iter().for_each(|n| push(&mut argv, "nav", n));
    }
    push(&mut argv, "out", &dir.join(format!("{}.pos", f.name)));
    push(&mut argv, "report", &dir.join(format!("{}.html", f.name)));
    argv
}

/// The steps of one flight, filling its row and report text.
fn flight_steps(f: &Flight, out: &Path, row: &mut SummaryRow, text: &mut String) -> Result<()> {
    let (ppk_keys, exp_keys) = settled_keys(f)?;
    let dir = out.join(&f.name);
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("{}: cannot create the folder", dir.display()))?;
    let pos = dir.join(format!("{}.pos", f.name));
    let argv = ppk_argv(f, &ppk_keys, &dir);
    let crate::Cmd::Ppk(a) = parse(argv, text)? else {
        bail!("internal: not a ppk command line");
    };
    let report = pipeline::ppk(&super::ppk::job(a)?, &NoProgress)
        .context("carrier-phase positioning failed")?;
    for n in &report.notes {
        text.push_str(&format!("note: {n}\n"));
    }
    text.push_str(&report.to_string());
    let r = &report.result;
    row.epochs = r.rover_epochs;
    row.solved = r.trajectory.epochs.len();
    row.fixed = r.fixed();
    row.sigma_3d = batch::median_sigma_3d(&r.trajectory);
    row.warnings = report.warnings.len();
    row.message = report.warnings.first().cloned().unwrap_or_default();
    row.outcome = Outcome::Done;
    exposures(f, &exp_keys, &pos, &dir, row, text)
}

/// The exposure stage of a flight, when it has exposure times: an MRK, the exposures.toml's
/// source, or a RINEX rover's events.
fn exposures(
    f: &Flight,
    keys: &BTreeSet<String>,
    pos: &Path,
    dir: &Path,
    row: &mut SummaryRow,
    text: &mut String,
) -> Result<()> {
    let Some(argv) = exposures_argv(f, keys, pos, dir) else {
        return Ok(());
    };
    let crate::Cmd::Exposures(a) = parse(argv, text)? else {
        bail!("internal: not an exposures command line");
    };
    let report = pipeline::exposures(&super::exposures::job(a)?).context("exposures failed")?;
    text.push_str(&report.to_string());
    let skipped = report.skipped();
    row.exposures = Some(report.result.stations.len());
    row.warnings += skipped.len() + report.result.warnings.len();
    if let Some(first) = skipped.first() {
        row.outcome = Outcome::Skipped;
        row.message = first.clone();
    }
    Ok(())
}

/// The `ppkat exposures` command line of a flight, None when it has no exposure times (no
/// MRK, no events in a RINEX rover, no exposures.toml).
pub fn exposures_argv(
    f: &Flight,
    keys: &BTreeSet<String>,
    pos: &Path,
    dir: &Path,
) -> Option<Vec<OsString>> {
    let given = ["events", "mrk", "times"].iter().any(|k| keys.contains(*k));
    let source = match (&f.mrk, &f.rover) {
        _ if given => None,
        (Some(m), _) => Some(("mrk", m.clone())),
        (None, Some(r)) if batch::has_events(r) => Some(("events", r.clone())),
        _ if f.exposures_config.is_none() => return None,
        _ => None,
    };
    let mut argv = start("exposures", f.exposures_config.as_deref());
    push(&mut argv, "trajectory", pos);
    if let Some((key, p)) = &source {
        push(&mut argv, key, p);
    }
    if let (Some(p), false) = (&f.photos, keys.contains("photos") || keys.contains("names")) {
        push(&mut argv, "photos", p);
    }
    push(&mut argv, "out", &dir.join("exposures.csv"));
    Some(argv)
}

/// The keys a flight's options file sets (kebab-case), none without a file.
pub fn config_keys(path: Option<&Path>) -> Result<BTreeSet<String>> {
    let Some(p) = path else {
        return Ok(BTreeSet::new());
    };
    let text = std::fs::read_to_string(p)
        .with_context(|| format!("cannot read the options file {}", p.display()))?;
    let table: toml::Table = toml::from_str(&text)
        .map_err(|e| anyhow::anyhow!("{}: {}", p.display(), e.message().trim()))?;
    Ok(table.keys().map(|k| k.replace('_', "-")).collect())
}

/// The start of a command line: `ppkat COMMAND [--config FILE]`.
fn start(command: &str, config: Option<&Path>) -> Vec<OsString> {
    let mut v = vec![OsString::from("ppkat"), OsString::from(command)];
    if let Some(c) = config {
        push(&mut v, "config", c);
    }
    v
}

/// Append `--KEY=PATH`.
fn push(argv: &mut Vec<OsString>, key: &str, path: &Path) {
    let mut s = OsString::from(format!("--{key}="));
    s.push(path.as_os_str());
    argv.push(s);
}

/// Expand the options file and parse the command line as the `ppkat` command line is parsed;
/// the notes go into the flight's report text.
pub fn parse(argv: Vec<OsString>, text: &mut String) -> Result<crate::Cmd> {
    let e = config::expand(&crate::Cli::command(), argv).map_err(|e| anyhow::anyhow!(e.0))?;
    for n in e.notes {
        text.push_str(&format!("note: {n}\n"));
    }
    let cli = crate::Cli::try_parse_from(e.args).map_err(|e| {
        let msg = e.to_string();
        anyhow::anyhow!(
            "{}",
            msg.lines()
                .next()
                .unwrap_or("bad options")
                .trim_start_matches("error: ")
        )
    })?;
    Ok(cli.cmd)
}
