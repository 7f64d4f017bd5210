//! `ppkat` command line: parse arguments, call one library function, print its report.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use integration::gnss::rinex::summary::ObsSummary;
use integration::gnss::rinex::ObsFile;
use integration::gnss::solution::PosFormat;
use integration::gnss::spp::SppOptions;
use integration::gnss::sv::Constellation;
use integration::pipeline;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "ppkat",
    version,
    about = "Flight GNSS post-processing and GNSS-supported aerial triangulation"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Clone, Copy, ValueEnum)]
enum Format {
    Llh,
    Xyz,
}

#[derive(Subcommand)]
enum Cmd {
    /// Describe an observation file: version, span, interval, systems, signals, events, problems.
    Info { file: PathBuf },
    /// Single-point positioning of every epoch, written as an RTKLIB-compatible .pos file.
    Spp {
        #[arg(long)]
        obs: PathBuf,
        /// Navigation file(s) (RINEX 2/3/4, may be given several times).
        #[arg(long, required = true)]
        nav: Vec<PathBuf>,
        /// Precise orbits and clocks (SP3) used instead of the broadcast ones.
        #[arg(long)]
        sp3: Option<PathBuf>,
        /// Elevation mask in degrees.
        #[arg(long, default_value_t = 15.0)]
        elev_mask: f64,
        /// Systems to use, e.g. G,E,C,J,R.
        #[arg(long, default_value = "G,E,C,J,R")]
        systems: String,
        #[arg(long, value_enum, default_value = "llh")]
        format: Format,
        #[arg(short = 'o', long)]
        out: PathBuf,
    },
    /// Benchmarks: `ppkat bench ingest FILE` measures observation parsing speed and memory.
    Bench {
        #[command(subcommand)]
        what: BenchCmd,
    },
}

#[derive(Subcommand)]
enum BenchCmd {
    /// Stream an observation file through the parser and report MB/s and peak RSS.
    Ingest { file: PathBuf },
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Info { file } => {
            let f = ObsFile::read(&file)?;
            print!("{}", ObsSummary::of(&f));
        }
        Cmd::Spp {
            obs,
            nav,
            sp3,
            elev_mask,
            systems,
            format,
            out,
        } => {
            let Some(systems) = Constellation::parse_list(&systems) else {
                bail!("--systems '{systems}': use letters among G,E,C,J,R separated by commas");
            };
            if !(0.0..90.0).contains(&elev_mask) {
                bail!("--elev-mask {elev_mask}: give an angle in degrees between 0 and 90");
            }
            let job = pipeline::SppJob {
                obs,
                nav,
                sp3,
                options: SppOptions {
                    elev_mask: elev_mask.to_radians(),
                    systems,
                    ..SppOptions::default()
                },
                format: match format {
                    Format::Llh => PosFormat::Llh,
                    Format::Xyz => PosFormat::Xyz,
                },
                out,
            };
            let report = pipeline::spp(&job).context("single-point positioning failed")?;
            print!("{report}");
        }
        Cmd::Bench { what } => match what {
            BenchCmd::Ingest { file } => {
                let b = integration::bench::ingest(&file)?;
                print!("{b}");
            }
        },
    }
    Ok(())
}
