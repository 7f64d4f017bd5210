//! `ppkat batch`: every flight of a folder through `ppk` and `exposures`, flights in
//! parallel, and one summary table.

use super::batch_cluster::{self as c, Scheduler};
use super::batch_flight::{print_table, run_flight, verdict, Done};
use anyhow::{Context, Result};
use common::progress::Progress;
use integration::batch::{self, SummaryRow};
use integration::batch_plan;
use rayon::prelude::*;
use std::path::PathBuf;

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

/// Run every flight of the folder and print their reports and the summary; or, with a
/// mode flag, one step of a run across machines ([`super::batch_cluster`]).
pub fn run(args: Args) -> Result<()> {
    let (dir, out) = (args.dir.as_path(), args.out.as_path());
    if args.status {
        return c::status(dir, out);
    }
    if args.merge {
        return c::merge(dir, out);
    }
    if args.only_index.is_some() || args.only.is_some() {
        return c::task(dir, out, args.only_index, args.only.as_deref());
    }
    if args.plan || args.slurm || args.k8s {
        return c::plan_and_scripts(&Scheduler {
            dir,
            out,
            slurm: args.slurm,
            submit: args.submit,
            k8s: args.k8s,
            max_parallel: args.max_parallel,
            cpus_per_task: args.cpus_per_task,
            mem_per_task: args.mem_per_task,
            sbatch_option: &args.sbatch_option,
            image: &args.image,
            claim: &args.claim,
            mount: args.mount.as_deref(),
        });
    }
    let t0 = std::time::Instant::now();
    // The plan checks the flights and makes the folders absolute: a flight run here writes
    // what its task on a cluster would.
    let (plan, _) = c::make_plan(dir, out)?;
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
    // The flights have run: a plan that cannot be written (a tab in a folder's name) costs
    // only --status and --merge on this folder, said.
    if let Err(e) = plan.write() {
        eprintln!("warning: no plan written ({e}): --status and --merge cannot read this run");
    }
    let rows: Vec<SummaryRow> = done.into_iter().map(|d| d.row).collect();
    let summary = out.join("summary.csv");
    batch::write_summary(&summary, &rows)?;
    print_table(&rows, t0.elapsed().as_secs_f64(), &summary);
    verdict(&rows)
}
