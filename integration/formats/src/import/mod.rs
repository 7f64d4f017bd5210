//! `ppkat import`: other tools' projects turned into ppkat project folders (`project.toml` and
//! its CSV tables, as the README describes) that `ppkat adjust` runs as they are.
//!
//! - [`micmac`]: `DicoAppuisFlottant` ground points, `SetOfMesureAppuisFlottants` image
//!   measurements, `CalibrationInternConique` calibrations, `OrientationConique` orientations
//!   (start values) and `OriConvert`-style GNSS text.
//! - [`colmap`]: a sparse text model (`cameras.txt`, `images.txt`, `points3D.txt`), its datum
//!   from the photos' EXIF GPS.
//! - [`patb`]: PATB image coordinates (millimetres from the image centre, y up, or pixels
//!   from the top-left corner) and PATB control points, with the cameras from a TOML file or
//!   from their numbers.
//!
//! Every importer counts what it read and what it skipped, with the reason ([`Summary`]);
//! problems that make the result wrong name the file, the line or element and what to do
//! ([`ImportError`]). Ground frames: map coordinates with `--crs` (UTM), or a local Cartesian
//! frame (no `--crs`) placed as east/north/up on the tangent plane at [`LOCAL_ORIGIN`]
//! (latitude 0°, longitude 0°, height 0): ECEF = (a + up, east, north), a = 6 378 137 m.
//!
//! What the importers share is in `common` (errors, summary, ground frame, text lines) and
//! `write` (the project folder written); this module only names them.

pub mod colmap;
mod common;
pub mod micmac;
mod micmac_gnss;
mod micmac_job;
pub mod patb;
pub mod strips;
mod write;

pub use common::{GroundFrame, ImportError, Summary, LOCAL_ORIGIN};
pub use write::{CameraOut, GroundOut, ProjectOut, StartOut, FILES};
