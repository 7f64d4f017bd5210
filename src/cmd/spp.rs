//! `ppkat spp`: single-point positioning of every epoch.

use super::{elev_mask, systems, PosFormatArg};
use anyhow::{Context, Result};
use integration::gnss::spp::SppOptions;
use integration::pipeline;
use std::path::PathBuf;

/// Single-point positioning of every epoch, written as an RTKLIB-compatible .pos file.
///
/// Reads one RINEX observation file and one or more navigation files (broadcast ephemerides;
/// optionally SP3 precise orbits and clocks instead), solves a code-only position and receiver
/// clock per epoch (with fault detection and exclusion), and writes an RTKLIB-compatible `.pos`
/// file in GPS time with quality Q = 5. Prints the number of epochs read and solved, and why
/// unsolved epochs failed.
#[derive(clap::Args)]
pub struct Args {
    /// RINEX observation file of the receiver to position.
    #[arg(long, value_name = "FILE")]
    obs: PathBuf,
    /// Navigation file (RINEX 2/3/4 broadcast ephemerides); give the flag once per file
    /// (e.g. one per constellation).
    #[arg(long, value_name = "FILE", required = true)]
    nav: Vec<PathBuf>,
    /// Precise orbits and clocks (SP3-c/d) used instead of the broadcast ones.
    #[arg(long, value_name = "FILE")]
    sp3: Option<PathBuf>,
    /// Elevation mask, degrees (0 to 90): satellites lower than this are not used.
    #[arg(long, value_name = "DEG", default_value_t = 15.0)]
    elev_mask: f64,
    /// Systems to use, letters separated by commas: G GPS, E Galileo, C BeiDou, J QZSS,
    /// R GLONASS.
    #[arg(long, value_name = "LIST", default_value = "G,E,C,J,R")]
    systems: String,
    /// Coordinates written into the .pos file.
    #[arg(long, value_enum, default_value = "llh")]
    format: PosFormatArg,
    /// Output .pos file (replaced if it exists; not written on failure).
    #[arg(short = 'o', long, value_name = "OUT.pos")]
    out: PathBuf,
}

/// Convert the arguments into a [`pipeline::SppJob`], run it and print its report.
pub fn run(args: Args) -> Result<()> {
    let systems = systems(&args.systems)?;
    let job = pipeline::SppJob {
        obs: args.obs,
        nav: args.nav,
        sp3: args.sp3,
        options: SppOptions {
            elev_mask: elev_mask(args.elev_mask)?,
            systems,
            ..SppOptions::default()
        },
        format: args.format.into(),
        out: args.out,
    };
    let report = pipeline::spp(&job).context("single-point positioning failed")?;
    print!("{report}");
    Ok(())
}
