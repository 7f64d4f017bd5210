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

#[derive(Clone, Copy, ValueEnum)]
enum FilterArg {
    Forward,
    Backward,
    Combined,
}

#[derive(Clone, Copy, ValueEnum)]
enum ArArg {
    Continuous,
    Instantaneous,
    FixAndHold,
    Off,
}

/// Three comma-separated numbers.
fn triple(what: &str, s: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .with_context(|| format!("{what} '{s}': give three numbers separated by commas"))?;
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        bail!("{what} '{s}': give exactly three numbers separated by commas");
    }
    Ok([v[0], v[1], v[2]])
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
    /// Carrier-phase kinematic positioning of a rover against a base (double differences,
    /// integer ambiguities), written as an RTKLIB-compatible .pos file.
    Ppk {
        #[arg(long)]
        rover: PathBuf,
        #[arg(long)]
        base: PathBuf,
        #[arg(long, required = true)]
        nav: Vec<PathBuf>,
        /// Base marker position, ECEF metres: X,Y,Z.
        #[arg(long, allow_hyphen_values = true, conflicts_with = "base_llh")]
        base_pos: Option<String>,
        /// Base marker position: latitude,longitude (degrees), ellipsoidal height (m).
        #[arg(long, allow_hyphen_values = true)]
        base_llh: Option<String>,
        #[arg(long, value_enum, default_value = "combined")]
        filter: FilterArg,
        #[arg(long, value_enum, default_value = "fix-and-hold")]
        ar: ArArg,
        #[arg(long, default_value_t = 15.0)]
        elev_mask: f64,
        /// Receiver antenna calibrations (ANTEX) for the header antenna types.
        #[arg(long)]
        antex: Option<PathBuf>,
        /// Systems, e.g. G,E,C,J (R adds GLONASS as float only).
        #[arg(long, default_value = "G,E,C,J")]
        systems: String,
        #[arg(long, value_enum, default_value = "llh")]
        format: Format,
        #[arg(short = 'o', long)]
        out: PathBuf,
    },
    /// Simulate a survey flight with exact truth: base and rover RINEX with camera events, a
    /// navigation file, truth trajectory, exposures, ground points and image observations.
    Simulate {
        /// Scenario file (TOML).
        #[arg(long, conflicts_with = "builtin")]
        scenario: Option<PathBuf>,
        /// Built-in scenario: demo, block20 or long.
        #[arg(long)]
        builtin: Option<String>,
        #[arg(long)]
        out: PathBuf,
    },
    /// The whole chain on a built-in simulated flight, with an accuracy summary against truth.
    Demo {
        #[arg(long, default_value = "ppkat-demo")]
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
        Cmd::Ppk {
            rover,
            base,
            nav,
            base_pos,
            base_llh,
            filter,
            ar,
            elev_mask,
            antex,
            systems,
            format,
            out,
        } => {
            use integration::gnss::frame::{Ecef, Geodetic};
            use integration::gnss::ppk::{ArMode, BasePosition, FilterMode, PpkOptions};
            let base_position = match (base_pos, base_llh) {
                (Some(p), _) => {
                    let [x, y, z] = triple("--base-pos", &p)?;
                    if Ecef::new(x, y, z).0.norm() < 6.0e6 {
                        bail!(
                            "--base-pos {p}: not an ECEF position on the Earth (metres expected)"
                        );
                    }
                    BasePosition::Given(Ecef::new(x, y, z))
                }
                (None, Some(l)) => {
                    let [lat, lon, h] = triple("--base-llh", &l)?;
                    if lat.abs() > 90.0 || lon.abs() > 360.0 {
                        bail!("--base-llh {l}: latitude and longitude in degrees expected");
                    }
                    BasePosition::Given(Geodetic::from_degrees(lat, lon, h).to_ecef())
                }
                (None, None) => BasePosition::Header,
            };
            let Some(systems) = Constellation::parse_list(&systems) else {
                bail!("--systems '{systems}': use letters among G,E,C,J,R separated by commas");
            };
            if !(0.0..90.0).contains(&elev_mask) {
                bail!("--elev-mask {elev_mask}: give an angle in degrees between 0 and 90");
            }
            let options = PpkOptions {
                elev_mask: elev_mask.to_radians(),
                ar_elev_mask: elev_mask.to_radians(),
                systems,
                filter: match filter {
                    FilterArg::Forward => FilterMode::Forward,
                    FilterArg::Backward => FilterMode::Backward,
                    FilterArg::Combined => FilterMode::Combined,
                },
                ar: match ar {
                    ArArg::Continuous => ArMode::Continuous,
                    ArArg::Instantaneous => ArMode::Instantaneous,
                    ArArg::FixAndHold => ArMode::FixAndHold,
                    ArArg::Off => ArMode::Off,
                },
                antex: match antex {
                    Some(p) => Some(std::sync::Arc::new(
                        integration::gnss::model::antex::Antex::read(&p)?,
                    )),
                    None => None,
                },
                ..PpkOptions::default()
            };
            let job = pipeline::PpkJob {
                rover,
                base,
                nav,
                base_position,
                options,
                format: match format {
                    Format::Llh => PosFormat::Llh,
                    Format::Xyz => PosFormat::Xyz,
                },
                out,
            };
            let bar = indicatif::ProgressBar::new_spinner();
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} {pos} epoch-passes processed ({per_sec})",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
            let report = pipeline::ppk(&job, &|n| bar.inc(n as u64));
            bar.finish_and_clear();
            print!("{}", report.context("carrier-phase positioning failed")?);
        }
        Cmd::Simulate {
            scenario,
            builtin,
            out,
        } => {
            use integration::simulate;
            let s = match (scenario, builtin) {
                (Some(p), _) => {
                    let text = std::fs::read_to_string(&p)
                        .with_context(|| format!("{}: cannot read the scenario", p.display()))?;
                    simulate::Scenario::from_toml(&text)
                        .with_context(|| format!("{}", p.display()))?
                }
                (None, Some(name)) => simulate::builtin(&name).with_context(|| {
                    format!(
                        "no built-in scenario '{name}' (there are: {})",
                        simulate::BUILTINS.join(", ")
                    )
                })?,
                (None, None) => bail!(
                    "give --scenario FILE.toml or --builtin NAME ({})",
                    simulate::BUILTINS.join(", ")
                ),
            };
            print!("{}", simulate::run(&s, &out)?);
        }
        Cmd::Demo { out } => {
            print!("{}", integration::demo::run(&out)?);
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
