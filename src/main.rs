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

#[derive(Clone, Copy, ValueEnum)]
enum TimeSystemArg {
    Gpst,
    Utc,
}

#[derive(Clone, Copy, ValueEnum)]
enum ConventionArg {
    /// yaw, pitch, roll (IMU, gimbal, compass)
    Ypr,
    /// omega, phi, kappa (R = Rω·Rφ·Rκ)
    Opk,
    /// phi, omega, kappa (R = Rφ·Rω·Rκ)
    Pok,
}

#[derive(Clone, Copy, ValueEnum)]
enum ExportArg {
    Metashape,
    Pix4d,
    Odm,
    Csv,
    Pos,
    /// Antenna positions with full covariance and segments: the GNSS input of `adjust`.
    Antenna,
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
    /// Camera projection centres: exposure times on a trajectory, lever arm rotated by the
    /// camera attitude, exported for photogrammetry software.
    Exposures {
        /// Antenna trajectory (.pos, llh or xyz).
        #[arg(long)]
        trajectory: PathBuf,
        /// Rover RINEX with flag-5 event records.
        #[arg(long, group = "src")]
        events: Option<PathBuf>,
        /// DJI Timestamp.MRK.
        #[arg(long, group = "src")]
        mrk: Option<PathBuf>,
        /// CSV of times (header: id and week,tow or time).
        #[arg(long, group = "src")]
        times: Option<PathBuf>,
        /// Time system of --times.
        #[arg(long, value_enum, default_value = "gpst")]
        time_system: TimeSystemArg,
        /// Antenna phase centre in the camera frame, metres: U,V,W.
        #[arg(long, allow_hyphen_values = true)]
        lever_arm: Option<String>,
        /// Attitude CSV: week,tow,angle1,angle2,angle3 (degrees).
        #[arg(long)]
        attitude: Option<PathBuf>,
        #[arg(long, value_enum, default_value = "ypr")]
        attitude_convention: ConventionArg,
        /// Camera latency added to every event, milliseconds.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        delay_ms: f64,
        /// Longest trajectory gap to interpolate across, seconds (default 2.5 intervals).
        #[arg(long)]
        max_gap: Option<f64>,
        #[arg(long, value_enum, default_value = "csv")]
        format: ExportArg,
        /// Folder of the photographs (JPEG), matched in name order to the exposures.
        #[arg(long)]
        photos: Option<PathBuf>,
        /// Write geotagged copies of the photos into this folder (originals are never touched).
        #[arg(long, requires = "photos")]
        geotag: Option<PathBuf>,
        /// geodetic, utm, utm:ZONE or gk:CENTRAL_MERIDIAN.
        #[arg(long, default_value = "geodetic")]
        projection: String,
        #[arg(short = 'o', long)]
        out: PathBuf,
    },
    /// The lever arm from tape lengths: D0 (origin mark → antenna) and DX,DY,DZ (marks at
    /// distance A along the body axes → antenna).
    Leverarm {
        /// D0,DX,DY,DZ in metres.
        #[arg(long)]
        tapes: String,
        /// Distance A of the marks from the origin, metres.
        #[arg(long)]
        ruler: f64,
        /// Sigma of one tape length, metres.
        #[arg(long, default_value_t = 0.002)]
        sigma: f64,
    },
    /// Bundle adjustment of a "Bundle Adjustment in the Large" problem.
    Bal {
        file: PathBuf,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Simulate a survey flight with exact truth: base and rover RINEX with camera events, a
    /// navigation file, truth trajectory, exposures, ground points and image observations.
    Simulate {
        /// Scenario file (TOML).
        #[arg(long, conflicts_with = "builtin")]
        scenario: Option<PathBuf>,
        /// Built-in scenario: demo, block20 or long (flights), or classic-block, close-range or
        /// block1000 (adjustment projects).
        #[arg(long)]
        builtin: Option<String>,
        #[arg(long)]
        out: PathBuf,
    },
    /// Joint GNSS-supported bundle adjustment of a project (TOML): writes orientations, points,
    /// residuals, report.json and report.html into the output folder.
    Adjust {
        /// The project file (see README: cameras, images, measurements, ground points, GNSS).
        #[arg(long)]
        project: PathBuf,
        /// Output folder (created; existing files of the same names are replaced atomically).
        #[arg(short, long)]
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
    /// Simulate a block of STRIPS × PER_STRIP photos and time its joint adjustment.
    Adjust {
        #[arg(long, default_value_t = 20)]
        strips: usize,
        #[arg(long, default_value_t = 50)]
        per_strip: usize,
        #[arg(long, default_value = "ppkat-bench-adjust")]
        out: PathBuf,
    },
}

fn main() {
    // `ppkat … | head` must end quietly, as other command-line tools do, not panic in print!.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
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
        Cmd::Exposures {
            trajectory,
            events,
            mrk,
            times,
            time_system,
            lever_arm,
            attitude,
            attitude_convention,
            delay_ms,
            max_gap,
            format,
            photos,
            geotag,
            projection,
            out,
        } => {
            use integration::exposure::{attitude, events::TimeSystem, export};
            use integration::pipeline::EventSource;
            let source = match (events, mrk, times) {
                (Some(p), _, _) => EventSource::Rinex(p),
                (_, Some(p), _) => EventSource::Mrk(p),
                (_, _, Some(p)) => EventSource::Times(
                    p,
                    match time_system {
                        TimeSystemArg::Gpst => TimeSystem::Gpst,
                        TimeSystemArg::Utc => TimeSystem::Utc,
                    },
                ),
                _ => bail!("give the exposure times: --events ROVER.obs, --mrk Timestamp.MRK or --times FILE.csv"),
            };
            let lever_arm = match lever_arm {
                Some(s) => {
                    let [u, v, w] = triple("--lever-arm", &s)?;
                    Some(integration::photo::lever::LeverArm::new(
                        nalgebra::Vector3::new(u, v, w),
                    ))
                }
                None => None,
            };
            let conv = match attitude_convention {
                ConventionArg::Ypr => attitude::AngleConvention::YawPitchRoll,
                ConventionArg::Opk => attitude::AngleConvention::OmegaPhiKappa,
                ConventionArg::Pok => attitude::AngleConvention::PhiOmegaKappa,
            };
            let attitude = match attitude {
                Some(p) => Some(attitude::AttitudeTable::read_csv(&p, conv)?),
                None => None,
            };
            let projection = export::Projection::parse(&projection).with_context(|| {
                format!(
                    "--projection {projection}: use geodetic, utm, utm:ZONE or gk:CENTRAL_MERIDIAN"
                )
            })?;
            let job = pipeline::ExposureJob {
                trajectory,
                events: source,
                options: integration::exposure::ExposureOptions {
                    lever_arm,
                    attitude,
                    delay_ms,
                    max_gap,
                },
                format: match format {
                    ExportArg::Metashape => export::Format::Metashape,
                    ExportArg::Pix4d => export::Format::Pix4d,
                    ExportArg::Odm => export::Format::Odm,
                    ExportArg::Csv => export::Format::Csv,
                    ExportArg::Pos => export::Format::Pos,
                    ExportArg::Antenna => export::Format::Antenna,
                },
                projection,
                out,
                photos,
                geotag,
            };
            print!("{}", pipeline::exposures(&job).context("exposures failed")?);
        }
        Cmd::Bal { file, threads } => {
            use integration::photo::bal;
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads.unwrap_or(0))
                .build()
                .context("cannot start the worker threads")?;
            let mut problem = bal::BalProblem::read(&file)?;
            println!(
                "{}: {} cameras, {} points, {} observations",
                file.display(),
                problem.cameras.len(),
                problem.points.len(),
                problem.obs.len()
            );
            let opts = bal::LmOptions {
                threads,
                ..bal::LmOptions::default()
            };
            let r = pool.install(|| bal::solve(&mut problem, &opts))?;
            println!("initial cost: {:.6e}", r.initial_cost);
            println!("iterations: {} ({} successful)", r.iterations, r.successful);
            println!(
                "wall time: {:.3} s on {} thread(s)",
                r.seconds,
                pool.current_num_threads()
            );
            println!("RMS reprojection error: {:.4} px", r.rms_px);
            println!("final cost: {:.6e}", r.final_cost);
        }
        Cmd::Leverarm {
            tapes,
            ruler,
            sigma,
        } => {
            let v: Vec<f64> = tapes
                .split(',')
                .map(|t| t.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .with_context(|| {
                    format!("--tapes '{tapes}': four lengths D0,DX,DY,DZ in metres")
                })?;
            if v.len() != 4 {
                bail!("--tapes '{tapes}': four lengths D0,DX,DY,DZ in metres");
            }
            let s = integration::exposure::leverarm::solve(v[0], [v[1], v[2], v[3]], ruler, sigma)?;
            println!(
                "lever arm (u v w, metres): {:.4} {:.4} {:.4}",
                s.offset.x, s.offset.y, s.offset.z
            );
            println!(
                "sigma     (u v w, metres): {:.4} {:.4} {:.4}",
                s.cov[(0, 0)].sqrt(),
                s.cov[(1, 1)].sqrt(),
                s.cov[(2, 2)].sqrt()
            );
        }
        Cmd::Simulate {
            scenario,
            builtin,
            out,
        } => {
            use integration::simulate;
            if let Some(r) = builtin
                .as_deref()
                .and_then(|b| simulate::block::builtin(b, &out))
            {
                println!("{}", r?);
                return Ok(());
            }
            let s = match (scenario, builtin) {
                (Some(p), _) => {
                    let text = std::fs::read_to_string(&p)
                        .with_context(|| format!("{}: cannot read the scenario", p.display()))?;
                    simulate::Scenario::from_toml(&text)
                        .with_context(|| format!("{}", p.display()))?
                }
                (None, Some(name)) => simulate::builtin(&name).with_context(|| {
                    format!(
                        "no built-in scenario '{name}' (flights: {}; adjustment projects: {})",
                        simulate::BUILTINS.join(", "),
                        simulate::block::BUILTINS.join(", ")
                    )
                })?,
                (None, None) => bail!(
                    "give --scenario FILE.toml or --builtin NAME ({})",
                    simulate::BUILTINS.join(", ")
                ),
            };
            print!("{}", simulate::run(&s, &out)?);
        }
        Cmd::Adjust { project, out } => {
            let r = integration::adjust::run(&project, &out, &Default::default())?;
            print!("{}", r.summary());
            println!("outputs in {}", out.display());
        }
        Cmd::Demo { out } => {
            print!("{}", integration::demo::run(&out, &Default::default())?);
        }
        Cmd::Bench { what } => match what {
            BenchCmd::Ingest { file } => {
                let b = integration::bench::ingest(&file)?;
                print!("{b}");
            }
            BenchCmd::Adjust {
                strips,
                per_strip,
                out,
            } => {
                print!(
                    "{}",
                    integration::bench::adjust(strips, per_strip, &out, &Default::default())?
                );
            }
        },
    }
    Ok(())
}
