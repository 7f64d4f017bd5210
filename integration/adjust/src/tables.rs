//! The tables a project names: image list, image measurements (CSV or PATB), ground points,
//! GNSS antenna table — or the antennas interpolated on a trajectory. Each problem names the
//! file and the line.

use super::error::AdjustError;
use super::input::{
    perr, Antenna, CameraDef, ControlAxes, GroundPoint, ImageDef, MeasuredDistance, Measurement,
    PointKind,
};
use exposure::export::Projection;
use gnss::frame::{Ecef, Geodetic};
use gnss::trajectory::{InterpError, Trajectory};
use nalgebra::{Matrix3, Vector2, Vector3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A CSV table: header names, then rows with their line numbers (comments `#` skipped).
struct Table {
    path: PathBuf,
    cols: Vec<String>,
    rows: Vec<(usize, Vec<String>)>,
}

impl Table {
    fn read(path: &Path) -> Result<Table, AdjustError> {
        let text =
            std::fs::read_to_string(path).map_err(|e| perr(path, format!("cannot read: {e}")))?;
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let (_, head) = lines
            .next()
            .ok_or_else(|| perr(path, "empty table: a header line is needed"))?;
        let cols = head
            .split(',')
            .map(|c| c.trim().trim_start_matches('#').to_ascii_lowercase())
            .collect();
        let rows = lines.map(|(i, l)| (i + 1, split_csv(l))).collect();
        Ok(Table {
            path: path.to_path_buf(),
            cols,
            rows,
        })
    }
    fn col(&self, name: &str) -> Option<usize> {
        self.cols.iter().position(|c| c == name)
    }
    fn need(&self, name: &str) -> Result<usize, AdjustError> {
        self.col(name).ok_or_else(|| {
            perr(
                &self.path,
                format!("no `{name}` column (header: {})", self.cols.join(",")),
            )
        })
    }
    fn num(&self, line: usize, row: &[String], c: usize) -> Result<f64, AdjustError> {
        let s = row.get(c).map(|s| s.trim()).unwrap_or("");
        s.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| AdjustError::Input {
                path: self.path.display().to_string(),
                line,
                what: format!("`{s}` is not a number (column {})", self.cols[c]),
            })
    }
    /// A whole number from 0 to `max` (an index or a code: `as` would wrap or saturate).
    fn whole(&self, line: usize, row: &[String], c: usize, max: f64) -> Result<f64, AdjustError> {
        let v = self.num(line, row, c)?;
        if v < 0.0 || v > max || v.fract() != 0.0 {
            return Err(AdjustError::Input {
                path: self.path.display().to_string(),
                line,
                what: format!(
                    "{v} in column {} is not a whole number from 0 to {max}",
                    self.cols[c]
                ),
            });
        }
        Ok(v)
    }
    fn text(&self, row: &[String], c: usize) -> String {
        row.get(c).map(|s| s.trim().to_string()).unwrap_or_default()
    }
}

fn split_csv(l: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    for ch in l.chars() {
        match ch {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cur)),
            c => cur.push(c),
        }
    }
    out.push(cur);
    out
}

