#![deny(missing_docs)]
//! # georef — where a position is written
//!
//! The last step of every output that carries coordinates: the system, the height and the
//! file format. Knows nothing of exposures, images or adjustments; `exposure`, the reports
//! and the pipelines call it.
//!
//! - [`crs`]: projected systems by EPSG code (`--crs EPSG:CODE`), pure-Rust `proj4rs`.
//! - [`height`]: ellipsoidal or orthometric output heights (EGM96 built in, geoid grids from
//!   [`geoid_grid`] files: GeographicLib PGM, PROJ GTX and GeoTIFF, text).
//! - [`vector`]: trajectories as `.pos`, KML, GeoJSON or GPX.
//!
//! Dependency direction: `vector` → `height` → `geoid_grid`; `crs` stands alone. Angles
//! radians unless a file says degrees, lengths metres.

pub mod crs;
pub mod geoid_grid;
pub mod height;
pub mod vector;
