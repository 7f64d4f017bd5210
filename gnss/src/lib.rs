//! # gnss — the GNSS half of ppkat
//!
//! - [`rinex`]: observation files (RINEX 2/3/4, Hatanaka, gzip) streamed into GPST epochs with
//!   every event record kept; navigation files into ephemeris records.
//! - [`raw`]: raw receiver logs (u-blox UBX) decoded (measurements, ephemerides, time marks)
//!   and converted to RINEX 3.04; [`obs`]: one entry for observations, RINEX or raw log,
//!   told apart by content.
//! - [`orbit`]: satellite positions and clocks from broadcast ephemerides (GPS, Galileo,
//!   BeiDou, QZSS, GLONASS) or SP3 precise orbits.
//! - [`model`], [`signal`]: troposphere, ionosphere, frequencies.
//! - [`frame`], [`tmerc`]: ECEF, geodetic, ENU and transverse Mercator coordinates, from the
//!   `common` crate (as are [`atomic`], [`progress`] and [`memory`]), re-exported here.
//! - [`spp`]: single-point positioning; [`ppk`]: carrier-phase kinematic positioning.
//! - [`trajectory`]: the rover trajectory in memory (with ambiguity segments) and its
//!   interpolation; [`solution`]: its RTKLIB-compatible `.pos` serialisation.
//!
//! Every epoch is a `hifitime::Epoch` in GPST; angles are radians; lengths metres.

#![deny(missing_docs)]

pub mod error;
pub mod model;
pub mod obs;
pub mod orbit;
pub mod ppk;
pub mod ppp;
pub mod raw;
pub mod rinex;
pub mod signal;
pub mod solution;
pub mod spp;
pub mod sv;
pub mod time;
pub mod trajectory;

pub use error::{Error, Result};

/// What every layer of ppkat shares, kept in the `common` crate and re-exported here so that
/// `gnss::frame::…` (and `crate::frame::…` inside this crate) still name it: [`frame`] and
/// [`tmerc`] (coordinates and projection), [`atomic`] (outputs written whole), [`progress`]
/// (the reporting trait of long stages), [`memory`] (freed pages handed back).
pub use common::{atomic, frame, memory, progress, tmerc};