pub(super) fn read_images(
    path: &Path,
    cameras: &[CameraDef],
) -> Result<Vec<ImageDef>, AdjustError> {
    let t = Table::read(path)?;
    let ci = t.need("image")?;
    let cc = t.col("camera");
    let cs = t.col("strip");
    let three = |a: &str, b: &str, c: &str| match (t.col(a), t.col(b), t.col(c)) {
        (Some(a), Some(e), Some(r)) => Some([a, e, r]),
        _ => None,
    };
    let (compass, opk) = (
        three("azimuth", "elevation", "roll"),
        three("omega", "phi", "kappa"),
    );
    let times = t.col("week").zip(t.col("tow"));
    let mut out: Vec<ImageDef> = Vec::new();
    let mut ids = std::collections::HashSet::new();
    for (line, row) in &t.rows {
        let id = t.text(row, ci);
        let camera = match cc {
            Some(c) => {
                let name = t.text(row, c);
                cameras
                    .iter()
                    .position(|x| x.id == name)
                    .ok_or_else(|| AdjustError::Input {
                        path: path.display().to_string(),
                        line: *line,
                        what: format!("image {id}: unknown camera `{name}`"),
                    })?
            }
            None if cameras.len() == 1 => 0,
            None => return Err(perr(path, "several cameras: a `camera` column is needed")),
        };
        if !ids.insert(id.clone()) {
            return Err(AdjustError::Input {
                path: path.display().to_string(),
                line: *line,
                what: format!("image {id} listed twice"),
            });
        }
        let angles = |c: Option<[usize; 3]>| -> Result<Option<[f64; 3]>, AdjustError> {
            match c {
                Some(c) => Ok(Some([
                    t.num(*line, row, c[0])?.to_radians(),
                    t.num(*line, row, c[1])?.to_radians(),
                    t.num(*line, row, c[2])?.to_radians(),
                ])),
                None => Ok(None),
            }
        };
        let (compass, opk) = (angles(compass)?, angles(opk)?);
        let time = match times {
            // Both cells empty: this image's time is unknown.
            Some((w, s)) if t.text(row, w).is_empty() && t.text(row, s).is_empty() => None,
            Some((w, s)) => {
                let week = t.num(*line, row, w)?;
                let tow = t.num(*line, row, s)?;
                Some(gnss::time::checked_week_tow(week, tow).map_err(|what| {
                    AdjustError::Input {
                        path: path.display().to_string(),
                        line: *line,
                        what,
                    }
                })?)
            }
            None => None,
        };
        out.push(ImageDef {
            id,
            camera,
            strip: cs.map(|c| t.text(row, c)).unwrap_or_else(|| "1".into()),
            compass,
            opk,
            time,
        });
    }
    if out.is_empty() {
        return Err(perr(path, "no images listed"));
    }
    Ok(out)
}

pub(super) fn read_measurements(
    path: &Path,
    index: &BTreeMap<&str, usize>,
    images: &[ImageDef],
    cameras: &[CameraDef],
) -> Result<Vec<Measurement>, AdjustError> {
    let t = Table::read(path)?;
    let (ci, cp, cx, cy) = (
        t.need("image")?,
        t.need("point")?,
        t.need("x_px")?,
        t.need("y_px")?,
    );
    let cs = t.col("sigma_px");
    let mut out = Vec::new();
    let mut seen: BTreeMap<(usize, String), usize> = BTreeMap::new();
    let bad = |line: usize, what: String| AdjustError::Input {
        path: path.display().to_string(),
        line,
        what,
    };
    for (line, row) in &t.rows {
        let im = t.text(row, ci);
        let &i = index
            .get(im.as_str())
            .ok_or_else(|| bad(*line, format!("image `{im}` is not in the image list")))?;
        let point = t.text(row, cp);
        if let Some(first) = seen.insert((i, point.clone()), *line) {
            return Err(bad(
                *line,
                format!("point `{point}` is measured twice in image `{im}` (lines {first} and {line}): keep one measurement"),
            ));
        }
        let cam = &cameras[images[i].camera];
        let px = Vector2::new(t.num(*line, row, cx)?, t.num(*line, row, cy)?);
        // A margin of 2 % of the frame: measurements at the edge pass, those of an image of
        // another size (half, double) do not.
        let (w, h) = (cam.camera.width_px as f64, cam.camera.height_px as f64);
        let m = 0.02 * w.max(h);
        if !(-m..=w + m).contains(&px.x) || !(-m..=h + m).contains(&px.y) {
            return Err(bad(
                *line,
                format!(
                    "point `{point}` in image `{im}` at ({:.1}, {:.1}) px lies outside the {w}×{h} px frame of camera `{}`: is the calibration for another image size (or are the measurements in another unit)?",
                    px.x, px.y, cameras[images[i].camera].id
                ),
            ));
        }
        let sigma_px = match cs {
            Some(c) if !t.text(row, c).is_empty() => t.num(*line, row, c)?,
            _ => cam.sigma_px,
        };
        if sigma_px.is_nan() || sigma_px <= 0.0 {
            return Err(bad(
                *line,
                format!("sigma_px {sigma_px} of point `{point}` in image `{im}`: a σ must be positive (pixels)"),
            ));
        }
        out.push(Measurement {
            image: i,
            point,
            xy: cam.camera.pixel_to_image(px),
            sigma: sigma_px * cam.camera.pixel,
            source: format!("{}:{line}", path.display()),
        });
    }
    Ok(out)
}

