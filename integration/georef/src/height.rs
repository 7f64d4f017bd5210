//! Heights of the written positions: ellipsoidal (WGS84, the default) or orthometric,
//! H = h − N, above a geoid whose undulation N comes from EGM96 (built in) or from a grid file
//! the user gives (`geoid:FILE`; EGM2008 is read that way, see [`Heights::parse`]).
//!
//! Enters: a `--height` value, a position (WGS84 geodetic). Leaves: the height to write and
//! the words every header uses to say which height it is. Grid files: [`crate::geoid_grid`].

use crate::geoid_grid::GeoidGrid;
use gnss::error::Result;
use gnss::frame::Geodetic;
use std::path::Path;

/// Which height the outputs carry.
#[derive(Clone, Debug, Default)]
pub enum Heights {
    /// Ellipsoidal height above the WGS84 ellipsoid (what GNSS measures).
    #[default]
    Ellipsoidal,
    /// Orthometric height above the EGM96 geoid: N from NGA's EGM96 spherical harmonics to
    /// degree 360 (the F477 algorithm, `egm96` crate), tide-free, WGS84.
    Egm96,
    /// Orthometric height above the geoid of a grid file.
    Grid(Box<GeoidGrid>),
}

/// How `--height egm2008` is given when no grid is found where PROJ and GeographicLib keep
/// theirs (see [`crate::geoid_grid::find`]).
pub const EGM2008_AS_FILE: &str = "EGM2008 comes from a grid file: --height egm2008 finds \
PROJ's us_nga_egm08_25.tif or GeographicLib's egm2008-*.pgm where PROJ and GeographicLib keep \
them; or give the file: --height geoid:FILE (a GeoTIFF, .pgm, .gtx, NGA's raw grid, or text)";

impl Heights {
    /// `ellipsoidal`, `egm96`, `egm2008` (the grid found where PROJ and GeographicLib keep
    /// theirs) or `geoid:FILE[@LAT,LON,MINUTES]` (the placement only for a crop of NGA's raw
    /// grid); the grid is read here. `Err` with the reason: a usage error (an unknown word)
    /// as [`HeightsError::Usage`], a grid that cannot be found or read as
    /// [`HeightsError::File`].
    pub fn parse(s: &str) -> std::result::Result<Heights, HeightsError> {
        Self::parse_with(s, &|k| std::env::var(k).ok())
    }

    /// [`Heights::parse`] with the environment read through `var`.
    pub fn parse_with(
        s: &str,
        var: &dyn Fn(&str) -> Option<String>,
    ) -> std::result::Result<Heights, HeightsError> {
        use crate::geoid_grid::{find, Placement};
        match s {
            "ellipsoidal" => Ok(Heights::Ellipsoidal),
            "egm96" => Ok(Heights::Egm96),
            "egm2008" => {
                let folders = find::folders(var);
                let path = find::first(&find::EGM2008_FILES, &folders)
                    .ok_or_else(|| HeightsError::NotFound(find::not_found(&folders)))?;
                GeoidGrid::read(&path)
                    .map(|g| Heights::Grid(Box::new(g.named("EGM2008"))))
                    .map_err(HeightsError::File)
            }
            s if s.starts_with("geoid:") => {
                let spec = &s[6..];
                // `FILE@LAT,LON,MINUTES` when the tail is a placement; the whole as a name
                // otherwise (a name may hold an '@').
                let (file, place) = match spec.rsplit_once('@') {
                    Some((f, p)) if !f.is_empty() => match Placement::parse(p) {
                        Some(p) => (f, Some(p)),
                        None => (spec, None),
                    },
                    _ => (spec, None),
                };
                GeoidGrid::read_placed(Path::new(file), place)
                    .map(|g| Heights::Grid(Box::new(g)))
                    .map_err(HeightsError::File)
            }
            s => Err(HeightsError::Usage(format!(
                "--height {s}: use ellipsoidal, egm96, egm2008 or geoid:FILE"
            ))),
        }
    }

    /// Whether the heights are above a geoid (sea level) rather than the ellipsoid.
    pub fn orthometric(&self) -> bool {
        !matches!(self, Heights::Ellipsoidal)
    }

