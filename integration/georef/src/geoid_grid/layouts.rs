//! The geoid grid layouts that say their own extent or have a fixed one: GeographicLib's PGM,
//! PROJ's GTX and the text layout (see the parent module for each).

use super::GeoidGrid;
use gnss::error::{Error, Result};
use std::path::Path;

/// GeographicLib's PGM: header tokens (comments hold Offset and Scale), then u16 samples.
pub(super) fn pgm(path: &Path, b: &[u8]) -> Result<GeoidGrid> {
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
    // File row 0 is the north pole.
    let step = (180.0 / (rows - 1) as f64, 360.0 / cols as f64);
    Ok(GeoidGrid::from_north_rows(
        path,
        (-90.0, 0.0),
        step,
        (rows, cols),
        |r, c| {
            let k = at + 2 * (r * cols + c);
            (offset + scale * u16::from_be_bytes([b[k], b[k + 1]]) as f64) as f32
        },
    ))
}

/// PROJ's GTX: big-endian header and f32 samples from the south-west corner.
pub(super) fn gtx(path: &Path, b: &[u8]) -> Result<GeoidGrid> {
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
        model: None,
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
pub(super) fn text(path: &Path, b: &[u8]) -> Result<GeoidGrid> {
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
        model: None,
    })
}
