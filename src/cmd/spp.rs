//! `ppkat spp`: single-point positioning of every epoch.

use super::{elev_mask, systems, ObsFormatArg, TimeHintArgs, TrajectoryFormatArg};
use anyhow::{Context, Result};
use integration::gnss::spp::SppOptions;
use integration::pipeline;
use std::path::PathBuf;

/// Single-point positioning of every epoch, written as an RTKLIB-compatible .pos file.
///
/// Reads one observation file — RINEX, or a raw u-blox UBX log (told apart by content, or
/// by --obs-format) — and the orbits: navigation files (broadcast ephemerides), or SP3
/// precise orbits (with clocks from the SP3 files or from RINEX clock files), or both; a UBX
/// log with navigation subframes (RXM-SFRBX) brings its own ephemerides, used when no
/// navigation file is given;
/// solves a code-only position and receiver clock per epoch (with fault detection and
/// exclusion), and writes an RTKLIB-compatible `.pos` file in GPS time with quality Q = 5.
/// Prints the number of epochs read and solved, why unsolved epochs failed and why satellites
/// were rejected.
///
/// Without a navigation file there are no Klobuchar ionosphere parameters: the ionosphere is
/// then not modelled (code weights are lowered, and a warning says so), no broadcast group
/// delay is applied, and GLONASS satellites need the observation header's frequency channels.
#[derive(clap::Args)]
pub struct Args {
    /// Observation file of the receiver to position: RINEX, or a raw receiver log (u-blox UBX, RTCM 3, Septentrio SBF).
    #[arg(long, value_name = "FILE")]
    obs: PathBuf,
    /// Format of the observation file; auto tells it from the content.
    #[arg(long, value_enum, value_name = "FORMAT", default_value = "auto")]
    obs_format: ObsFormatArg,
    #[command(flatten)]
    time: TimeHintArgs,
    /// Navigation file (RINEX 2/3/4 broadcast ephemerides); give the flag once per file
    /// (e.g. one per constellation). Required unless --sp3 is given or the UBX log carries
    /// ephemerides (then those are used); with --sp3 it still
    /// gives the ionosphere parameters, group delays and GLONASS frequency channels.
    #[arg(long, value_name = "FILE")]
    nav: Vec<PathBuf>,
    /// Precise orbits and clocks (SP3-a/b/c/d, plain or gzip), used instead of the broadcast
    /// ones; give the flag once per file: the previous, current and next day's files cover
    /// the day's edges (they are merged; an epoch in several files is taken from the file
    /// holding it most centrally). Positions are interpolated (degree 10), clocks linearly;
    /// a satellite outside the files or in a gap of their records is not used.
    #[arg(long, value_name = "FILE")]
    sp3: Vec<PathBuf>,
    /// RINEX clock file (2.x/3.x, plain or gzip) whose satellite clocks (AS records) are used
    /// instead of the SP3 clocks; give the flag once per file. Needs --sp3. Clocks are
    /// interpolated linearly between records, never across a gap of more than 2 record
    /// intervals: a satellite without a clock then is not used (counted in the report).
    #[arg(long, value_name = "FILE", requires = "sp3")]
    clk: Vec<PathBuf>,
    /// Elevation mask, degrees (0 to 90): satellites lower than this are not used.
    #[arg(long, value_name = "DEG", default_value_t = 15.0)]
    elev_mask: f64,
    /// Systems to use, letters separated by commas: G GPS, E Galileo, C BeiDou, J QZSS,
    /// R GLONASS.
    #[arg(long, value_name = "LIST", default_value = "G,E,C,J,R")]
    systems: String,
    /// Layout of the output: an RTKLIB .pos in llh or xyz, or KML, GeoJSON or GPX (WGS84,
    /// heights as --height; times in UTC) with every epoch's time, Q, satellites and σ.
    #[arg(long, value_enum, default_value = "llh")]
    format: TrajectoryFormatArg,
    /// Heights written: ellipsoidal (WGS84, GNSS's own), egm96 (orthometric above the EGM96
    /// geoid, built in: NGA's spherical harmonics to degree 360), egm2008 (orthometric above
    /// EGM2008, from the grid found in PROJ's or GeographicLib's data folders: PROJ_DATA,
    /// PROJ_LIB, ~/.local/share/proj, /usr/share/proj, GeographicLib's geoids; the file used
    /// is named) or geoid:FILE (orthometric above a grid file, bilinear: PROJ's GeoTIFF such
    /// as us_nga_egm08_25.tif, a GeographicLib .pgm such as egm2008-1.pgm, NGA's raw EGM2008
    /// grid, a PROJ .gtx, or text lines LAT LON N; a crop of NGA's raw grid as
    /// geoid:FILE@LAT,LON,MINUTES with its north-west node and spacing). Every output's header says which.
    #[arg(long, value_name = "HEIGHT", default_value = "ellipsoidal", value_parser = super::height_arg)]
    height: String,
    /// Output file, a .pos or the --format chosen (replaced if it exists; not written on
    /// failure).
    #[arg(short = 'o', long, value_name = "OUT.pos")]
    out: PathBuf,
}

/// Convert the arguments into a [`pipeline::SppJob`], run it and print its report.
pub fn run(args: Args) -> Result<()> {
    let systems = systems(&args.systems)?;
    let job = pipeline::SppJob {
        obs: args.obs,
        obs_format: args.obs_format.into(),
        time_hint: args.time.hint(),
        nav: args.nav,
        sp3: args.sp3,
        clk: args.clk,
        options: SppOptions {
            elev_mask: elev_mask(args.elev_mask)?,
            systems,
            ..SppOptions::default()
        },
        format: args.format.into(),
        heights: super::heights(&args.height)?,
        out: args.out,
    };
    let bar = super::progress::Bar::new();
    let report = pipeline::spp(&job, &bar);
    drop(bar);
    let report = report.context("single-point positioning failed")?;
    for n in &report.notes {
        eprintln!("note: {n}");
    }
    print!("{report}");
    Ok(())
}
