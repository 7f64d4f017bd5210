//! `ppkat bench`: throughput and peak memory of the stages.

use anyhow::Result;
use clap::Subcommand;
use integration::adjust::RunOptions;
use integration::bench;
use std::path::PathBuf;

/// Benchmarks: observation parsing speed, carrier-phase processing time per epoch, and the
/// joint adjustment's wall time and memory.
///
/// `ppkat bench ingest FILE` streams an observation file through the parser and prints MB/s
/// of RINEX text and the peak memory; given a raw receiver log (u-blox UBX, RTCM 3 or
/// Septentrio SBF) it times its
/// conversion to RINEX observations and navigation instead and prints MB/s of log. `ppkat bench ppk …` runs `ppkat ppk` with the same
/// flags and prints the engine's milliseconds per rover epoch and the peak memory.
/// `ppkat bench adjust` simulates a block of photos and prints its joint adjustment's wall
/// time and peak memory. `ppkat bench match --photos N` renders a textured block of N photos
/// with exact truth and prints each tie-point stage's wall time and peak memory, the tracks
/// and how many are right. `ppkat bench ins` simulates a long flight with a tactical IMU and
/// times the GNSS/INS filter and smoother on it.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: BenchCmd,
}

#[derive(Subcommand)]
enum BenchCmd {
    Ingest(IngestArgs),
    Ppk(Box<PpkArgs>),
    Adjust(AdjustArgs),
    Match(MatchArgs),
    Ins(InsArgs),
}

/// Simulate a long flight with a tactical IMU and time the GNSS/INS filter on it.
///
/// A tactical-grade IMU circling at 60 m/s with GNSS positions at 1 Hz (simulated, not
/// timed); the loosely coupled forward filter and the Rauch–Tung–Striebel smoother run over
/// it with outputs at 10 Hz. Prints the samples, updates and outputs, the wall time of the
/// filter and smoother, samples per second, the peak resident memory (Linux) and the
/// smoothed positions' horizontal RMS against the truth.
#[derive(clap::Args)]
struct InsArgs {
    /// Length of the flight, minutes.
    #[arg(long, value_name = "MIN", default_value_t = 60.0, value_parser = minutes)]
    minutes: f64,
    /// IMU rate, Hz.
    #[arg(long, value_name = "HZ", default_value_t = 200.0, value_parser = rate)]
    rate: f64,
}

/// `--minutes`: more than 0, at most 600.
fn minutes(s: &str) -> std::result::Result<f64, String> {
    let x = super::finite_number(s)?;
    (x > 0.0 && x <= 600.0)
        .then_some(x)
        .ok_or_else(|| format!("'{s}': give minutes in (0, 600]"))
}

/// `--rate`: 1 to 2000 Hz.
fn rate(s: &str) -> std::result::Result<f64, String> {
    let x = super::finite_number(s)?;
    (1.0..=2000.0)
        .contains(&x)
        .then_some(x)
        .ok_or_else(|| format!("'{s}': give a rate of 1 to 2000 Hz"))
}

/// Render a textured block of about N photos and time `ppkat match` on it, stage by stage.
///
/// The block (the scene of `simulate --builtin textured-block`, 1600 × 1200 px photos, about
/// √N / 2 strips) is rendered into the folder once and reused by later runs asking for the
/// same number of photos (rendering takes about a second per photo on two cores). The match
/// runs as `ppkat match` does, with the antenna positions (pairs by footprint) or, with
/// `--no-positions`, without any (pairs by appearance), and without a feature cache. Prints
/// the pairs, each stage's wall time and peak resident memory (Linux), the tracks, the share
/// whose every measurement lies within 2 px of the truth and their RMS, and how many photos
/// came out in one block.
#[derive(clap::Args)]
struct MatchArgs {
    /// Photos in the block (rounded up to fill the strips).
    #[arg(long, value_name = "N", default_value_t = 1000,
          value_parser = clap::value_parser!(u64).range(2..100_000))]
    photos: u64,
    /// Match without positions (pairs by appearance).
    #[arg(long)]
    no_positions: bool,
    /// Folder of the rendered block (created; reused when it holds a block of the same size).
    #[arg(
        short = 'o',
        long,
        value_name = "DIR",
        default_value = "ppkat-bench-match"
    )]
    out: PathBuf,
}

