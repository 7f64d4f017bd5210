#![deny(missing_docs)]
//! # formats — other tools' files, read as ppkat's own
//!
//! What surveyors bring from the programs they use today: projects of MicMac, COLMAP and
//! PATB turned into ppkat project folders, and an RTKLIB configuration file's options as
//! `ppkat ppk` flags. The files ppkat itself writes and reads (project tables, `.pos`,
//! exports) stay with the stage that owns them, but for one: ppkat camera files
//! (`import::patb::camera_file`, `[[camera]]` tables), which `ppkat match` reads too.
//!
//! - [`import`]: MicMac, COLMAP and PATB projects → `project.toml` and its CSV tables, which
//!   `adjust` runs as they are.
//! - [`rtklib_conf`]: `ppkat ppk --rtklib-conf FILE.conf`.
//!
//! Dependency direction: `import` uses `adjust` (camera sections, project schema) and
//! `exposure` (the photos' EXIF positions); `rtklib_conf` stands alone.

pub mod import;
pub mod rtklib_conf;
