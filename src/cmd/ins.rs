//! `ppkat ins`: an IMU log and a GNSS trajectory into a smoothed position, velocity and
//! attitude trajectory (loosely coupled).

use super::triple;
use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use integration::ins::attitude::Euler;
use integration::ins::job::{run_job, ImuFormat as JobFormat, InsJob, PhaseFiles};
use integration::ins::output::{write_csv, write_pos};
use integration::ins::spec::{Grade, ImuSpec};
use nalgebra::Vector3;
use std::path::PathBuf;

/// GNSS/INS: an IMU log and a GNSS trajectory (.pos), and optionally the receivers'
/// carrier phases, into a smoothed trajectory with attitude.
///
/// The IMU log is turned into the body frame (x forward, y right, z down) by --mount and
/// shifted by --imu-time-offset; the IMU is levelled while the antenna stands still before it
/// first moves, and its heading is taken from the course once the antenna moves faster than
/// 1 m/s (nothing is written before). An error-state Kalman filter runs forward with each
/// GNSS position as an update through the lever arm (fixed epochs at 2 cm / 4 cm, others at
/// 0.3 m / 0.6 m, or the file's σ when larger), zero velocity and angular rate wherever the
/// GNSS says the antenna stands still (under 5 cm/s for a second or more), the IMU's random
/// walks raised when the innovations say the data sheet is too optimistic; a
/// Rauch–Tung–Striebel smoother then runs back over it. The run starts again from its own
/// smoothed start, and again with the random walks raised when the GNSS, returning after a
/// gap, meets the bridged positions further off than their σ said (the summary gives the
/// factor). With --rover and --base the double-differenced phases hold the IMU where no
/// position is used (tight coupling). Writes CSV (or .pos): GPS week and second, latitude,
/// longitude, ellipsoidal height of the IMU, velocity north/east/up, roll/pitch/heading
/// (degrees) and their 1-σ columns (the columns ../shared/tools/insstat.py reads), and a page
/// beside it. Exits with code 3 when IMU rows were skipped (each named on stderr).
#[derive(clap::Args)]
pub struct Args {
    /// IMU log, in the form --imu-format names, the IMU's own axes (--mount turns them).
    #[arg(long, value_name = "IMU.csv")]
    imu: PathBuf,
    /// The IMU log's RTKLIB time-tag file (default: the log's name with .tag appended).
    #[arg(long, value_name = "IMU.csv.tag")]
    imu_tag: Option<PathBuf>,
    /// Format of the IMU log: rtklib-csv (rows "ax,ay,az,gx,gy,gz,tick": g, °/s, ms since
    /// power-up, with a time-tag file; rtklibexplorer's GNSS_IMU), csv (a header naming each
    /// column with its unit, GPST: gpst_week + gpst_tow, or gpst_s, or gpst_tow alone; gx_radps
    /// or gx_dps rates, or dthx_rad / dthx_deg increments; ax_mps2 or ax_g, or dvx_mps
    /// increments; likewise y and z; each row covers the interval since the row before) or
    /// kf-gins (KF-GINS' text: "tow dθx dθy dθz dvx dvy dvz" in s, rad, m/s). Seconds of week
    /// take the GNSS trajectory's week, said in the summary. A file whose force is not near g
    /// in its stated unit, or whose rates look like °/s written as rad/s, is refused.
    #[arg(long, value_enum, default_value_t = ImuFormat::RtklibCsv)]
    imu_format: ImuFormat,
    /// GNSS antenna trajectory (.pos of ppkat or RTKLIB, llh or xyz).
    #[arg(long, value_name = "FILE.pos")]
    gnss: PathBuf,
    /// IMU grade whose data-sheet figures to use: navigation, tactical or mems.
    #[arg(long, value_name = "GRADE", default_value = "mems", value_parser = grade)]
    grade: Grade,
    /// Your IMU's figures instead of a grade's: a TOML file with name, arw_deg_per_sqrt_h,
    /// vrw_mps_per_sqrt_h, gyro_bias_instability_deg_per_h, accel_bias_instability_mg,
    /// bias_correlation_s, gyro_turn_on_deg_per_h, accel_turn_on_mg.
    #[arg(long, value_name = "IMU.toml")]
    imu_spec: Option<PathBuf>,
    /// Mounting: the body's axes in the IMU's as roll,pitch,yaw in degrees (Groves' Euler
    /// angles, as rtklibexplorer's configuration files give them); 0,0,0 when the IMU's axes
    /// are the body's.
    #[arg(
        long,
        value_name = "R,P,Y",
        default_value = "0,0,0",
        allow_hyphen_values = true
    )]
    mount: String,
    /// Seconds added to the IMU's times (its logging delay: negative when it logs late).
    #[arg(long, value_name = "S", default_value_t = 0.0, allow_hyphen_values = true, value_parser = super::finite_number)]
    imu_time_offset: f64,
    /// IMU → antenna in the body frame (forward, right, down), metres.
    #[arg(
        long,
        value_name = "X,Y,Z",
        default_value = "0,0,0",
        allow_hyphen_values = true
    )]
    lever_arm: String,
    /// A land vehicle: its velocity across and perpendicular to its nose is zero within
    /// this σ (m/s), applied while it moves faster than 1 m/s.
    #[arg(long, value_name = "M/S", value_parser = super::finite_number)]
    no_side_slip: Option<f64>,
    /// Withhold the GNSS epochs from A to B seconds after the first one (repeatable), to see
    /// how the IMU bridges an outage against the fixes left out.
    #[arg(long, value_name = "A,B", allow_hyphen_values = true)]
    withhold: Vec<String>,
    /// Write a row every this many IMU samples (besides each GNSS epoch).
    #[arg(long, value_name = "N", default_value_t = 10)]
    every: usize,
    /// Output: CSV (the columns above), or an RTKLIB .pos when the name ends in .pos (the
    /// IMU's latitude, longitude, ellipsoidal height and σ; Q that of the last GNSS epoch used
    /// when it is at most 2 s old, 5 while the IMU bridges longer). Replaced if it exists.
    /// Beside it OUT.html: the alignment, the GNSS outages bridged and how far the σ grew,
    /// attitude and its σ, position σ and the estimated sensor biases over time.
    #[arg(short = 'o', long = "out", value_name = "OUT.csv")]
    out: PathBuf,
    /// Tight coupling: the rover's observations (RINEX or a raw log). With --base, the
    /// double-differenced carrier phases update the filter wherever no position is used
    /// (withheld by --withhold, missing from the .pos, or between its epochs), so that a sky
    /// of two or three satellites still holds the IMU; their integers are learnt where the
    /// positions hold the filter (the σ of a double difference's range, its own noise
    /// included, under 2 cm; three epochs in a row within 0.15 cycle of the same integer),
    /// checked there again (dropped beyond 3σ) and kept while the phases' arcs continue.
    /// Epochs with fewer than three double differences before --withheld-satellites thins
    /// them are not used.
    #[arg(long, value_name = "FILE", requires = "base")]
    rover: Option<PathBuf>,
    /// Tight coupling: the base's observations.
    #[arg(long, value_name = "FILE", requires = "rover")]
    base: Option<PathBuf>,
    /// Tight coupling: navigation files (broadcast orbits; repeatable); default: the rover
    /// log's own.
    #[arg(long, value_name = "FILE", requires = "rover")]
    nav: Vec<PathBuf>,
    /// Tight coupling: the base's antenna reference point, ECEF metres (default: its
    /// header's).
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        requires = "rover"
    )]
    base_pos: Option<String>,
    /// Tight coupling: in the withheld windows, use the phases of only the N highest
    /// satellites (a narrow sky: a street, a cliff, trees), to see how the IMU and a few
    /// phases bridge where no position could be computed.
    #[arg(long, value_name = "N", requires = "rover", value_parser = clap::value_parser!(u64).range(2..))]
    withheld_satellites: Option<u64>,
    /// Write the forward filter's trajectory instead of the smoothed one (what a real-time
    /// system would have had; to compare).
    #[arg(long)]
    forward: bool,
    /// Options from a TOML file: each key a flag of this command without its dashes
    /// (`mount = "180,-6.79,185.35"`, `no-side-slip = 0.3`, `withhold = ["40,55"]`);
    /// relative paths are read from the file's folder; flags on the command line win over
    /// the file.
    #[arg(long, value_name = "FILE.toml")]
    config: Option<PathBuf>,
}

