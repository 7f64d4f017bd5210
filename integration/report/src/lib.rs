#![deny(missing_docs)]
//! # report — what a person reads after a run
//!
//! The plots every HTML page draws, and the pages and summaries of the GNSS runs. Knows the
//! results of `gnss` and nothing of the photogrammetric side; the adjustment's own pages
//! (in `adjust`) draw with [`plot`] too.
//!
//! - [`plot`]: SVG axes, scales and series (plotters), shared by every page.
//! - [`ppk_summary`]: what a PPK run did ([`ppk_summary::PpkReport`]), as the report line and
//!   the page's table; [`ppk_report`]: the PPK page (trajectory, quality, σ, satellites).
//! - [`ppp_report`]: what a PPP run did ([`ppp_report::PppReport`]) and its page.
//! - [`survey`]: the summary of a static run (`OUT.pos.json` and report lines).
//!
//! Dependency direction: the PPK page → `ppk_summary` → `survey`; the PPP page → `survey`;
//! `survey` → `georef::height`; every page → `plot`. Times are GPST, lengths metres.

pub mod plot;
pub mod ppk_report;
pub mod ppk_summary;
pub mod ppp_report;
pub mod survey;
