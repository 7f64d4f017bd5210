//! Projected coordinate reference systems named by an EPSG code (`--crs EPSG:CODE`): UTM
//! zones on any datum, national grids. The definitions come from `crs-definitions` (the EPSG
//! dataset as PROJ.4 strings) and the projections from `proj4rs`, both pure Rust — no system
//! PROJ. Our own transverse Mercator (`common::tmerc`) stays the projection of `utm` and `gk`;
//! the tests hold the two to the millimetre on a UTM zone.
//!
//! Enters: WGS84 geodetic positions. Leaves: easting and northing (metres) in the system;
//! heights are not transformed (ellipsoidal WGS84, as everywhere in ppkat).

use gnss::frame::Geodetic;

/// A projected system given by its EPSG code.
pub struct EpsgProjection {
    code: u16,
    proj4: &'static str,
    wgs84: proj4rs::Proj,
    target: proj4rs::Proj,
}

impl std::fmt::Debug for EpsgProjection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "EPSG:{} ({})", self.code, self.proj4)
    }
}

impl EpsgProjection {
    /// The system of EPSG `code`; an error (saying what to give instead) when the code is
    /// unknown to the dataset or is not a projected system (geographic, geocentric).
    pub fn new(code: u16) -> Result<EpsgProjection, String> {
        let def = crs_definitions::from_code(code).ok_or_else(|| {
            format!("EPSG:{code} is not in the EPSG dataset ppkat carries; give a projected system's code, e.g. EPSG:32632 (WGS 84 / UTM zone 32N)")
        })?;
        let target = proj4rs::Proj::from_proj_string(def.proj4)
            .map_err(|e| format!("EPSG:{code} ({}): {e}", def.proj4))?;
        if target.is_latlong() || target.is_geocent() {
            return Err(format!(
                "EPSG:{code} ({}) is not a projected system; use geodetic for latitude and longitude, or a projected code",
                def.proj4
            ));
        }
        let wgs84 = proj4rs::Proj::from_proj_string("+proj=longlat +datum=WGS84 +no_defs")
            .map_err(|e| format!("WGS84: {e}"))?;
        Ok(EpsgProjection {
            code,
            proj4: def.proj4,
            wgs84,
            target,
        })
    }

    /// The EPSG code.
    pub fn code(&self) -> u16 {
        self.code
    }

    /// `EPSG:CODE (PROJ.4 definition)`, for headers people read.
    pub fn name(&self) -> String {
        format!("EPSG:{} ({})", self.code, self.proj4)
    }

    /// Easting and northing (metres) of a WGS84 position; an error when the position is
    /// outside what the projection can represent.
    pub fn forward(&self, g: &Geodetic) -> Result<(f64, f64), String> {
        let mut p = (g.lon, g.lat, g.h);
        proj4rs::transform::transform(&self.wgs84, &self.target, &mut p).map_err(|e| {
            format!(
                "{:.6}°, {:.6}° cannot be projected to EPSG:{}: {e}",
                g.lat.to_degrees(),
                g.lon.to_degrees(),
                self.code
            )
        })?;
        Ok((p.0, p.1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use common::tmerc::TransverseMercator;

    /// proj4rs' UTM (EPSG:32632) equals our Krüger-series transverse Mercator to 1 mm
    /// over the zone and beyond its edges, north and south (EPSG:32732).
    #[test]
    fn epsg_utm_agrees_with_our_transverse_mercator() {
        for (code, north) in [(32632, true), (32732, false)] {
            let p = EpsgProjection::new(code).unwrap();
            let tm = TransverseMercator::utm(32, north);
            let mut worst: f64 = 0.0;
            for lat in [0.5, 12.0, 35.0, 48.3, 61.95, 79.0] {
                for lon in [3.0, 6.0, 9.0, 11.7, 12.0, 14.5] {
                    let lat = if north { lat } else { -lat };
                    let g = Geodetic::from_degrees(lat, lon, 250.0);
                    let (e, n) = p.forward(&g).unwrap();
                    let q = tm.forward(&g);
                    worst = worst.max((e - q.easting).hypot(n - q.northing));
                }
            }
            assert!(worst < 1e-3, "EPSG:{code}: {worst} m from tmerc");
        }
    }

    /// A national grid on another ellipsoid: ETRS89 / UTM 32N (EPSG:25832, GRS80, no datum
    /// shift) is the WGS84 zone to well under a millimetre here.
    #[test]
    fn etrs89_utm_and_refusals() {
        let g = Geodetic::from_degrees(52.5, 9.7, 80.0);
        let (e, n) = EpsgProjection::new(25832).unwrap().forward(&g).unwrap();
        let q = TransverseMercator::utm(32, true).forward(&g);
        assert!((e - q.easting).hypot(n - q.northing) < 1e-3);
        assert!(
            (e - 547_580.0).abs() < 1000.0 && (n - 5_816_500.0).abs() < 2000.0,
            "{e} {n}"
        );
        let err = EpsgProjection::new(4326).unwrap_err();
        assert!(err.contains("not a projected system"), "{err}");
        assert!(EpsgProjection::new(1)
            .unwrap_err()
            .contains("not in the EPSG dataset"));
    }
}
