//! Exposure positions from a ppkat table (`exposures` CSV, or an antenna table such as the
//! simulator's `antennas.csv`): a header naming `id` (or `name`, `image`, `label`), `lat`,
//! `lon`, `h` and, when present, σ as `sigma_e`/`sigma_n`/`sigma_u` (m) or variances
//! `c_ee`/`c_nn`/`c_uu` (m²). `#` lines are comments. They take precedence over EXIF.

use std::collections::BTreeMap;
use std::path::Path;

/// An exposure position: latitude, longitude (degrees), ellipsoidal height (m), σ E/N/U (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position {
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Height, m.
    pub h: f64,
    /// σ east, north, up (m), when the table gives them.
    pub sigma: Option<[f64; 3]>,
}

/// The positions of a table by id; errors name the file, line and column.
pub fn read(path: &Path) -> Result<BTreeMap<String, Position>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim_start().starts_with('#') && !l.trim().is_empty());
    let Some((_, head)) = lines.next() else {
        return Err(format!("{}: no header line", path.display()));
    };
    let cols: Vec<String> = head.split(',').map(|c| c.trim().to_lowercase()).collect();
    let col = |names: &[&str]| names.iter().find_map(|n| cols.iter().position(|c| c == n));
    let (Some(id), Some(lat), Some(lon), Some(h)) = (
        col(&["id", "name", "image", "label"]),
        col(&["lat"]),
        col(&["lon"]),
        col(&["h", "height"]),
    ) else {
        return Err(format!(
            "{}: the header must name id (or name/image/label), lat, lon and h",
            path.display()
        ));
    };
    let sd = [col(&["sigma_e"]), col(&["sigma_n"]), col(&["sigma_u"])];
    let var = [col(&["c_ee"]), col(&["c_nn"]), col(&["c_uu"])];
    let mut out = BTreeMap::new();
    for (n, l) in lines {
        let f: Vec<&str> = l.split(',').map(str::trim).collect();
        let num = |k: usize| -> Result<f64, String> {
            f.get(k)
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "{}:{}: column {} (`{}`) is not a finite number",
                        path.display(),
                        n + 1,
                        k + 1,
                        f.get(k).unwrap_or(&"")
                    )
                })
        };
        let name = f.get(id).copied().unwrap_or("").to_string();
        let three = |c: [Option<usize>; 3], sq: bool| -> Result<Option<[f64; 3]>, String> {
            let (Some(a), Some(b), Some(d)) = (c[0], c[1], c[2]) else {
                return Ok(None);
            };
            let v = [num(a)?, num(b)?, num(d)?];
            Ok(Some(if sq { v.map(|x| x.max(0.0).sqrt()) } else { v }))
        };
        let sigma = match three(sd, false)? {
            Some(s) => Some(s),
            None => three(var, true)?,
        };
        let p = Position {
            lat: num(lat)?,
            lon: num(lon)?,
            h: num(h)?,
            sigma,
        };
        if p.lat.abs() > 90.0 || p.lon.abs() > 360.0 {
            return Err(format!(
                "{}:{}: latitude/longitude out of range",
                path.display(),
                n + 1
            ));
        }
        if out.insert(name.clone(), p).is_some() {
            return Err(format!(
                "{}:{}: `{name}` is listed twice: keep one",
                path.display(),
                n + 1
            ));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn antenna_and_exposure_tables_are_read() {
        let dir = testkit::scratch_dir("positions");
        let a = dir.join("antennas.csv");
        std::fs::write(&a, "# x\nid,week,tow,lat,lon,h,c_ee,c_en,c_eu,c_nn,c_nu,c_uu\nI1,0,0,47.1,8.2,500.5,4e-4,0,0,9e-4,0,0.0016\n").unwrap();
        let p = read(&a).unwrap();
        let s = p["I1"].sigma.unwrap();
        assert!((s[0] - 0.02).abs() < 1e-12 && (s[2] - 0.04).abs() < 1e-12);
        let e = dir.join("e.csv");
        std::fs::write(
            &e,
            "id,week,tow,lat,lon,h,sigma_e,sigma_n,sigma_u\nDJI_0001,1,2,47,8,x,1,1,1\n",
        )
        .unwrap();
        let err = read(&e).unwrap_err();
        assert!(err.contains("e.csv:2: column 6 (`x`)"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
