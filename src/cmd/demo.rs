//! `ppkat demo`: the whole chain on the built-in simulated flight.

use anyhow::Result;
use integration::adjust::RunOptions;
use std::path::PathBuf;

/// The whole chain on a built-in simulated flight, with an accuracy summary against truth.
///
/// Simulates the built-in demo flight (rover and base RINEX with camera events, navigation
/// file, truth), then runs single-point positioning, carrier-phase positioning, the camera
/// exposures and the joint GNSS-supported bundle adjustment, and prints each stage's accuracy
/// against the exact truth. Everything, inputs and outputs, goes into the output folder; the
/// adjustment report is OUT/adjust/report.html.
#[derive(clap::Args)]
pub struct Args {
    /// Output folder (created; files of the same names are replaced).
    #[arg(short = 'o', long, value_name = "DIR", default_value = "ppkat-demo")]
    out: PathBuf,
}

/// Run the demo chain on `threads` threads and print its report.
pub fn run(args: Args, threads: Option<usize>) -> Result<()> {
    print!(
        "{}",
        integration::demo::run(&args.out, &RunOptions { threads })?
    );
    Ok(())
}
