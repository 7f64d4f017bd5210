//! Geoid grid files (`--height geoid:FILE`): a regular latitude/longitude grid of undulations
//! N (m above the WGS84 ellipsoid), interpolated bilinearly. Five layouts, told from the
//! content:
//! - GeographicLib PGM (`P5`, the `egm2008-1/-2_5/-5.pgm` and `egm96-5/-15.pgm` files):
//!   16-bit big-endian samples, N = Offset + Scale·value from the `# Offset` and `# Scale`
//!   comment lines, rows from 90° N southwards, columns from 0° E eastwards, global.
//! - PROJ GeoTIFF (`us_nga_egm08_25.tif`, `us_nga_egm96_15.tif` and the national grids PROJ
//!   ships): the first image of a TIFF with GeoTIFF's pixel scale and tie point
//!   ([`geotiff`]).
//! - NGA's raw EGM2008 grids (`Und_min2.5x2.5_egm2008_…`, `Und_min1x1_egm2008_…`): Fortran
//!   unformatted records, one per row from the north, of float32 values ([`nga`]); the whole
//!   grids place themselves, a crop needs its north-west node and spacing ([`Placement`]).
//! - PROJ GTX (name ending `.gtx`): a 40-byte big-endian header (south latitude, west
//!   longitude, latitude step, longitude step, all degrees f64; rows, columns i32), then
//!   rows × columns f32 from the south-west corner, row by row; −88.8888 means no value.
//! - Text: one node per line, `LAT LON N` (degrees, degrees, metres; spaces, tabs or commas;
//!   `#` starts a comment), every node of a regular grid exactly once, in any order.
//!
//! Reading is bounded: at most [`MAX_GRID_BYTES`], sizes checked against the bytes present;
//! errors name the file and, for text, the line. A point the grid does not cover is an error
//! naming the point and the grid's extent. Where the usual grids are kept: [`find`].

pub mod find;
pub mod geotiff;
mod layouts;
pub mod nga;

use gnss::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Largest grid file read, bytes (GeographicLib's 1' EGM2008 grid is 467 MB).
pub const MAX_GRID_BYTES: u64 = 1 << 30;

/// A regular grid of geoid undulations.
#[derive(Clone, Debug)]
pub struct GeoidGrid {
    path: PathBuf,
    /// Latitude of row 0 (the southernmost), degrees.
    lat0: f64,
    /// Longitude of column 0 (the westernmost), degrees.
    lon0: f64,
    dlat: f64,
    dlon: f64,
    rows: usize,
    cols: usize,
    /// Row-major from the south-west corner; NaN where the grid has no value.
    n: Vec<f32>,
    /// The geoid model, when the grid was found by its name (`EGM2008`).
    model: Option<&'static str>,
}

/// Where a grid that does not say it lies: its north-west node and its spacing (a crop of
/// NGA's raw grid). Written `@LAT,LON,MINUTES` after the file name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Latitude of the northernmost row, degrees.
    pub north: f64,
    /// Longitude of the westernmost column, degrees (east positive).
    pub west: f64,
    /// Spacing of rows and columns, arc-minutes.
    pub minutes: f64,
}

impl Placement {
    /// `LAT,LON,MINUTES` (three finite numbers, a positive spacing); `None` otherwise.
    pub fn parse(s: &str) -> Option<Placement> {
        let v: Vec<f64> = s
            .split(',')
            .map(|t| t.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<_>>()?;
        match v[..] {
            [north, west, minutes] if minutes > 0.0 && north.abs() <= 90.0 => Some(Placement {
                north,
                west,
                minutes,
            }),
            _ => None,
        }
    }
}

impl GeoidGrid {
    /// Read a grid file (layout told from the content, see the module).
    pub fn read(path: &Path) -> Result<GeoidGrid> {
        Self::read_placed(path, None)
    }

    /// [`GeoidGrid::read`], with the placement of a grid that does not carry one (a crop of
    /// NGA's raw grid); a placement given for a grid that carries its own is an error.
    pub fn read_placed(path: &Path, placement: Option<Placement>) -> Result<GeoidGrid> {
        let len = std::fs::metadata(path).map_err(Error::io(path))?.len();
        if len > MAX_GRID_BYTES {
            return Err(Error::input(
                path,
                format!("{len} bytes: larger than any geoid grid this program reads (1 GiB)"),
            ));
        }
        let bytes = std::fs::read(path).map_err(Error::io(path))?;
        let is_gtx = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("gtx"));
        let nga = nga::records(&bytes);
        if placement.is_some() && nga.is_none() {
            return Err(Error::input(
                path,
                "a placement (@LAT,LON,MINUTES) is for NGA's raw grid files, whose records do not say where they lie; this grid says it itself: give the file alone",
            ));
        }
        let g = if bytes.starts_with(b"P5") {
            layouts::pgm(path, &bytes)?
        } else if geotiff::is_tiff(&bytes) {
            geotiff::read(path, &bytes)?
        } else if let Some(records) = nga {
            nga::read(path, &bytes, records, placement)?
        } else if is_gtx {
            layouts::gtx(path, &bytes)?
        } else {
            layouts::text(path, &bytes)?
        };
        if g.rows < 2 || g.cols < 2 || !(g.dlat > 0.0 && g.dlon > 0.0) {
            return Err(Error::input(
                path,
                "the grid needs at least 2 × 2 nodes with positive steps",
            ));
        }
        Ok(g)
    }