/// PATB-style image coordinates: a line with the photo id, then `point x y` in millimetres
/// (x right, y up, from the principal point's origin), closed by `-99`.
pub(super) fn read_patb(
    path: &Path,
    index: &BTreeMap<&str, usize>,
    images: &[ImageDef],
    cameras: &[CameraDef],
) -> Result<Vec<Measurement>, AdjustError> {
    let text =
        std::fs::read_to_string(path).map_err(|e| perr(path, format!("cannot read: {e}")))?;
    let bad = |line: usize, what: String| AdjustError::Input {
        path: path.display().to_string(),
        line,
        what,
    };
    let mut out = Vec::new();
    let mut current: Option<usize> = None;
    for (n, l) in text.lines().enumerate() {
        let line = n + 1;
        let f: Vec<&str> = l.split_whitespace().collect();
        match (current, f.as_slice()) {
            (_, []) => {}
            (_, ["-99", ..]) => current = None,
            (None, [id, ..]) => {
                current =
                    Some(*index.get(id).ok_or_else(|| {
                        bad(line, format!("photo `{id}` is not in the image list"))
                    })?)
            }
            (Some(i), [p, x, y, ..]) => {
                let num = |s: &str| {
                    s.parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| bad(line, format!("`{s}` is not a number")))
                };
                let cam = &cameras[images[i].camera];
                out.push(Measurement {
                    image: i,
                    point: p.to_string(),
                    xy: Vector2::new(num(x)? * 1e-3, num(y)? * 1e-3),
                    sigma: cam.sigma_px * cam.camera.pixel,
                    source: format!("{}:{line}", path.display()),
                });
            }
            (Some(_), _) => {
                return Err(bad(line, "expected `point x y` (mm) or -99".into()));
            }
        }
    }
    Ok(out)
}

/// Measured distances: `point_a, point_b, distance[, sigma]` (metres; σ 1 cm when not given).
pub(super) fn read_distances(path: &Path) -> Result<Vec<MeasuredDistance>, AdjustError> {
    let t = Table::read(path)?;
    let (ca, cb, cd) = (t.need("point_a")?, t.need("point_b")?, t.need("distance")?);
    let cs = t.col("sigma");
    let mut out = Vec::new();
    for (line, row) in &t.rows {
        let points = [t.text(row, ca), t.text(row, cb)];
        let distance = t.num(*line, row, cd)?;
        let sigma = match cs {
            Some(c) if !t.text(row, c).is_empty() => t.num(*line, row, c)?,
            _ => 0.01,
        };
        if !(distance > 0.0 && sigma > 0.0) || points[0] == points[1] {
            return Err(AdjustError::Input {
                path: path.display().to_string(),
                line: *line,
                what: "a distance needs two different points, a positive distance and a positive σ"
                    .into(),
            });
        }
        out.push(MeasuredDistance {
            points,
            distance,
            sigma,
            source: format!("{}:{line}", path.display()),
        });
    }
    Ok(out)
}

/// Which columns hold a ground point's coordinates.
enum Coords {
    Geo(usize, usize, usize),
    Xyz(usize, usize, usize),
    Proj(usize, usize, usize),
}

impl Coords {
    /// The coordinate columns of a ground-point table.
    fn of(t: &Table) -> Result<Coords, AdjustError> {
        let lat = t.col("lat").or(t.col("lat_deg"));
        let lon = t.col("lon").or(t.col("lon_deg"));
        if let (Some(a), Some(b), Some(c)) = (lat, lon, t.col("h")) {
            Ok(Coords::Geo(a, b, c))
        } else if let (Some(a), Some(b), Some(c)) = (t.col("x"), t.col("y"), t.col("z")) {
            Ok(Coords::Xyz(a, b, c))
        } else if let (Some(a), Some(b), Some(c)) =
            (t.col("easting"), t.col("northing"), t.col("h"))
        {
            Ok(Coords::Proj(a, b, c))
        } else {
            Err(perr(&t.path, "coordinates: give lat,lon,h or x,y,z (ECEF) or easting,northing,h (with crs in [ground])"))
        }
    }

