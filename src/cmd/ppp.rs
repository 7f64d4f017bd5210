//! `ppkat ppp`: precise point positioning of one receiver.

use super::{elev_mask, systems, ObsFormatArg, TimeHintArgs, TrajectoryFormatArg};
use anyhow::{Context, Result};
use clap::ValueEnum;
use integration::gnss::ppk::{Motion, Reference};
use integration::gnss::ppp::PppOptions;
use integration::ppp;
use std::path::PathBuf;

/// Precise point positioning of one receiver (no base): float ionosphere-free code and
/// carrier phase with precise orbits and clocks, written as an RTKLIB-compatible .pos file
/// (Q = 6).
///
/// The model: satellite positions interpolated to the transmission time, satellite clocks
/// from clock files (--clk) or, failing that, the SP3 records (interpolated linearly, with a
/// warning about the accuracy this allows), satellite antenna offsets and nadir variations
/// under nominal yaw attitude, receiver antenna offsets and variations, phase wind-up, the
/// solid-Earth tide, the Shapiro delay, Saastamoinen hydrostatic and wet delays with Niell
/// mapping plus an estimated zenith wet delay (random walk), a receiver clock per epoch and
/// one float ambiguity per arc (new arcs at cycle slips). Satellites in the Earth's shadow
/// and for 30 minutes after are not used (their yaw is not known). Outliers restart
/// ambiguities or drop codes, and are counted. Not modelled: ocean and atmospheric loading,
/// second-order ionosphere.
///
/// In static mode each .pos line is the solution accumulated so far (the last line is the
/// final one), and OUT.pos.json holds the final coordinate with its σ, the frame of the
/// orbits and the epoch (decimal year) it holds at, residuals and counts. OUT.pos.ztd.csv
/// holds the zenith total delay per epoch, OUT.pos.html the convergence, ZTD and satellite
/// plots.
///
/// The σ are the filter's scaled by the size and time correlation of the phase residuals
/// (interpolated clocks and unmodelled effects last minutes to hours), plus a floor of
/// 1/1.5 cm horizontal/up (2/5 cm when an antenna is not modelled).
#[derive(clap::Args)]
pub struct Args {
    /// Observation file with two frequencies of code and phase: RINEX 2/3/4 (Hatanaka, gzip)
    /// or a raw receiver log (u-blox UBX RXM-RAWX, RTCM 3 MSM), told from the content.
    #[arg(long, value_name = "FILE")]
    obs: PathBuf,
    /// Format of the observation file; auto tells it from its content.
    #[arg(long, value_enum, value_name = "FORMAT", default_value = "auto")]
    obs_format: ObsFormatArg,
    #[command(flatten)]
    time: TimeHintArgs,
    /// Precise orbits (SP3-a/b/c/d, plain or gzip); give the flag once per file: the
    /// previous, current and next day's files cover the day's edges.
    #[arg(long, value_name = "FILE", required = true)]
    sp3: Vec<PathBuf>,
    /// RINEX clock files (30 s or finer) whose satellite clocks are used instead of the SP3
    /// clocks; give the flag once per file.
    #[arg(long, value_name = "FILE")]
    clk: Vec<PathBuf>,
    /// Navigation files: only for GLONASS frequency channels missing from the header.
    #[arg(long, value_name = "FILE")]
    nav: Vec<PathBuf>,
    /// ANTEX files. The first gives the satellite and receiver antenna model (it must match
    /// the orbits: relative igs_01.atx for orbits before GPS week 1400, absolute igs05/08/14/20
    /// after). When that file lists satellite blocks only (old relative files), give another
    /// ANTEX file that names the satellites (e.g. igs05.atx): it is used only to know which
    /// block each satellite belonged to at the time.
    #[arg(long, value_name = "FILE")]
    antex: Vec<PathBuf>,
    /// One position over the whole span (static), or one per epoch (kinematic).
    #[arg(long, value_enum, default_value = "static")]
    mode: ModeArg,
    /// The point the positions describe: the marker, or the antenna reference point (marker
    /// plus the header's ANTENNA: DELTA H/E/N).
    #[arg(long, value_enum, default_value = "marker")]
    refer: ReferArg,
    /// Systems to use, letters separated by commas (G GPS, E Galileo).
    #[arg(long, value_name = "LIST", default_value = "G,E")]
    systems: String,
    /// Elevation mask, degrees (0 to 90).
    #[arg(long, value_name = "DEG", default_value_t = 10.0)]
    elev_mask: f64,
    /// Layout of the output: RTKLIB .pos in ECEF (xyz) or geodetic (llh) coordinates, or a
    /// trajectory for Google Earth (kml), QGIS (geojson) or GPS tools (gpx).
    #[arg(long, value_enum, default_value = "xyz")]
    format: TrajectoryFormatArg,
    /// Heights written: ellipsoidal (WGS84, GNSS's own), egm96 (orthometric above the EGM96
    /// geoid, built in: NGA's spherical harmonics to degree 360), egm2008 (orthometric above
    /// EGM2008, from the grid found in PROJ's or GeographicLib's data folders: PROJ_DATA,
    /// PROJ_LIB, ~/.local/share/proj, /usr/share/proj, GeographicLib's geoids; the file used
    /// is named) or geoid:FILE (orthometric above a grid file, bilinear: PROJ's GeoTIFF such
    /// as us_nga_egm08_25.tif, a GeographicLib .pgm such as egm2008-1.pgm, NGA's raw EGM2008
    /// grid, a PROJ .gtx, or text lines LAT LON N; a crop of NGA's raw grid as
    /// geoid:FILE@LAT,LON,MINUTES with its north-west node and spacing). The header says which; a static run's OUT.pos.json
    /// keeps the ellipsoidal height and adds the orthometric one with the geoid undulation.
    #[arg(long, value_name = "HEIGHT", default_value = "ellipsoidal", value_parser = super::height_arg)]
    height: String,
    /// Output .pos file (replaced if it exists; not written on failure).
    #[arg(short = 'o', long, value_name = "OUT.pos")]
    out: PathBuf,
}

/// How the receiver moves.
#[derive(Clone, Copy, ValueEnum)]
enum ModeArg {
    /// One position over the whole span
    Static,
    /// A position per epoch
    Kinematic,
}

/// The point the positions describe.
#[derive(Clone, Copy, ValueEnum)]
enum ReferArg {
    /// The marker
    Marker,
    /// The antenna reference point
    Arp,
}

/// Convert the arguments into a [`ppp::PppJob`], run it with a progress spinner and print
/// its report.
pub fn run(args: Args) -> Result<()> {
    let options = PppOptions {
        systems: systems(&args.systems)?,
        elev_mask: elev_mask(args.elev_mask)?,
        motion: match args.mode {
            ModeArg::Static => Motion::Static,
            ModeArg::Kinematic => Motion::Kinematic,
        },
        refer: match args.refer {
            ReferArg::Marker => Reference::Marker,
            ReferArg::Arp => Reference::Arp,
        },
        ..PppOptions::default()
    };
    let job = ppp::PppJob {
        obs: args.obs,
        sp3: args.sp3,
        clk: args.clk,
        nav: args.nav,
        antex: args.antex,
        options,
        format: args.format.into(),
        out: args.out,
        heights: super::heights(&args.height)?,
        obs_format: args.obs_format.into(),
        time_hint: args.time.hint(),
    };
    let bar = super::progress::Bar::new();
    let report = ppp::ppp(&job, &bar);
    drop(bar);
    print!("{}", report.context("precise point positioning failed")?);
    Ok(())
}
