//! `ppkat batch`: every flight of a folder through `ppk` and `exposures`, flights in
//! parallel, and one summary table.

use super::config;
use anyhow::{bail, Context, Result};
use clap::{CommandFactory, Parser};
use common::progress::{NoProgress, Progress};
use integration::batch::{self, Flight, Outcome, SummaryRow};
use integration::pipeline;
use rayon::prelude::*;
use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// Process a folder of flights: each subfolder one flight, run through `ppkat ppk` and, when
/// it has exposure times, `ppkat exposures`; flights in parallel; one summary table.
///
/// A flight folder holds the rover's and the base's observations (RINEX — plain, gzip or
/// Hatanaka — or a UBX/RTCM 3 log; the file whose name contains "base" is the base, told
/// apart from navigation files by content), its broadcast navigation files, optionally a DJI
/// Timestamp.MRK and the photos (JPEG in the folder or in photos/), and optionally ppk.toml
/// and exposures.toml: options of `ppkat ppk` and `ppkat exposures` as their --config files
/// (e.g. base-pos, elev-mask, lever-arm, format); what those files name wins over what was
/// found. Without an MRK, a RINEX rover's flag-5 events are the exposure times.
///
/// Writes OUT/FLIGHT/FLIGHT.pos, FLIGHT.html (the PPK report) and exposures.csv (or the
/// exposures.toml format's file) per flight, and OUT/summary.csv: per flight the outcome,
/// epochs, solved, fixed and fix %, the median 3D σ, exposures, warnings and the error or
/// first warning. Prints each flight's report (in name order) and the table. Exit code 0 when
/// every flight did all it was asked; 3 when some flight failed or skipped inputs (each named);
/// 1 when none gave a trajectory.
#[derive(clap::Args)]
pub struct Args {
    /// Folder whose subfolders are the flights (subfolders without observation files are
    /// left out).
    #[arg(value_name = "DIR")]
    dir: PathBuf,
    /// Output folder (created): a subfolder per flight and summary.csv.
    #[arg(short = 'o', long, value_name = "OUTDIR")]
    out: PathBuf,
    /// Flights processed at the same time (default: one per worker thread, see --threads);
    /// results are the same whatever the number.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    jobs: Option<u16>,
}

/// What one flight's run gave: its summary row and its report text.
struct Done {
    row: SummaryRow,
    text: String,
}

/// Run every flight of the folder and print their reports and the summary.
pub fn run(args: Args) -> Result<()> {
    let t0 = std::time::Instant::now();
    let flights = batch::find_flights(&args.dir)?;
    if flights.is_empty() {
        bail!(
            "{}: no flight subfolders (a subfolder holding rover and base observation files)",
            args.dir.display()
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the output folder", args.out.display()))?;
    let jobs = args
        .jobs
        .map_or_else(rayon::current_num_threads, usize::from);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .context("cannot start the worker threads")?;
    let bar = super::progress::Bar::new();
    bar.set_len("flights", flights.len() as u64);
    let done: Vec<Done> = pool.install(|| {
        flights
            .par_iter()
            .map(|f| {
                let d = run_flight(f, &args.out);
                bar.inc(1);
                d
            })
            .collect()
    });
    bar.finish();
    drop(bar);
    for d in &done {
        print!("{}", d.text);
    }
    let rows: Vec<SummaryRow> = done.into_iter().map(|d| d.row).collect();
    let summary = args.out.join("summary.csv");
    batch::write_summary(&summary, &rows)?;
    print_table(&rows, t0.elapsed().as_secs_f64(), &summary);
    verdict(&rows)
}

/// Exit 0 when all flights are done, 3 naming the ones that failed or skipped inputs, 1 when
/// none gave a trajectory.
fn verdict(rows: &[SummaryRow]) -> Result<()> {
    if rows.iter().all(|r| r.outcome == Outcome::Failed) {
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
fn print_table(rows: &[SummaryRow], seconds: f64, path: &Path) {
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
fn run_flight(f: &Flight, out: &Path) -> Done {
    let mut row = SummaryRow {
        flight: f.name.clone(),
        outcome: Outcome::Failed,
        epochs: 0,
        solved: 0,
        fixed: 0,
        sigma_3d: f64::NAN,
        exposures: None,
        warnings: 0,
        message: String::new(),
    };
    let mut text = format!("── flight {} ──\n", f.name);
    if let Err(e) = flight_steps(f, out, &mut row, &mut text) {
        row.outcome = Outcome::Failed;
        row.message = format!("{e:#}").replace('\n', " ");
        text.push_str(&format!("error: {}\n", row.message));
    }
    Done { row, text }
}

/// The steps of one flight, filling its row and report text.
fn flight_steps(f: &Flight, out: &Path, row: &mut SummaryRow, text: &mut String) -> Result<()> {
    let ppk_keys = config_keys(f.ppk_config.as_deref())?;
    let exp_keys = config_keys(f.exposures_config.as_deref())?;
    for p in &f.problems {
        let settled = ppk_keys.contains(p.option) || exp_keys.contains(p.option);
        if !settled {
            bail!("{}: {}", f.dir.display(), p.text);
        }
    }
    let dir = out.join(&f.name);
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("{}: cannot create the folder", dir.display()))?;
    let pos = dir.join(format!("{}.pos", f.name));
    let mut argv = start("ppk", f.ppk_config.as_deref());
    let found = [("rover", &f.rover), ("base", &f.base)];
    for (key, path) in found {
        if let (false, Some(p)) = (ppk_keys.contains(key), path) {
            push(&mut argv, key, p);
        }
    }
    if !ppk_keys.contains("nav") {
        f.nav.iter().for_each(|n| push(&mut argv, "nav", n));
    }
    push(&mut argv, "out", &pos);
    push(&mut argv, "report", &dir.join(format!("{}.html", f.name)));
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
    let given = ["events", "mrk", "times"].iter().any(|k| keys.contains(*k));
    let source = match (&f.mrk, &f.rover) {
        _ if given => None,
        (Some(m), _) => Some(("mrk", m.clone())),
        (None, Some(r)) if batch::has_events(r) => Some(("events", r.clone())),
        _ if f.exposures_config.is_none() => return Ok(()),
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

/// The keys a flight's options file sets (kebab-case), none without a file.
fn config_keys(path: Option<&Path>) -> Result<BTreeSet<String>> {
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
fn parse(argv: Vec<OsString>, text: &mut String) -> Result<crate::Cmd> {
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
