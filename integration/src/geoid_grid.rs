//! Geoid grid files (`--height geoid:FILE`): a regular latitude/longitude grid of undulations
//! N (m above the WGS84 ellipsoid), interpolated bilinearly. Three layouts, told from the
//! content:
//! - GeographicLib PGM (`P5`, the `egm2008-1/-2_5/-5.pgm` and `egm96-5/-15.pgm` files):
//!   16-bit big-endian samples, N = Offset + Scale·value from the `# Offset` and `# Scale`
//!   comment lines, rows from 90° N southwards, columns from 0° E eastwards, global.
//! - PROJ GTX (name ending `.gtx`): a 40-byte big-endian header (south latitude, west
//!   longitude, latitude step, longitude step, all degrees f64; rows, columns i32), then
//!   rows × columns f32 from the south-west corner, row by row; −88.8888 means no value.
//! - Text: one node per line, `LAT LON N` (degrees, degrees, metres; spaces, tabs or commas;
//!   `#` starts a comment), every node of a regular grid exactly once, in any order.
//!
//! Reading is bounded: at most [`MAX_GRID_BYTES`], sizes checked against the bytes present;
//! errors name the file and, for text, the line.

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
}

impl GeoidGrid {
    /// Read a grid file (layout told from the content, see the module).
    pub fn read(path: &Path) -> Result<GeoidGrid> {
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
        let g = if bytes.starts_with(b"P5") {
            pgm(path, &bytes)?
        } else if is_gtx {
            gtx(path, &bytes)?
        } else {
            text(path, &bytes)?
        };
        if g.rows < 2 || g.cols < 2 || !(g.dlat > 0.0 && g.dlon > 0.0) {
            return Err(Error::input(
                path,
                "the grid needs at least 2 × 2 nodes with positive steps",
            ));
        }
        Ok(g)
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
                format!("the geoid grid does not cover latitude {lat:.6}, longitude {lon:.6}: give a grid that does"),
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

/// GeographicLib's PGM: header tokens (comments hold Offset and Scale), then u16 samples.
fn pgm(path: &Path, b: &[u8]) -> Result<GeoidGrid> {
    let mut at = 2;
    let (mut offset, mut scale) = (None, None);
    let mut nums = Vec::new();
    while nums.len() < 3 {
        while at < b.len() && b[at].is_ascii_whitespace() {
            at += 1;
        }
        if at >= b.len() {
            return Err(Error::input(path, "the PGM header is cut short"));
        }
        let end = b[at..]
            .iter()
            .position(|&c| c == b'\n' || (b[at] != b'#' && c.is_ascii_whitespace()))
            .map_or(b.len(), |p| at + p);
        let tok = String::from_utf8_lossy(&b[at..end]).into_owned();
        if let Some(c) = tok.strip_prefix('#') {
            let mut w = c.split_whitespace();
            match (w.next(), w.next().and_then(|v| v.parse::<f64>().ok())) {
                (Some("Offset"), Some(v)) => offset = Some(v),
                (Some("Scale"), Some(v)) => scale = Some(v),
                _ => {}
            }
        } else {
            nums.push(
                tok.parse::<usize>().map_err(|_| {
                    Error::input(path, format!("PGM header: {tok:?} is not a size"))
                })?,
            );
        }
        at = end;
    }
    at += 1; // the single whitespace after the maximum value
    let (cols, rows, max) = (nums[0], nums[1], nums[2]);
    let (Some(offset), Some(scale)) = (offset, scale) else {
        return Err(Error::input(
            path,
            "a PGM without '# Offset' and '# Scale' lines is no GeographicLib geoid grid",
        ));
    };
    // A size of 0 needs no bytes, so it is refused here: the rows of a 0 × 4.4·10¹² header
    // were walked one by one (the release binary still ran after 60 s).
    let need = rows.checked_mul(cols).and_then(|n| n.checked_mul(2));
    if rows < 2 || cols < 2 {
        return Err(Error::input(
            path,
            format!("the PGM says {cols} × {rows} samples: a grid needs at least 2 × 2; give a whole GeographicLib geoid grid such as egm2008-2_5.pgm"),
        ));
    }
    if !(256..=65535).contains(&max) || need.is_none_or(|n| n > b.len().saturating_sub(at)) {
        return Err(Error::input(
            path,
            format!(
                "the PGM says {cols} × {rows} 16-bit samples but the file is shorter or not 16-bit"
            ),
        ));
    }
    let mut n = vec![0f32; rows * cols];
    for r in 0..rows {
        // File row 0 is the north pole; ours is the south.
        let dst = &mut n[(rows - 1 - r) * cols..(rows - r) * cols];
        for (c, v) in dst.iter_mut().enumerate() {
            let k = at + 2 * (r * cols + c);
            *v = (offset + scale * u16::from_be_bytes([b[k], b[k + 1]]) as f64) as f32;
        }
    }
    Ok(GeoidGrid {
        path: path.to_path_buf(),
        lat0: -90.0,
        lon0: 0.0,
        dlat: 180.0 / (rows - 1) as f64,
        dlon: 360.0 / cols as f64,
        rows,
        cols,
        n,
    })
}

/// PROJ's GTX: big-endian header and f32 samples from the south-west corner.
fn gtx(path: &Path, b: &[u8]) -> Result<GeoidGrid> {
    if b.len() < 40 {
        return Err(Error::input(path, "shorter than a GTX header (40 bytes)"));
    }
    let f = |k: usize| f64::from_be_bytes(b[k..k + 8].try_into().expect("8 bytes"));
    let i = |k: usize| i32::from_be_bytes(b[k..k + 4].try_into().expect("4 bytes"));
    let (rows, cols) = (i(32), i(36));
    let need = usize::try_from(rows)
        .ok()
        .zip(usize::try_from(cols).ok())
        .and_then(|(r, c)| r.checked_mul(c)?.checked_mul(4));
    if need.is_none_or(|n| 40 + n > b.len()) {
        return Err(Error::input(
            path,
            format!("the GTX header says {rows} × {cols} samples but the file is shorter"),
        ));
    }
    let n = b[40..40 + need.expect("checked")]
        .chunks_exact(4)
        .map(|c| {
            let v = f32::from_be_bytes(c.try_into().expect("4 bytes"));
            if (v + 88.8888).abs() < 1e-3 {
                f32::NAN
            } else {
                v
            }
        })
        .collect();
    Ok(GeoidGrid {
        path: path.to_path_buf(),
        lat0: f(0),
        lon0: f(8),
        dlat: f(16),
        dlon: f(24),
        rows: rows as usize,
        cols: cols as usize,
        n,
    })
}

/// The first value of a sorted, deduplicated `axis` that is not `axis[0]` plus a whole number
/// of `step`s, its index apart.
fn irregular(axis: &[f64], step: f64) -> Option<f64> {
    let tol = 1e-6 * step.abs().max(1e-9);
    axis.iter()
        .enumerate()
        .find(|&(i, &v)| (v - axis[0] - i as f64 * step).abs() > tol)
        .map(|(_, &v)| v)
}

/// The text layout: `LAT LON N` per line, a full regular grid.
fn text(path: &Path, b: &[u8]) -> Result<GeoidGrid> {
    let s = std::str::from_utf8(b)
        .map_err(|_| Error::input(path, "neither a PGM, a .gtx nor text (LAT LON N per line)"))?;
    let mut pts = Vec::new();
    for (k, line) in s.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let v: Vec<f64> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|t| !t.is_empty())
            .map(|t| t.parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| Error::parse(path, k + 1, "expected LAT LON N: three numbers"))?;
        if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
            return Err(Error::parse(
                path,
                k + 1,
                "expected LAT LON N: three numbers (degrees, degrees, metres)",
            ));
        }
        pts.push((k + 1, v[0], v[1], v[2]));
    }
    let axis = |sel: fn(&(usize, f64, f64, f64)) -> f64| {
        let mut a: Vec<f64> = pts.iter().map(sel).collect();
        a.sort_by(f64::total_cmp);
        a.dedup_by(|x, y| (*x - *y).abs() < 1e-9);
        a
    };
    let (lats, lons) = (axis(|p| p.1), axis(|p| p.2));
    if lats.len() < 2 || lons.len() < 2 {
        return Err(Error::input(
            path,
            "the grid needs at least 2 latitudes and 2 longitudes",
        ));
    }
    let (dlat, dlon) = (lats[1] - lats[0], lons[1] - lons[0]);
    for (axis, step, what) in [(&lats, dlat, "latitudes"), (&lons, dlon, "longitudes")] {
        if let Some(v) = irregular(axis, step) {
            return Err(Error::input(
                path,
                format!("the {what} are not evenly spaced ({v} is off the step of {step}° from {}): give a full regular grid", axis[0]),
            ));
        }
    }
    // Checked before allocating: a few diagonal lines must not ask for a grid of billions.
    if lats.len().checked_mul(lons.len()) != Some(pts.len()) {
        return Err(Error::input(
            path,
            format!(
                "{} latitudes × {} longitudes make {} nodes but the file gives {}: nodes are missing or given twice",
                lats.len(),
                lons.len(),
                lats.len().saturating_mul(lons.len()),
                pts.len()
            ),
        ));
    }
    let mut n = vec![f32::NAN; lats.len() * lons.len()];
    for &(line, lat, lon, v) in &pts {
        let (y, x) = ((lat - lats[0]) / dlat, (lon - lons[0]) / dlon);
        let off = |z: f64| (z - z.round()).abs() > 1e-6;
        if off(y) || off(x) {
            return Err(Error::parse(path, line, format!("{lat} {lon} is off the regular grid (steps {dlat}°, {dlon}° from the smallest values)")));
        }
        let (yi, xi) = (y.round() as usize, x.round() as usize);
        if yi >= lats.len() || xi >= lons.len() {
            return Err(Error::parse(
                path,
                line,
                format!("{lat} {lon} is off the grid"),
            ));
        }
        let at = yi * lons.len() + xi;
        if !n[at].is_nan() {
            return Err(Error::parse(
                path,
                line,
                format!("node {lat} {lon} given twice"),
            ));
        }
        n[at] = v as f32;
    }
    if let Some(k) = n.iter().position(|v| v.is_nan()) {
        let (lat, lon) = (
            lats[0] + (k / lons.len()) as f64 * dlat,
            lons[0] + (k % lons.len()) as f64 * dlon,
        );
        return Err(Error::input(
            path,
            format!("the node {lat} {lon} of the grid is missing: every node needs a value"),
        ));
    }
    Ok(GeoidGrid {
        path: path.to_path_buf(),
        lat0: lats[0],
        lon0: lons[0],
        dlat,
        dlon,
        rows: lats.len(),
        cols: lons.len(),
        n,
    })
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
