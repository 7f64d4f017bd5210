//! One module per subcommand. Each holds the subcommand's clap arguments (with their help
//! texts) and a `run` that converts them into the library's options, calls one library
//! function and prints its report. Argument conversions shared by several commands live here.

pub mod adjust;
pub mod bal;
pub mod bench;
pub mod convert;
pub mod demo;
pub mod exposures;
pub mod import;
pub mod info;
pub mod leverarm;
pub mod ppk;
pub mod ppp;
pub mod simulate;
pub mod spp;

use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use integration::gnss::solution::PosFormat;
use integration::gnss::sv::Constellation;
use integration::vector::TrajectoryFormat;

/// Coordinates written into a `.pos` file.
#[derive(Clone, Copy, ValueEnum)]
pub enum PosFormatArg {
    /// Latitude, longitude (degrees), ellipsoidal height (m)
    Llh,
    /// Earth-centred, Earth-fixed X, Y, Z (m)
    Xyz,
}

impl From<PosFormatArg> for PosFormat {
    fn from(f: PosFormatArg) -> PosFormat {
        match f {
            PosFormatArg::Llh => PosFormat::Llh,
            PosFormatArg::Xyz => PosFormat::Xyz,
        }
    }
}

/// Layout of a trajectory file (`spp`, `ppk`).
#[derive(Clone, Copy, ValueEnum)]
pub enum TrajectoryFormatArg {
    /// RTKLIB .pos: latitude, longitude (degrees), ellipsoidal height (m)
    Llh,
    /// RTKLIB .pos: Earth-centred, Earth-fixed X, Y, Z (m)
    Xyz,
    /// KML for Google Earth: the track and a placemark per epoch coloured by Q
    Kml,
    /// GeoJSON for QGIS: the track and a point per epoch with time, Q, σ
    Geojson,
    /// GPX 1.1: one track, a track point per epoch with time, Q, σ
    Gpx,
}

impl From<TrajectoryFormatArg> for TrajectoryFormat {
    fn from(f: TrajectoryFormatArg) -> TrajectoryFormat {
        match f {
            TrajectoryFormatArg::Llh => TrajectoryFormat::Pos(PosFormat::Llh),
            TrajectoryFormatArg::Xyz => TrajectoryFormat::Pos(PosFormat::Xyz),
            TrajectoryFormatArg::Kml => TrajectoryFormat::Kml,
            TrajectoryFormatArg::Geojson => TrajectoryFormat::GeoJson,
            TrajectoryFormatArg::Gpx => TrajectoryFormat::Gpx,
        }
    }
}

/// Three comma-separated finite numbers, for the flag `what`.
pub fn triple(what: &str, s: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .with_context(|| format!("{what} '{s}': give three numbers separated by commas"))?;
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        bail!("{what} '{s}': give exactly three numbers separated by commas");
    }
    Ok([v[0], v[1], v[2]])
}

/// The `--systems` list, e.g. "G,E,C,J,R".
pub fn systems(s: &str) -> Result<Vec<Constellation>> {
    match Constellation::parse_list(s) {
        Some(list) => Ok(list),
        None => bail!("--systems '{s}': use letters among G,E,C,J,R separated by commas"),
    }
}

/// The `--elev-mask` angle, degrees in [0, 90), as radians.
pub fn elev_mask(deg: f64) -> Result<f64> {
    if !(0.0..90.0).contains(&deg) {
        bail!("--elev-mask {deg}: give an angle in degrees between 0 and 90");
    }
    Ok(deg.to_radians())
}
