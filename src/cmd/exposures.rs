//! `ppkat exposures`: camera projection centres from exposure times on a trajectory.

use super::triple;
use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use integration::exposure::attitude::{AngleConvention, AttitudeTable};
use integration::exposure::events::TimeSystem;
use integration::exposure::export::{Format, Projection};
use integration::exposure::ExposureOptions;
use integration::photo::lever::LeverArm;
use integration::pipeline::{self, EventSource};
use std::path::PathBuf;

/// Camera projection centres: exposure times on a trajectory, lever arm rotated by the
/// camera attitude, exported for photogrammetry software.
///
/// Reads a trajectory (.pos) and the exposure times (flag-5 events of the rover's RINEX file,
/// a DJI Timestamp.MRK, or a CSV of times), interpolates the antenna position at each
/// exposure, subtracts the lever arm rotated by the camera attitude (from --attitude, else the
/// trajectory's heading with zero pitch and roll, flagged) and writes one camera station per
/// exposure, with accuracy and flags, in the chosen format. The lever arm (u, v, w) is the
/// antenna in the camera frame: X_antenna = X_camera + R·(u, v, w).
///
/// Names (the labels Metashape, Pix4D and ODM join to the images): the photographs' file names
/// with --photos DIR (the photos in EXIF capture-time order, or file-name order when not all
/// have one; with --mrk each photo goes to the MRK line whose index is its DJI_NNNN number);
/// else the lines of --names FILE; else DJI_NNNN from the MRK index (as DJI names the
/// photos), a --times file's id column, or E0001, E0002 … (with a note). With --photos,
/// --geotag writes geotagged copies (originals are never modified). Prints how many stations
/// were written, what was refused and why, and warnings; exits with code 3 when exposures
/// were refused or photos left out (each named on stderr).
#[derive(clap::Args)]
pub struct Args {
    /// Antenna trajectory (.pos from ppkat or RTKLIB, llh or xyz).
    #[arg(long, value_name = "FILE.pos")]
    trajectory: PathBuf,
    /// Exposure times: rover RINEX observation file with flag-5 event records (the receiver
    /// clock is removed from the event times).
    #[arg(long, value_name = "ROVER.obs", group = "src")]
    events: Option<PathBuf>,
    /// Exposure times: a DJI Timestamp.MRK file.
    #[arg(long, value_name = "FILE.MRK", group = "src")]
    mrk: Option<PathBuf>,
    /// Exposure times: a CSV with a header naming an id column and either week,tow or time.
    #[arg(long, value_name = "FILE.csv", group = "src")]
    times: Option<PathBuf>,
    /// Time system of the --times file.
    #[arg(long, value_enum, default_value = "gpst")]
    time_system: TimeSystemArg,
    /// Antenna phase centre in the camera frame, metres: U,V,W (default: none, the stations
    /// are the antenna positions).
    #[arg(long, value_name = "U,V,W", allow_hyphen_values = true)]
    lever_arm: Option<String>,
    /// Camera attitude over time: a CSV with header week,tow,a1,a2,a3 (GPST, angles in
    /// degrees, see --attitude-convention) (default: the trajectory heading, zero pitch and
    /// roll).
    #[arg(long, value_name = "FILE")]
    attitude: Option<PathBuf>,
    /// Camera attitude from a GNSS/INS trajectory written by `ppkat ins -o FILE.csv`: roll,
    /// pitch and heading of the IMU's body (x forward, y right, z down; the camera mounted
    /// looking down with image x forward, as --attitude-convention ypr), interpolated at each
    /// exposure with their σ, which the antenna table (--format antenna) carries as
    /// sd_omega,sd_phi,sd_kappa for `ppkat adjust`'s [attitude] observations, where the
    /// boresight between the IMU and the camera is estimated. Write the trajectory densely
    /// enough for the motion (ppkat ins --every).
    #[arg(long, value_name = "INS.csv", conflicts_with = "attitude")]
    ins: Option<PathBuf>,
    /// Meaning of the three angles of the --attitude file.
    #[arg(long, value_enum, default_value = "ypr")]
    attitude_convention: ConventionArg,
    /// Camera latency added to every exposure time, milliseconds (may be negative).
    #[arg(
        long,
        value_name = "MS",
        default_value_t = 0.0,
        allow_hyphen_values = true,
        value_parser = super::finite_number
    )]
    delay_ms: f64,
    /// Longest trajectory gap to interpolate across, seconds (default: 2.5 trajectory
    /// intervals); exposures in longer gaps are refused.
    #[arg(long, value_name = "SECONDS", value_parser = super::finite_number)]
    max_gap: Option<f64>,
    /// Output layout.
    #[arg(long, value_enum, default_value = "csv")]
    format: ExportArg,
    /// Folder of the photographs (JPEG); their file names become the exposure names. Paired
    /// in time order, the photos sorted by EXIF capture time (by file name when not every
    /// photo has one) and the rhythm of the capture times checked; with --mrk by number: MRK
    /// index = the DJI_NNNN number of the file name.
    #[arg(long, value_name = "DIR")]
    photos: Option<PathBuf>,
    /// Exposure names: a text file with one name per line in exposure order (blank lines and
    /// lines starting with # skipped); as many names as exposures.
    #[arg(long, value_name = "FILE", conflicts_with = "photos")]
    names: Option<PathBuf>,
    /// Write geotagged copies of the --photos into this folder (originals are never touched;
    /// the folder is written whole, or not at all; an existing folder holding other files than
    /// the photos' names is refused).
    #[arg(long, value_name = "OUTDIR", requires = "photos")]
    geotag: Option<PathBuf>,
    /// Horizontal coordinates of the output: geodetic, utm (zone of the first station),
    /// utm:ZONE, gk:CENTRAL_MERIDIAN (Gauss–Krüger, degrees) or EPSG:CODE (any projected
    /// system, e.g. EPSG:32632 or a national grid); heights: see --height. Also --crs.
    #[arg(
        long,
        alias = "crs",
        value_name = "PROJECTION",
        default_value = "geodetic"
    )]
    projection: String,
    /// Heights written: ellipsoidal (WGS84, GNSS's own), egm96 (orthometric above the EGM96
    /// geoid, built in: NGA's spherical harmonics to degree 360), egm2008 (orthometric above
    /// EGM2008, from the grid found in PROJ's or GeographicLib's data folders: PROJ_DATA,
    /// PROJ_LIB, ~/.local/share/proj, /usr/share/proj, GeographicLib's geoids; the file used
    /// is named) or geoid:FILE (orthometric above a grid file, bilinear: PROJ's GeoTIFF such
    /// as us_nga_egm08_25.tif, a GeographicLib .pgm such as egm2008-1.pgm, NGA's raw EGM2008
    /// grid, a PROJ .gtx, or text lines LAT LON N; a crop of NGA's raw grid as
    /// geoid:FILE@LAT,LON,MINUTES with its north-west node and spacing). Every output's header says which;
    /// geotags write a sea-level GPSAltitude only for orthometric heights.
    #[arg(long, value_name = "HEIGHT", default_value = "ellipsoidal", value_parser = super::height_arg)]
    height: String,
    /// Output file (replaced if it exists).
    #[arg(short = 'o', long, value_name = "OUT")]
    out: PathBuf,
    /// Options from a TOML file: each key a flag of this command without its dashes
    /// (`lever-arm = [0.02, -0.01, 0.12]`, `format = "metashape"`); relative paths are read
    /// from the file's folder; flags on the command line win over the file.
    #[arg(long, value_name = "FILE.toml")]
    config: Option<PathBuf>,
}

