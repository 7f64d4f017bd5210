//! `ppkat adjust`: the joint GNSS-supported bundle adjustment of a project.

use anyhow::Result;
use integration::adjust::{self, RunOptions};
use std::path::PathBuf;

/// Joint GNSS-supported bundle adjustment of a project (TOML): writes orientations, points,
/// residuals, report.json and report.html into the output folder.
///
/// Reads the project file and the tables it names (cameras, image list, image measurements,
/// ground control and check points, GNSS antenna positions with their covariance; see the
/// README), adjusts image orientations, points, lever arm, GNSS drift and latency and
/// optionally the camera calibration together, with data snooping and variance components,
/// and writes orientations.csv, points.csv, image_residuals.csv, gnss_residuals.csv,
/// parameters.csv, report.json and a self-contained report.html. Prints a summary:
/// redundancy, σ0, per-group variance factors, lever arm, drift, latency, observations
/// removed and the check-point table.
///
/// Images and points the observations do not determine (a single ray, one point and a GNSS
/// centre, points in line) are left out, each named with the reason, and the rest is
/// adjusted: the exit code is then 3. Only a defect of the whole block (no datum, a drift
/// that control cannot separate) fails the run (exit 1).
#[derive(clap::Args)]
pub struct Args {
    /// The project file (TOML; see the README: cameras, images, measurements, ground points,
    /// GNSS, adjustment settings).
    #[arg(long, value_name = "FILE.toml")]
    project: PathBuf,
    /// Output folder (created; existing files of the same names are replaced atomically;
    /// nothing is written when the adjustment fails).
    #[arg(short, long, value_name = "DIR")]
    out: PathBuf,
}

/// Run the adjustment on `threads` threads and print its summary.
pub fn run(args: Args, threads: Option<usize>) -> Result<()> {
    let bar = std::sync::Arc::new(super::progress::Bar::new());
    let r = adjust::run_with_progress(
        &args.project,
        &args.out,
        &RunOptions { threads },
        Some(bar.clone()),
    );
    drop(bar);
    let r = r?;
    print!("{}", r.summary());
    println!("outputs in {}", args.out.display());
    super::complete(r.left_out)
}