/// IMU log formats.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ImuFormat {
    /// RTKLIB-style raw CSV (g, °/s, ms ticks) with a time-tag file.
    RtklibCsv,
    /// A CSV with a header stating each column's quantity and unit.
    Csv,
    /// KF-GINS' text increments (tow, Δθ rad, Δv m/s).
    KfGins,
}

pub(crate) fn grade(s: &str) -> std::result::Result<Grade, String> {
    Grade::parse(s).ok_or_else(|| format!("'{s}': give navigation, tactical or mems"))
}

/// Run it: the smoothed trajectory written, a summary printed.
pub fn run(args: Args) -> Result<()> {
    let job = job(&args)?;
    let done = run_job(&job).context("ins failed")?;
    let rows: Vec<_> = if args.forward {
        done.run.forward.clone()
    } else {
        done.run
            .smoothed
            .iter()
            .map(|(t, s)| (*t, s.est, s.cov))
            .collect()
    };
    if rows.is_empty() {
        bail!("ins produced nothing: no IMU data after the alignment");
    }
    let comments = vec![
        format!(
            "ppkat ins: {} {}, coupled on {}",
            args.imu.display(),
            if args.forward {
                "forward only"
            } else {
                "smoothed"
            },
            args.gnss.display()
        ),
        format!("IMU figures: {}", job.spec.name),
    ];
    let first = done.gnss[0].time;
    let used: Vec<_> = done
        .gnss
        .iter()
        .filter(|g| !integration::ins::job::withheld(&job, first, g.time))
        .collect();
    if args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("pos"))
    {
        write_pos(&args.out, &comments, &rows, &used)?;
    } else {
        write_csv(&args.out, &comments, &rows)?;
    }
    let r = &done.run;
    let summary = format!(
        "ins: {} rows → {}; aligned at {} (levelled roll {:.2}°, pitch {:.2}°; heading from the course); {} GNSS epochs used, {} withheld or outside the IMU data; IMU noise raised ×{:.1} by the innovations; {} GNSS gaps over 2 s checked at their ends: the data sheet's noise ×{:.1}",
        rows.len(),
        args.out.display(),
        done.levelled.2,
        done.levelled.0.to_degrees(),
        done.levelled.1.to_degrees(),
        r.nis.len(),
        r.unused_fixes + (done.gnss.len() - used.len()),
        r.noise_scale,
        done.bridge_scale.1,
        done.bridge_scale.0
    );
    let summary = match &done.trial {
        Some((t, k)) => format!(
            "{summary}; the smoothed σ inside gaps checked in {} trial gaps of {:.1} s cut where the GNSS is continuous ({} fixes withheld and compared): NEES per axis {:.2}{}",
            t.gaps,
            t.length,
            t.fixes,
            t.ratio,
            if *k > 1.0 {
                format!(", the noise raised ×{k:.1} more for them")
            } else {
                String::new()
            }
        ),
        None => summary,
    };
    let summary = if args.rover.is_some() {
        let nis = r.phase_nis.iter().sum::<f64>() / r.phase_nis.len().max(1) as f64;
        format!(
            "{summary}; tight: {} phase integers learnt ({} dropped again), {} double-differenced phases used where no position was (NIS per phase {nis:.2})",
            r.integers, r.integers_dropped, r.phase_rows
        )
    } else {
        summary
    };
    let mut page = args.out.clone().into_os_string();
    page.push(".html");
    let page = PathBuf::from(page);
    let (roll, pitch, at) = done.levelled;
    integration::ins::report::write_page(
        &page,
        &rows,
        &integration::ins::report::PageInputs {
            summary: &summary,
            used: &used,
            alignment: (at, roll, pitch, done.heading),
        },
    )?;
    println!("{summary}; report → {}", page.display());
    for a in &done.assumed {
        println!("  assumed: {a}");
    }
    if args.rover.is_some() {
        let (missing, warnings) = &done.phase_notes;
        if *missing > 0 {
            println!("  tight: {missing} rover epochs without double differences (no base epoch, or fewer than three)");
        }
        for w in warnings {
            println!("  tight: {w}");
        }
    }
    let skipped: Vec<String> = done
        .imu_notes
        .iter()
        .map(|n| format!("{}: {n}", args.imu.display()))
        .collect();
    super::complete(skipped)
}

