//! `ppkat batch`: every flight of a folder through `ppk` and `exposures`, flights in
//! parallel, and one summary table.

use super::config;
use anyhow::{bail, Context, Result};
use clap::{CommandFactory, Parser};
use common::progress::{NoProgress, Progress};
use integration::batch::{self, Flight, Outcome, SummaryRow};
use integration::batch_plan;
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
/// first warning; also OUT/plan.tsv and each flight's OUT/FLIGHT/result.json (its row and
/// report), as a cluster's tasks leave them. Prints each flight's report (in name order) and
/// the table. Exit code 0 when
/// every flight did all it was asked; 3 when some flight failed or skipped inputs (each named);
/// 1 when none gave a trajectory.
///
/// Many machines: `--plan` validates every flight and writes OUTDIR/plan.tsv (a line per
/// flight: index, name, what is wrong with it, the command of its task, its outputs); task i
/// of any scheduler runs `ppkat batch DIR -o OUTDIR --only-index i`, and `--merge` makes the
/// summary from the tasks' results, naming the flights that failed or never ran. `--slurm`
/// writes (and with `--submit` submits) a Slurm job array and its merge job; `--k8s` writes
/// a Kubernetes Indexed Job and its merge Job; `--status` shows where every flight stands.
/// Every output is written whole (temporary file, then renamed): a task or a merge may be
/// run again at any time.
#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("mode").args(["plan", "only_index", "only", "merge", "status", "slurm", "k8s"])))]
pub struct Args {
    /// Folder whose subfolders are the flights (subfolders without observation files are
    /// left out).
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
    /// Output folder (created): a subfolder per flight and summary.csv.
    #[arg(short = 'o', long, value_name = "OUTDIR")]
    pub out: PathBuf,
    /// Flights processed at the same time (default: one per worker thread, see --threads);
    /// results are the same whatever the number.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    jobs: Option<u16>,
    /// Validate every flight (inputs readable, options files parse, outputs apart) and write
    /// OUTDIR/plan.tsv: a line per flight with its index, name, what is wrong with it, the
    /// command its task runs and the outputs it writes. Runs nothing. Exit 3 when a flight
    /// cannot run (named; its task will fail saying why), else 0.
    #[arg(long)]
    pub plan: bool,
    /// Run the flight of this index in OUTDIR/plan.tsv alone (a scheduler's task: Slurm's
    /// $SLURM_ARRAY_TASK_ID, Kubernetes' $JOB_COMPLETION_INDEX): its outputs, then
    /// OUTDIR/FLIGHT/result.json, and OUTDIR/status/FLIGHT.json when it starts and ends (exit
    /// code, wall time, peak memory). Safe to run again; exit 0, 3 or 1 as the flight went.
    #[arg(long, value_name = "I")]
    pub only_index: Option<usize>,
    /// Run the flight of this name in OUTDIR/plan.tsv alone (as --only-index).
    #[arg(long, value_name = "FLIGHT")]
    pub only: Option<String>,
    /// Make OUTDIR/summary.csv and the table from the results of the plan's flights, naming
    /// those that failed or never ran (exit 3; 1 when none gave a trajectory). Safe to run
    /// again: nothing is counted twice.
    #[arg(long)]
    pub merge: bool,
    /// Show where every flight of the plan stands: done, skipped inputs, failed (with its
    /// error), running (where, since when), died (no result), not started.
    #[arg(long)]
    pub status: bool,
    /// Write the plan and a Slurm job array (OUTDIR/slurm/batch.sbatch: a task per flight,
    /// logs in OUTDIR/logs/) with its merge job (merge.sbatch, to run after it with
    /// --dependency=afterany); print the sbatch commands, or run them with --submit. Every
    /// path is the shared filesystem's: no task relies on a local disk.
    #[arg(long)]
    pub slurm: bool,
    /// With --slurm: submit the array and the merge after it (sbatch on the PATH).
    #[arg(long, requires = "slurm")]
    pub submit: bool,
    /// With --slurm or --k8s: tasks running at once (Slurm's %M, the Job's parallelism;
    /// default 16).
    #[arg(long, value_name = "M", value_parser = clap::value_parser!(u16).range(1..))]
    pub max_parallel: Option<u16>,
    /// With --slurm or --k8s: CPUs per task (default 1: the flights are the parallelism).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub cpus_per_task: Option<u16>,
    /// With --slurm or --k8s: memory per task, MB (default: from the largest flight's
    /// input, 512 MB + 40 × its observation files' size, compressed files counted 8 times;
    /// said in the plan's output).
    #[arg(long, value_name = "MB", value_parser = clap::value_parser!(u32).range(64..))]
    pub mem_per_task: Option<u32>,
    /// With --slurm: one more #SBATCH option for both scripts, e.g.
    /// --sbatch-option=--partition=survey (repeatable).
    #[arg(long, value_name = "OPTION", allow_hyphen_values = true)]
    pub sbatch_option: Vec<String>,
    /// Write the plan and Kubernetes manifests: OUTDIR/k8s/batch-job.json (an Indexed Job, a
    /// pod per flight, JOB_COMPLETION_INDEX → --only-index, the folders from a
    /// PersistentVolumeClaim at /data) and merge-job.json; print the kubectl commands that
    /// would submit them (nothing is submitted).
    #[arg(long)]
    pub k8s: bool,
    /// With --k8s: the container image holding `ppkat` on its PATH.
    #[arg(long, value_name = "IMAGE", default_value = "ppkat:latest")]
    pub image: String,
    /// With --k8s: the PersistentVolumeClaim that holds DIR and OUTDIR.
    #[arg(long, value_name = "NAME", default_value = "ppkat-data")]
    pub claim: String,
    /// With --k8s: the local folder the claim holds, mounted at /data in the pods; DIR and
    /// OUTDIR must lie inside it (default: DIR's parent).
    #[arg(long, value_name = "DIR")]
    pub mount: Option<PathBuf>,
}