    /// The projection of easting/northing columns (`None` for the others).
    fn projection(
        &self,
        path: &Path,
        crs: Option<&str>,
    ) -> Result<Option<(common::tmerc::TransverseMercator, String)>, AdjustError> {
        match (self, crs) {
            (Coords::Proj(..), Some(c)) => {
                let p = Projection::parse(c)
                    .ok_or_else(|| perr(path, format!("crs `{c}`: use utm:ZONE or gk:CM")))?;
                match p {
                    Projection::Utm(None) | Projection::Geodetic | Projection::Epsg(_) => {
                        Err(perr(path, "crs: give the UTM zone (utm:ZONE) or gk:CM"))
                    }
                    _ => {
                        let lat = if c.ends_with(['S', 's']) { -1.0 } else { 1.0 };
                        Ok(p.mercator(&Geodetic::from_degrees(lat, 0.0, 0.0)))
                    }
                }
            }
            (Coords::Proj(..), None) => Err(perr(
                path,
                "easting/northing columns need `crs` in [ground]",
            )),
            _ => Ok(None),
        }
    }

    /// The position of one row.
    fn position(
        &self,
        t: &Table,
        line: usize,
        row: &[String],
        tm: Option<&common::tmerc::TransverseMercator>,
    ) -> Result<Ecef, AdjustError> {
        let n = |c: usize| t.num(line, row, c);
        Ok(match *self {
            Coords::Geo(a, b, c) => Geodetic::from_degrees(n(a)?, n(b)?, n(c)?).to_ecef(),
            Coords::Xyz(a, b, c) => Ecef::new(n(a)?, n(b)?, n(c)?),
            Coords::Proj(a, b, c) => {
                let tm = tm.ok_or_else(|| perr(&t.path, "crs missing"))?;
                let p = common::tmerc::Projected {
                    easting: n(a)?,
                    northing: n(b)?,
                };
                tm.inverse(&p, n(c)?).to_ecef()
            }
        })
    }
}

/// σ east, north, up of a ground-point row: `sigma_xy, sigma_z`, or `sigma_e, sigma_n,
/// sigma_u`, or 2/2/3 cm.
fn ground_sigma(t: &Table, row: &[String], line: usize) -> Result<[f64; 3], AdjustError> {
    if let (Some(a), Some(b)) = (t.col("sigma_xy"), t.col("sigma_z")) {
        let (h, v) = (t.num(line, row, a)?, t.num(line, row, b)?);
        return Ok([h, h, v]);
    }
    if let (Some(a), Some(b), Some(c)) = (t.col("sigma_e"), t.col("sigma_n"), t.col("sigma_u")) {
        return Ok([
            t.num(line, row, a)?,
            t.num(line, row, b)?,
            t.num(line, row, c)?,
        ]);
    }
    Ok([0.02, 0.02, 0.03])
}