/// The library's job for the arguments.
fn job(args: &Args) -> Result<InsJob> {
    let spec = match &args.imu_spec {
        Some(p) => ImuSpec::from_file(p)?,
        None => ImuSpec::preset(args.grade),
    };
    if args.imu_tag.is_some() && !matches!(args.imu_format, ImuFormat::RtklibCsv) {
        bail!("--imu-tag belongs to --imu-format rtklib-csv; the other formats carry their times");
    }
    let m = triple("--mount", &args.mount)?;
    let l = triple("--lever-arm", &args.lever_arm)?;
    let withhold = args
        .withhold
        .iter()
        .map(|w| {
            let (a, b) = super::pair("--withhold", w)?;
            if b < a {
                bail!("--withhold {w}: give A,B with A before B");
            }
            Ok((a, b))
        })
        .collect::<Result<Vec<_>>>()?;
    if args.every == 0 {
        bail!("--every 0: give 1 or more");
    }
    Ok(InsJob {
        imu_csv: args.imu.clone(),
        imu_format: match args.imu_format {
            ImuFormat::RtklibCsv => JobFormat::RtklibCsv,
            ImuFormat::Csv => JobFormat::Csv,
            ImuFormat::KfGins => JobFormat::KfGins,
        },
        imu_tag: args.imu_tag.clone().unwrap_or_else(|| {
            let mut s = args.imu.clone().into_os_string();
            s.push(".tag");
            s.into()
        }),
        gnss: args.gnss.clone(),
        spec,
        mount: Euler {
            roll: m[0].to_radians(),
            pitch: m[1].to_radians(),
            heading: m[2].to_radians(),
        },
        imu_time_offset: args.imu_time_offset,
        lever_arm: Vector3::new(l[0], l[1], l[2]),
        no_side_slip: args.no_side_slip,
        withhold,
        every: args.every,
        phases: match (&args.rover, &args.base) {
            (Some(rover), Some(base)) => Some(PhaseFiles {
                rover: rover.clone(),
                base: base.clone(),
                nav: args.nav.clone(),
                base_position: super::ppk::base_position(args.base_pos.as_deref(), None)?,
                keep: args.withheld_satellites.map(|n| n as usize),
            }),
            _ => None,
        },
    })
}