/// Time system of a CSV of times.
#[derive(Clone, Copy, ValueEnum)]
enum TimeSystemArg {
    /// GPS time
    Gpst,
    /// UTC (converted with the leap seconds)
    Utc,
}

/// Convention of the three attitude angles.
#[derive(Clone, Copy, ValueEnum)]
enum ConventionArg {
    /// yaw, pitch, roll (IMU, gimbal, compass)
    Ypr,
    /// omega, phi, kappa (R = Rω·Rφ·Rκ)
    Opk,
    /// phi, omega, kappa (R = Rφ·Rω·Rκ)
    Pok,
}

/// Output layout of the camera stations.
#[derive(Clone, Copy, ValueEnum)]
enum ExportArg {
    /// Agisoft Metashape reference CSV
    Metashape,
    /// Pix4D image geolocation CSV
    Pix4d,
    /// OpenDroneMap geo.txt
    Odm,
    /// Full CSV: time, coordinates, sigmas, quality, attitude, flags
    Csv,
    /// RTKLIB-compatible .pos
    Pos,
    /// Antenna positions with full covariance and segments: the GNSS input of `adjust`
    Antenna,
    /// KML of the projection centres for Google Earth, named by the station labels
    Kml,
    /// GeoJSON of the projection centres for QGIS (name, time, Q, σ per station)
    Geojson,
    /// GPX of the projection centres (a track point per station)
    Gpx,
}