    /// The geoid undulation N at `g` (0 for ellipsoidal heights), metres; `Err` when a grid
    /// does not cover the position.
    pub fn undulation(&self, g: &Geodetic) -> Result<f64> {
        let (lat, lon) = (g.lat.to_degrees(), g.lon.to_degrees());
        match self {
            Heights::Ellipsoidal => Ok(0.0),
            Heights::Egm96 => Ok(egm96::egm96_compute_altitude_offset(lat, lon)),
            Heights::Grid(grid) => grid.undulation(lat, lon),
        }
    }

    /// The height to write at `g`: h, or H = h − N.
    pub fn height(&self, g: &Geodetic) -> Result<f64> {
        Ok(g.h - self.undulation(g)?)
    }

    /// Words for headers, e.g. `ellipsoidal heights (WGS84)` or `orthometric heights H = h -
    /// N, EGM96 geoid`.
    pub fn describe(&self) -> String {
        match self {
            Heights::Ellipsoidal => "ellipsoidal heights (WGS84)".into(),
            Heights::Egm96 => {
                "orthometric heights H = h - N, EGM96 geoid (NGA spherical harmonics, degree 360)"
                    .into()
            }
            Heights::Grid(g) => match g.model() {
                Some(m) => format!(
                    "orthometric heights H = h - N, {m} geoid, grid {}",
                    g.path().display()
                ),
                None => format!("orthometric heights H = h - N, geoid grid {}", g.name()),
            },
        }
    }

    /// A short name (`ellipsoidal`, `EGM96`, the grid's file name) for tags and columns.
    pub fn short(&self) -> String {
        match self {
            Heights::Ellipsoidal => "ellipsoidal".into(),
            Heights::Egm96 => "EGM96".into(),
            Heights::Grid(g) => g.name(),
        }
    }
}

/// Why a `--height` value cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum HeightsError {
    /// Bad usage (exit code 2).
    #[error("{0}")]
    Usage(String),
    /// The grid file cannot be read (exit code 1).
    #[error(transparent)]
    File(gnss::error::Error),
    /// No grid of a named geoid was found where grids are kept (exit code 1): where it was
    /// looked for and where to put one.
    #[error("{0}")]
    NotFound(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geo(lat: f64, lon: f64) -> Geodetic {
        Geodetic {
            lat: lat.to_radians(),
            lon: lon.to_radians(),
            h: 100.0,
        }
    }

    /// NGA's EGM96 test values: the six points and undulations of the `readme.txt` that comes
    /// with the F477 program and the 15' grid (`INPUT.DAT` → `OUTF477.DAT`), longitudes east.
    #[test]
    fn egm96_matches_nga_published_test_values() {
        let nga = [
            (38.6281550, 269.7791550, -31.628),
            (-14.6212170, 305.0211140, -2.969),
            (46.8743190, 102.4487290, -43.575),
            (-23.6174460, 133.8747120, 15.871),
            (38.6254730, 359.9995000, 50.066),
            (-0.4667440, 0.0023000, 17.329),
        ];
        for (lat, lon, n) in nga {
            let got = Heights::Egm96.undulation(&geo(lat, lon)).unwrap();
            assert!(
                (got - n).abs() < 0.01,
                "({lat}, {lon}): {got:.3} m, NGA {n} m"
            );
        }
        let h = Heights::Egm96
            .height(&geo(38.6281550, 269.7791550))
            .unwrap();
        assert!((h - 131.628).abs() < 0.01, "{h}");
    }

    #[test]
    fn parse_says_what_to_do() {
        assert!(matches!(
            Heights::parse("ellipsoidal"),
            Ok(Heights::Ellipsoidal)
        ));
        assert!(matches!(Heights::parse("egm96"), Ok(Heights::Egm96)));
        let nowhere = |k: &str| (k == "HOME").then(|| "/nonexistent-home".to_string());
        match Heights::parse_with("egm2008", &nowhere) {
            Err(HeightsError::NotFound(m)) => assert!(
                m.contains("geoid:FILE") && m.contains("/nonexistent-home/.local/share/proj"),
                "{m}"
            ),
            Err(e) => panic!("{e}"),
            Ok(h) => assert!(h.describe().contains("EGM2008"), "a grid on this machine"),
        }
        assert!(matches!(Heights::parse("msl"), Err(HeightsError::Usage(_))));
        assert!(matches!(
            Heights::parse("geoid:/nonexistent/grid.txt"),
            Err(HeightsError::File(_))
        ));
    }
}
