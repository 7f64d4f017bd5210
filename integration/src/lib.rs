#![deny(missing_docs)]
//! # integration — where the GNSS and photogrammetric halves meet
//!
//! Everything that needs both `gnss` and `photo`; the `ppkat` binary calls one function of it
//! per command and prints what comes back.
//!
//! - [`pipeline`]: the whole-stage runs of `ppkat spp`, `ppk` and `exposures` — job (input
//!   paths, library options) in, output file and report out; [`observations`]: a run's
//!   observation files, RINEX or raw receiver log; [`orbits`]: the orbit files a run names
//!   (navigation, SP3, RINEX clock, or a log's own ephemerides) read and checked against the
//!   observations.
//! - [`exposure`]: exposure times (RINEX flag-5 events, DJI MRK, CSV) on a trajectory → camera
//!   stations (projection centres with covariance, attitude, ambiguity segment), exports for
//!   photogrammetry software, photo matching and geotags, the lever arm from tape measurements.
//! - [`adjust`]: the joint GNSS-supported adjustment of a project (images, measurements,
//!   ground points, antenna table) with statistics and reports.
//! - [`import`]: MicMac and COLMAP projects turned into ppkat project folders.
//! - [`crs`]: projected systems by EPSG code (`--crs EPSG:CODE`), pure-Rust `proj4rs`.
//! - [`vector`]: trajectories as `.pos`, KML, GeoJSON or GPX.
//! - [`height`]: ellipsoidal or orthometric output heights (EGM96 built in, geoid grids from
//!   [`geoid_grid`] files: GeographicLib PGM, PROJ GTX, text).
//! - [`survey`]: the summary of a static run (`OUT.pos.json` and report lines).
//! - [`simulate`]: a flight simulator (scenario → RINEX, navigation and truth files) and
//!   simulated adjustment projects with truth (aerial block, close-range pair).
//! - [`demo`]: the whole chain on a simulated flight, compared with the truth.
//! - [`rtklib_conf`]: an RTKLIB configuration file's options as `ppkat ppk` flags.
//! - [`batch`]: flights found in subfolders (`ppkat batch`) and their summary table.
//! - [`bench`](mod@bench): throughput and peak memory of ingest and adjustment.
//!
//! Dependency direction: `pipeline` and `demo` use `exposure`; `pipeline` uses `observations`, `orbits` and `survey`; `demo` and `bench` use
//! `simulate` and `adjust`; `simulate` writes the files `adjust` reads. Times are GPST, angles
//! radians unless a file says degrees, lengths metres.

pub mod batch;
pub mod bench;
pub mod bench_match;
pub mod demo;
pub mod hard_sky;
pub mod observations;
pub mod orbits;
pub mod pipeline;
pub mod ppp;

use report::{ppk_report, ppp_report};
pub use report::{ppk_summary, survey};
pub use adjust;
pub use exposure;
pub use formats::{import, rtklib_conf};
pub use georef::{crs, geoid_grid, height, vector};
pub use gnss;
pub use sim as simulate;
pub use tiepoints;
pub use photo;
