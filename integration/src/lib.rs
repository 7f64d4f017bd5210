//! # integration — where the GNSS and photogrammetric halves meet
//!
//! Exposures, lever arm, the joint GNSS-supported adjustment, project files, reports and the
//! flight simulator (later issues). Today: [`pipeline`], the whole-stage runs the `ppkat`
//! binary calls. It uses `gnss` and `photo`; the binary uses it.

pub mod adjust;
pub mod bench;
pub mod demo;
pub mod exposure;
pub mod pipeline;
pub mod simulate;

pub use gnss;
pub use photo;