/// Convert the arguments into a [`pipeline::ExposureJob`], run it and print its report.
pub fn run(args: Args) -> Result<()> {
    let job = job(args)?;
    if job.geotag.is_some() && !job.heights.orthometric() {
        super::note("geotags with ellipsoidal heights: EXIF GPSAltitude means above sea level, so the copies carry no EXIF altitude; the ellipsoidal height is in their XMP (ppkat:Height, drone-dji:AbsoluteAltitude). Give --height egm96 or geoid:FILE for a sea-level EXIF altitude.");
    }
    let report = pipeline::exposures(&job).context("exposures failed")?;
    print!("{report}");
    if let Some(n) = &report.names_note {
        super::note(n);
    }
    super::complete(report.skipped())
}

/// The library's job for the arguments.
pub fn job(args: Args) -> Result<pipeline::ExposureJob> {
    let events = match (args.events, args.mrk, args.times) {
        (Some(p), _, _) => EventSource::Rinex(p),
        (_, Some(p), _) => EventSource::Mrk(p),
        (_, _, Some(p)) => EventSource::Times(
            p,
            match args.time_system {
                TimeSystemArg::Gpst => TimeSystem::Gpst,
                TimeSystemArg::Utc => TimeSystem::Utc,
            },
        ),
        _ => bail!(
            "give the exposure times: --events ROVER.obs, --mrk Timestamp.MRK or --times FILE.csv"
        ),
    };
    let lever_arm = match args.lever_arm {
        Some(s) => Some(LeverArm::new(triple("--lever-arm", &s)?.into())),
        None => None,
    };
    let convention = match args.attitude_convention {
        ConventionArg::Ypr => AngleConvention::YawPitchRoll,
        ConventionArg::Opk => AngleConvention::OmegaPhiKappa,
        ConventionArg::Pok => AngleConvention::PhiOmegaKappa,
    };
    let attitude = match (args.attitude, args.ins) {
        (Some(p), _) => Some(AttitudeTable::read_csv(&p, convention)?),
        (None, Some(p)) => Some(AttitudeTable::read_ins_csv(&p)?),
        (None, None) => None,
    };
    let projection = Projection::parse(&args.projection).with_context(|| {
        format!(
            "--projection {}: use geodetic, utm, utm:ZONE, gk:CENTRAL_MERIDIAN or EPSG:CODE",
            args.projection
        )
    })?;
    let job = pipeline::ExposureJob {
        trajectory: args.trajectory,
        events,
        options: ExposureOptions {
            lever_arm,
            attitude,
            delay_ms: args.delay_ms,
            max_gap: args.max_gap,
        },
        format: match args.format {
            ExportArg::Metashape => Format::Metashape,
            ExportArg::Pix4d => Format::Pix4d,
            ExportArg::Odm => Format::Odm,
            ExportArg::Csv => Format::Csv,
            ExportArg::Pos => Format::Pos,
            ExportArg::Antenna => Format::Antenna,
            ExportArg::Kml => Format::Kml,
            ExportArg::Geojson => Format::GeoJson,
            ExportArg::Gpx => Format::Gpx,
        },
        projection,
        heights: super::heights(&args.height)?,
        out: args.out,
        photos: args.photos,
        names: args.names,
        geotag: args.geotag,
    };
    Ok(job)
}