/// What one flight's run gave: its summary row and its report text.
pub(super) struct Done {
    /// The summary row.
    pub row: SummaryRow,
    /// The report text.
    pub text: String,
}

/// Run every flight of the folder and print their reports and the summary; or, with a
/// mode flag, one step of a run across machines ([`super::batch_cluster`]).
pub fn run(args: Args) -> Result<()> {
    use super::batch_cluster as c;
    if args.status {
        return c::status(&args);
    }
    if args.merge {
        return c::merge(&args);
    }
    if args.only_index.is_some() || args.only.is_some() {
        return c::task(&args);
    }
    if args.plan || args.slurm || args.k8s {
        return c::plan_and_scripts(&args);
    }
    let t0 = std::time::Instant::now();
    // The plan checks the flights and makes the folders absolute: a flight run here writes
    // what its task on a cluster would.
    let (plan, _) = super::batch_cluster::make_plan(&args.dir, &args.out)?;
    let flights = batch::find_flights(&plan.root)?;
    let out = plan.out.clone();
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
                let d = run_flight(f, &out);
                bar.inc(1);
                d
            })
            .collect()
    });
    bar.finish();
    drop(bar);
    for d in &done {
        print!("{}", d.text);
        batch_plan::FlightResult::new(&d.row, &d.text).write(&out)?;
    }
    plan.write()?;
    let rows: Vec<SummaryRow> = done.into_iter().map(|d| d.row).collect();
    let summary = out.join("summary.csv");
    batch::write_summary(&summary, &rows)?;
    print_table(&rows, t0.elapsed().as_secs_f64(), &summary);
    verdict(&rows)
}

/// Exit 0 when all flights are done, 3 naming the ones that failed or skipped inputs, 1 when
/// none gave a trajectory.
pub(super) fn verdict(rows: &[SummaryRow]) -> Result<()> {
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
pub(super) fn print_table(rows: &[SummaryRow], seconds: f64, path: &Path) {
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
pub(super) fn run_flight(f: &Flight, out: &Path) -> Done {
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

/// The keys of a flight's two options files, once its open questions are settled by them.
pub(super) fn settled_keys(f: &Flight) -> Result<(BTreeSet<String>, BTreeSet<String>)> {
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
pub(super) fn ppk_argv(f: &Flight, keys: &BTreeSet<String>, dir: &Path) -> Vec<OsString> {
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
pub(super) fn exposures_argv(
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
pub(super) fn config_keys(path: Option<&Path>) -> Result<BTreeSet<String>> {
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
pub(super) fn parse(argv: Vec<OsString>, text: &mut String) -> Result<crate::Cmd> {
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
