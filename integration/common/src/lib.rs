//! # common — what every layer of ppkat shares
//!
//! The small pieces that the GNSS side (`gnss`), the photogrammetric side (`photo`), the
//! crates of `integration/` and the command line all need, kept apart so that none of them
//! reaches into another's crate for them. It depends on no other ppkat crate.
//!
//! - [`atomic`]: outputs that appear whole or not at all (files renamed over, folders swapped
//!   in), and the clean-up of what killed runs left behind.
//! - [`lines`]: text inputs (plain or gzip) read line by line, every line bounded.
//! - [`progress`]: the [`progress::Progress`] trait long stages report through.
//! - [`memory`]: freed memory handed back to the operating system between stages.
//! - [`frame`], [`tmerc`]: WGS84 ECEF, geodetic and east-north-up coordinates, and the
//!   transverse Mercator projection (UTM, Gauss–Krüger).
//!
//! Angles are radians; lengths metres.

#![deny(missing_docs)]

pub mod atomic;
pub mod frame;
pub mod lines;
pub mod memory;
pub mod progress;
pub mod tmerc;
