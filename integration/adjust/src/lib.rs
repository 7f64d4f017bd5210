#![deny(missing_docs)]
//! # adjust — the joint GNSS-supported bundle adjustment
//!
//! `ppkat adjust`: image points, control and
//! check points, GNSS antenna positions with their full covariance, an unknown lever arm,
//! drift per block, strip or ambiguity segment, optional self-calibration — all factors on
//! `photo::lsq`, the one least-squares core. Then data snooping with removal, variance
//! components, covariances, reliability and the check-point table; outputs in geodetic and
//! UTM / Gauss–Krüger.
//!
//! What enters: a project file (TOML) naming its tables, or a [`project::Project`] built in
//! memory. What leaves: [`results::Results`] and the files of [`report`].
//!
//! Stages, each a module that only uses the ones before it: [`input`] (the rows of the
//! tables) ← `tables` (readers) ← [`project`] (TOML schema, loading) → [`build`] (frame, start
//! values, factors; [`factors`] holds the GNSS-centre factor) → [`solve`](mod@solve) (snooping, variance
//! components) → [`residuals`] and [`results`] (numbers for the report, read from the factors)
//! → [`report`] (CSV, JSON, HTML with SVG plots). [`error`] is the error type of them all.

mod assemble;
pub mod attitude;
pub mod build;
pub mod camera_section;
mod checks;
pub mod dd_factor;
pub mod error;
mod estimated;
pub mod factors;
mod frame;
pub mod groups;
pub mod input;
pub mod latency;
mod leave_out;
mod parameters;
pub mod project;
mod quality;
mod rays;
pub mod report;
mod residual_plots;
pub mod residuals;
pub mod results;
pub mod sections;
pub mod solve;
mod start;
pub mod start_file;
mod start_relative;
mod summary;
mod tables;
pub mod tight;
pub mod tight_report;

pub use error::AdjustError;
use project::Project;
pub use solve::{solve, solve_with_progress, RunOptions, SharedProgress, Solved};
pub use start::compass_rotation;
use std::path::Path;

/// Load, adjust and write every output into `out`; returns the report.
pub fn run(
    project_path: &Path,
    out: &Path,
    opts: &RunOptions,
) -> Result<results::Results, AdjustError> {
    run_with_progress(project_path, out, opts, None)
}

/// [`run`], the solves and snooping rounds told to `progress` ([`solve_with_progress`]).
pub fn run_with_progress(
    project_path: &Path,
    out: &Path,
    opts: &RunOptions,
    progress: Option<SharedProgress>,
) -> Result<results::Results, AdjustError> {
    let project = Project::load(project_path)?;
    let solved = solve_with_progress(&project, opts, progress)?;
    let res = results::collect(&project, &solved)?;
    report::write_all(&project, &res, out)?;
    Ok(res)
}