    /// A grid whose file stores its rows from the north (PGM, NGA's records, GeoTIFF): node
    /// (r, c) of the file is `value(r, c)` (NaN where there is none); `south` and `west` place
    /// the last row's first node; the steps are (latitude, longitude), all in degrees.
    fn from_north_rows(
        path: &Path,
        (south, west): (f64, f64),
        (dlat, dlon): (f64, f64),
        (rows, cols): (usize, usize),
        value: impl Fn(usize, usize) -> f32,
    ) -> GeoidGrid {
        let mut n = vec![0f32; rows * cols];
        for r in 0..rows {
            // File row r is our row rows − 1 − r (ours run from the south).
            let dst = &mut n[(rows - 1 - r) * cols..(rows - r) * cols];
            for (c, v) in dst.iter_mut().enumerate() {
                *v = value(r, c);
            }
        }
        GeoidGrid {
            path: path.to_path_buf(),
            lat0: south,
            lon0: west,
            dlat,
            dlon,
            rows,
            cols,
            n,
            model: None,
        }
    }

    /// The grid's extent in words: latitudes and longitudes of its outer nodes, the spacing.
    pub fn extent(&self) -> String {
        let north = self.lat0 + (self.rows - 1) as f64 * self.dlat;
        let east = self.lon0 + (self.cols - 1) as f64 * self.dlon;
        let lon = if self.global() {
            "all longitudes".to_string()
        } else {
            format!("longitudes {:.6}° to {east:.6}°", self.lon0)
        };
        format!(
            "latitudes {:.6}° to {north:.6}°, {lon}, every {:.4}′",
            self.lat0,
            self.dlat * 60.0
        )
    }

    /// The grid labelled as a grid of `model` (e.g. `EGM2008`).
    pub fn named(mut self, model: &'static str) -> Self {
        self.model = Some(model);
        self
    }