/// Ground points: `point, kind (gcp|check|tie)`, coordinates as lat/lon/h, ECEF x/y/z or
/// easting/northing/h in `crs`, optional σ. Tie rows are skipped; control points named in
/// `as_check` become check points.
pub(super) fn read_ground(
    path: &Path,
    crs: Option<&str>,
    as_check: &[String],
) -> Result<Vec<GroundPoint>, AdjustError> {
    let t = Table::read(path)?;
    let (cp, ck) = (t.need("point")?, t.need("kind")?);
    let coords = Coords::of(&t)?;
    let tm = coords.projection(path, crs)?;
    let bad = |line: usize, what: String| AdjustError::Input {
        path: path.display().to_string(),
        line,
        what,
    };
    let mut out = Vec::new();
    let mut ids = std::collections::HashSet::new();
    for (line, row) in &t.rows {
        let id = t.text(row, cp);
        let kind_text = t.text(row, ck).to_ascii_lowercase().replace('_', "-");
        let (kind, axes) = match kind_text.as_str() {
            "gcp" | "control" | "gcp-xy" | "gcp-z" if as_check.contains(&id) => {
                (PointKind::Check, ControlAxes::All)
            }
            "gcp" | "control" | "gcp-xyz" => (PointKind::Control, ControlAxes::All),
            "gcp-xy" => (PointKind::Control, ControlAxes::Horizontal),
            "gcp-z" | "gcp-h" => (PointKind::Control, ControlAxes::Height),
            "check" => (PointKind::Check, ControlAxes::All),
            "tie" => continue,
            k => {
                let what =
                    format!("point {id}: kind `{k}`: use gcp, gcp-xy (planimetric), gcp-z (height), check or tie");
                return Err(bad(*line, what));
            }
        };
        let pos = coords.position(&t, *line, row, tm.as_ref().map(|x| &x.0))?;
        let sigma = ground_sigma(&t, row, *line)?;
        if sigma.iter().any(|s| s.is_nan() || *s <= 0.0) && kind == PointKind::Control {
            return Err(bad(
                *line,
                format!("control point {id}: σ must be positive"),
            ));
        }
        if !ids.insert(id.clone()) {
            return Err(bad(*line, format!("point {id} listed twice")));
        }
        out.push(GroundPoint {
            id,
            kind,
            pos,
            sigma,
            axes,
            source: format!("{}:{line}", path.display()),
        });
    }
    Ok(out)
}

pub(super) fn read_antennas(path: &Path, scale: f64) -> Result<Vec<Antenna>, AdjustError> {
    let t = Table::read(path)?;
    let need: Vec<usize> = [
        "id", "week", "tow", "lat", "lon", "h", "c_ee", "c_en", "c_eu", "c_nn", "c_nu", "c_uu",
    ]
    .iter()
    .map(|c| t.need(c))
    .collect::<Result<_, _>>()?;
    let seg = t.col("segment");
    let qcol = t.col("quality");
    let opk = match (t.col("omega"), t.col("phi"), t.col("kappa")) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    let vel = velocity_columns(&t, path)?;
    let sd = attitude_sigma_columns(&t, path, opk.is_some())?;
    let mut out = Vec::new();
    for (line, row) in &t.rows {
        let v: Vec<f64> = need[1..]
            .iter()
            .map(|&c| t.num(*line, row, c))
            .collect::<Result<_, _>>()?;
        let cov =
            Matrix3::new(v[5], v[6], v[7], v[6], v[8], v[9], v[7], v[9], v[10]) * (scale * scale);
        if cov.cholesky().is_none() {
            return Err(AdjustError::Input {
                path: path.display().to_string(),
                line: *line,
                what: "the covariance is not positive definite".into(),
            });
        }
        let rotation = match opk {
            Some(c) => Some(
                photo::rotation::Angles::OmegaPhiKappa {
                    omega: t.num(*line, row, c[0])?.to_radians(),
                    phi: t.num(*line, row, c[1])?.to_radians(),
                    kappa: t.num(*line, row, c[2])?.to_radians(),
                }
                .matrix(),
            ),
            None => None,
        };
        let time = gnss::time::checked_week_tow(v[0], v[1]).map_err(|what| AdjustError::Input {
            path: path.display().to_string(),
            line: *line,
            what,
        })?;
        out.push(Antenna {
            image: t.text(row, need[0]),
            time,
            pos: Geodetic::from_degrees(v[2], v[3], v[4]).to_ecef(),
            cov_enu: cov,
            segment: match seg {
                Some(c) => t.whole(*line, row, c, u32::MAX as f64)? as u32,
                None => 0,
            },
            quality: match qcol {
                Some(c) => t.whole(*line, row, c, 255.0)? as u8,
                None => 1,
            },
            rotation,
            rotation_sigma: match sd {
                Some(c) => {
                    let mut s = Vector3::zeros();
                    for (k, &ci) in c.iter().enumerate() {
                        let v = t.num(*line, row, ci)?;
                        if v <= 0.0 {
                            return Err(AdjustError::Input {
                                path: path.display().to_string(),
                                line: *line,
                                what: format!(
                                    "{v} in column {}: a σ must be positive (degrees)",
                                    t.cols[ci]
                                ),
                            });
                        }
                        s[k] = v.to_radians();
                    }
                    Some(s)
                }
                None => None,
            },
            vel_enu: match vel {
                Some(c) => Some(Vector3::new(
                    t.num(*line, row, c[0])?,
                    t.num(*line, row, c[1])?,
                    t.num(*line, row, c[2])?,
                )),
                None => None,
            },
        });
    }
    Ok(out)
}