/// Stream an observation file through the parser, or convert a raw log, and report MB/s and
/// peak RSS.
///
/// A RINEX file is read keeping nothing (the pure parse cost); a compressed file (gzip,
/// Hatanaka) is first expanded to a temporary plain RINEX file, so the figure is the parser's
/// speed on plain text. Prints the megabytes of RINEX text, epochs and satellite records, the
/// time, MB/s, the peak resident memory (Linux) and the memory factor: peak RSS over the
/// file's size and over the RINEX text's. A raw log (told from its content) is converted as
/// `ppkat convert --nav` does, to temporary files, repeatedly for at least a second; prints
/// megabytes of log, epochs, ephemerides, runs, MB/s, the peak memory and its factor over the
/// log's size.
/// Writes only those temporary files, removed after.
#[derive(clap::Args)]
struct IngestArgs {
    /// RINEX observation file to parse (plain, Hatanaka or gzip), or a raw receiver log
    /// (u-blox UBX, RTCM 3, Septentrio SBF).
    #[arg(value_name = "FILE")]
    file: PathBuf,
}

/// Run `ppkat ppk` with the same flags and report the engine's time per rover epoch.
///
/// Runs the carrier-phase job exactly as `ppkat ppk` (writing its outputs), prints its
/// report, then the time spent reading the inputs, the engine's time and milliseconds per
/// rover epoch, the number of filter passes and the peak resident memory (Linux).
#[derive(clap::Args)]
struct PpkArgs {
    #[command(flatten)]
    ppk: super::ppk::Args,
}

/// Simulate a block of STRIPS × PER_STRIP photos and time its joint adjustment.
///
/// Writes the simulated project into the output folder and the adjustment's outputs into its
/// `out` subfolder, and prints the block's size (images, points, observations, unknowns), the
/// simulation's and the adjustment's wall times, σ0 and the peak resident memory (Linux).
#[derive(clap::Args)]
struct AdjustArgs {
    /// Number of strips of the simulated block.
    #[arg(long, value_name = "N", default_value_t = 20)]
    strips: usize,
    /// Photos per strip.
    #[arg(long, value_name = "N", default_value_t = 50)]
    per_strip: usize,
    /// Output folder of the simulated project; the adjustment writes into DIR/out (created;
    /// files of the same names are replaced).
    #[arg(
        short = 'o',
        long,
        value_name = "DIR",
        default_value = "ppkat-bench-adjust"
    )]
    out: PathBuf,
}

/// Run the benchmark asked for and print its report.
pub fn run(args: Args, threads: Option<usize>) -> Result<()> {
    match args.what {
        BenchCmd::Ingest(a) => print!("{}", bench::ingest(&a.file)?),
        BenchCmd::Ppk(a) => {
            let r = super::ppk::run_job(a.ppk)?;
            print!("{r}{}", bench::PpkBench::of(&r));
        }
        BenchCmd::Adjust(a) => print!(
            "{}",
            bench::adjust(a.strips, a.per_strip, &a.out, &RunOptions { threads })?
        ),
        BenchCmd::Match(a) => {
            eprintln!(
                "bench match: {} photos in {} (rendered once, then reused)",
                a.photos,
                a.out.display()
            );
            let r = integration::bench_match::run(a.photos as usize, &a.out, !a.no_positions)
                .map_err(|e| anyhow::anyhow!("bench match: {e}"))?;
            print!("{r}");
        }
        BenchCmd::Ins(a) => print!("{}", integration::bench_ins::run_bench(a.minutes, a.rate)),
    }
    Ok(())
}
