#![deny(missing_docs)]
//! # integration — the whole-stage runs the `ppkat` binary calls
//!
//! The thin top of the house: each command of the binary is one function here (or in a crate
//! beside it), which reads the inputs, runs the stages and writes the outputs.
//!
//! - [`pipeline`]: the whole-stage runs of `ppkat spp`, `ppk` and `exposures` — job (input
//!   paths, library options) in, output file and report out; [`observations`]: a run's
//!   observation files, RINEX or raw receiver log; [`orbits`]: the orbit files a run names
//!   (navigation, SP3, RINEX clock, or a log's own ephemerides) read and checked against the
//!   observations; [`ppp`]: `ppkat ppp`.
//! - [`demo`]: the whole chain on a simulated flight, compared with the truth; [`hard_sky`]:
//!   the simulated flight under trees and bridges, scored against its truth.
//! - [`batch`]: flights found in subfolders (`ppkat batch`) and their summary table.
//! - [`bench`](mod@bench), [`bench_match`]: throughput and peak memory of ingest, adjustment
//!   and matching.
//!
//! The crates beside it in `integration/`, in the order data flows through them (each uses
//! only crates above it in this list), re-exported here under the module names the binary
//! and the tests use:
//! - `georef` → [`crs`], [`height`], [`geoid_grid`], [`vector`]: where positions are written.
//! - `report` → [`survey`], [`ppk_summary`] and the PPK and PPP pages: what a person reads.
//! - [`exposure`]: exposure times on a trajectory → camera stations, exports, geotags.
//! - [`adjust`]: the joint GNSS-supported adjustment of a project, with its report.
//! - `formats` → [`import`], [`rtklib_conf`]: other tools' files.
//! - [`tiepoints`]: `ppkat match`, photographs → a block of tie points.
//! - `sim` → [`simulate`]: flights and projects with exact truth.
//!
//! Below them all: `gnss`, `photo` and `common` (atomic outputs, bounded text input,
//! progress, frames, transverse Mercator). Times are GPST, angles radians unless a file says degrees, lengths metres.

pub mod batch;
pub mod batch_plan;
pub mod bench;
pub mod bench_ins;
pub mod bench_match;
pub mod cluster;
pub mod demo;
pub mod hard_sky;
pub mod observations;
pub mod orbits;
pub mod pipeline;
pub mod ppp;

pub use adjust;
pub use exposure;
pub use formats::{import, rtklib_conf};
pub use georef::{crs, geoid_grid, height, vector};
pub use gnss;
pub use ins;
pub use photo;
pub use report::{ppk_summary, survey};
pub use sim as simulate;
pub use tiepoints;

use report::{ppk_report, ppp_report};