/// The velocity columns `ve,vn,vu` of an antenna table: all three or none.
fn velocity_columns(t: &Table, path: &Path) -> Result<Option<[usize; 3]>, AdjustError> {
    match (t.col("ve"), t.col("vn"), t.col("vu")) {
        (Some(a), Some(b), Some(c)) => Ok(Some([a, b, c])),
        (None, None, None) => Ok(None),
        _ => Err(perr(
            path,
            "the velocity needs all three columns `ve,vn,vu` (m/s, ENU at the antenna): add the missing ones or remove the others",
        )),
    }
}

/// The attitude σ columns `sd_omega,sd_phi,sd_kappa` (degrees) of an antenna table: all
/// three or none, and only beside `omega,phi,kappa`.
fn attitude_sigma_columns(
    t: &Table,
    path: &Path,
    has_attitude: bool,
) -> Result<Option<[usize; 3]>, AdjustError> {
    let cols = match (t.col("sd_omega"), t.col("sd_phi"), t.col("sd_kappa")) {
        (Some(a), Some(b), Some(c)) => [a, b, c],
        (None, None, None) => return Ok(None),
        _ => {
            return Err(perr(
                path,
                "the attitude σ needs all three columns `sd_omega,sd_phi,sd_kappa` (degrees): add the missing ones or remove the others",
            ))
        }
    };
    if !has_attitude {
        return Err(perr(
            path,
            "`sd_omega,sd_phi,sd_kappa` are the σ of an attitude, but the table has no `omega,phi,kappa` columns: add them or remove the σ",
        ));
    }
    Ok(Some(cols))
}

/// Read the `.pos` trajectory a project names (segments derived from its Q changes and gaps).
pub(super) fn read_trajectory(path: &Path) -> Result<Trajectory, AdjustError> {
    Trajectory::read_pos(path).map_err(|e| perr(path, e.to_string()))
}

/// Antenna positions interpolated on a trajectory (read from `path`) at the image times:
/// covariance and ambiguity segment from the trajectory; images outside it or in its gaps are
/// listed, and so is where its segments came from when not from the filter.
pub(super) fn antennas_from_trajectory(
    traj: &Trajectory,
    path: &Path,
    images: &[ImageDef],
    scale: f64,
    warnings: &mut Vec<String>,
) -> Result<Vec<Antenna>, AdjustError> {
    if images.iter().all(|im| im.time.is_none()) {
        return Err(perr(
            path,
            "a trajectory needs the image times: add `week,tow` (GPST) columns to the image list",
        ));
    }
    warnings.extend(traj.segments_from.note());
    let max_gap = 2.5 * traj.interval;
    let mut out = Vec::new();
    let mut missed = Vec::new();
    for im in images {
        let Some(t) = im.time else {
            missed.push(format!("{} (no time)", im.id));
            continue;
        };
        match traj.interpolate(t, max_gap) {
            Ok(ip) => {
                let r = gnss::frame::enu_rotation(&ip.pos.to_geodetic());
                out.push(Antenna {
                    image: im.id.clone(),
                    time: t,
                    pos: ip.pos,
                    cov_enu: r * ip.cov * r.transpose() * (scale * scale),
                    segment: ip.segment,
                    quality: ip.quality as u8,
                    rotation: None,
                    rotation_sigma: None,
                    vel_enu: Some(r * ip.vel),
                });
            }
            Err(InterpError::Outside) => missed.push(format!("{} (outside the trajectory)", im.id)),
            Err(InterpError::Gap(g)) => missed.push(format!("{} (in a {g:.1} s gap)", im.id)),
        }
    }
    if !missed.is_empty() {
        warnings.push(format!(
            "{} image(s) without a GNSS position from {}: {}",
            missed.len(),
            path.display(),
            missed.join(", ")
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
