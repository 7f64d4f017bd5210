//! `ppkat bal`: bundle adjustment of a "Bundle Adjustment in the Large" problem.

use anyhow::Result;
use integration::photo::bal::{self, LmOptions};
use std::path::PathBuf;

/// Bundle adjustment of a "Bundle Adjustment in the Large" problem.
///
/// Reads a BAL problem file (camera count, point count, observation count; observations;
/// cameras as Rodrigues rotation, translation, f, k1, k2; points), minimises half the sum of
/// squared reprojection errors by Levenberg–Marquardt with the points eliminated by the Schur
/// complement, and prints one line each: the problem's size, `initial cost: …`,
/// `iterations: N (M successful)`, `wall time: … s on T thread(s)`,
/// `RMS reprojection error: … px` and `final cost: …` (costs in pixels²). Writes nothing.
#[derive(clap::Args)]
pub struct Args {
    /// BAL problem file (text, as published by the BAL project, e.g. problem-49-7776-pre.txt).
    #[arg(value_name = "FILE")]
    file: PathBuf,
}

/// Adjust the file with the default solver options on `threads` threads and print the report.
pub fn run(args: Args, threads: Option<usize>) -> Result<()> {
    let opts = LmOptions {
        threads,
        ..LmOptions::default()
    };
    print!("{}", bal::run(&args.file, &opts)?);
    Ok(())
}