    /// The geoid model the grid was found for, if it was.
    pub fn model(&self) -> Option<&'static str> {
        self.model
    }

    /// The file the grid was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The file's name, for headers.
    pub fn name(&self) -> String {
        self.path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| self.path.display().to_string())
    }

    /// Whether the columns go round the globe (the last column's east neighbour is column 0).
    fn global(&self) -> bool {
        (self.cols as f64 * self.dlon - 360.0).abs() < 1e-6 * self.dlon.max(1e-9) + 1e-9
    }

    /// N at latitude, longitude (degrees), bilinear; `Err` when outside the grid or next to a
    /// node without a value.
    pub fn undulation(&self, lat: f64, lon: f64) -> Result<f64> {
        let outside = || {
            Error::input(
                &self.path,
                format!(
                    "the geoid grid does not cover latitude {lat:.6}°, longitude {lon:.6}° (it covers {}, and needs values at the four nodes around a point): give a grid that does",
                    self.extent()
                ),
            )
        };
        let y = (lat - self.lat0) / self.dlat;
        let x = (lon - self.lon0).rem_euclid(360.0) / self.dlon;
        let last_x = (self.cols - 1) as f64;
        let last_y = (self.rows - 1) as f64;
        if !(0.0..=last_y + 1e-9).contains(&y) || (!self.global() && x > last_x + 1e-9) {
            return Err(outside());
        }
        let (i, j) = (
            (y.floor() as usize).min(self.rows - 2),
            x.floor() as usize % self.cols,
        );
        let (fy, fx) = (y - i as f64, x - x.floor());
        let j1 = if self.global() {
            (j + 1) % self.cols
        } else {
            (j + 1).min(self.cols - 1)
        };
        let at = |r: usize, c: usize| self.n[r * self.cols + c] as f64;
        let v = [at(i, j), at(i, j1), at(i + 1, j), at(i + 1, j1)];
        if v.iter().any(|x| x.is_nan()) {
            return Err(outside());
        }
        let south = v[0] + (v[1] - v[0]) * fx;
        let north = v[2] + (v[3] - v[2]) * fx;
        Ok(south + (north - south) * fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str, bytes: &[u8]) -> PathBuf {
        testkit::scratch_file(&format!("geoid-{name}"), bytes)
    }

    #[test]
    fn text_grid_interpolates_bilinearly_and_names_lines() {
        let p = tmp(
            "g.txt",
            b"# lat lon N\n50 0 40\n50 1 41\n51 0 42\n51 1 44\n",
        );
        let g = GeoidGrid::read(&p).unwrap();
        assert!((g.undulation(50.5, 0.5).unwrap() - 41.75).abs() < 1e-9);
        assert!((g.undulation(50.0, 1.0).unwrap() - 41.0).abs() < 1e-9);
        assert!(g.undulation(52.0, 0.5).is_err());
        let bad = tmp("bad.txt", b"50 0 40\n50 1 x\n");
        let e = GeoidGrid::read(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.txt") && e.contains('2'), "{e}");
        let missing = tmp("missing.txt", b"50 0 40\n50 1 41\n51 0 42\n");
        assert!(GeoidGrid::read(&missing)
            .unwrap_err()
            .to_string()
            .contains("missing"));
    }

    #[test]
    fn hostile_grids_are_errors_not_panics_or_huge_allocations() {
        // Uneven latitudes {0, 0.5, 1e6}: the node at 1e6 was indexed past the grid.
        let p = tmp("uneven.txt", b"1000000 0 1\n0 0 1\n0.5 0 1\n0 1 1\n");
        let e = GeoidGrid::read(&p).unwrap_err().to_string();
        assert!(e.contains("not evenly spaced"), "{e}");
        // 50,000 diagonal nodes asked for a 2.5e9-node grid (10 GB) before the count check.
        let diag: String = (0..50_000).map(|k| format!("{k} {k} 0\n")).collect();
        let e = GeoidGrid::read(&tmp("diag.txt", diag.as_bytes()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("2500000000 nodes"), "{e}");
        // A PGM whose size makes `at + n` wrap past usize::MAX.
        let huge = b"P5\n# Offset 0\n# Scale 1\n4611686018427387903 2\n65535\n\0\0";
        let e = GeoidGrid::read(&tmp("huge.pgm", huge))
            .unwrap_err()
            .to_string();
        assert!(e.contains("shorter"), "{e}");
        // 0 columns need no bytes: the reader walked every empty row (the fuzzer's timeout).
        let empty = b"P5\n# Offset 0\n# Scale 1\n0 44444444444443\n6554";
        let e = GeoidGrid::read(&tmp("empty.pgm", empty))
            .unwrap_err()
            .to_string();
        assert!(e.contains("0 × 44444444444443 samples"), "{e}");
    }

    #[test]
    fn gtx_and_pgm_layouts() {
        let mut gtx_bytes = Vec::new();
        for v in [50.0f64, 359.0, 1.0, 1.0] {
            gtx_bytes.extend_from_slice(&v.to_be_bytes());
        }
        gtx_bytes.extend_from_slice(&2i32.to_be_bytes());
        gtx_bytes.extend_from_slice(&3i32.to_be_bytes());
        for v in [40.0f32, 41.0, 42.0, 43.0, 44.0, -88.8888] {
            gtx_bytes.extend_from_slice(&v.to_be_bytes());
        }
        let g = GeoidGrid::read(&tmp("g.gtx", &gtx_bytes)).unwrap();
        // Longitude -0.5 is 359.5 east: between columns 0 and 1 of the south row.
        assert!((g.undulation(50.0, -0.5).unwrap() - 40.5).abs() < 1e-6);
        assert!(
            g.undulation(50.5, 0.5).is_err(),
            "next to a node without value"
        );
        // A global 3 × 4 PGM (90°, 0°, −90° by 0°, 90°, 180°, 270°).
        let mut pgm_bytes = b"P5\n# Offset -10\n# Scale 0.5\n4 3\n65535\n".to_vec();
        for v in [0u16, 0, 0, 0, 20, 22, 24, 26, 40, 40, 40, 40] {
            pgm_bytes.extend_from_slice(&v.to_be_bytes());
        }
        let g = GeoidGrid::read(&tmp("g.pgm", &pgm_bytes)).unwrap();
        assert!((g.undulation(0.0, 45.0).unwrap() - 0.5).abs() < 1e-6);
        assert!(
            (g.undulation(0.0, -45.0).unwrap() - 1.5).abs() < 1e-6,
            "wraps at 360°"
        );
        assert!((g.undulation(90.0, 10.0).unwrap() + 10.0).abs() < 1e-6);
    }
}
