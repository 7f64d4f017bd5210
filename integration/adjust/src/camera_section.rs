//! The `[[camera]]` section of a project: focal length and principal point in millimetres
//! (with the pixel size) or in pixels, a distortion centre apart from the principal point,
//! Brown k1–k3, p1 p2 and affinity b1 b2, each free or fixed on its own.
//!
//! Millimetre positions (`principal_point_mm`, `distortion_centre_mm`) are offsets from the
//! image centre with x right and y up; pixel positions (`principal_point_px`,
//! `distortion_centre_px`) are (column, row) from the top-left corner, as image measurements.
//! Distortion coefficients act on image coordinates in metres (see `photo::camera`).

use super::error::AdjustError;
use super::input::{perr, CameraDef};
use nalgebra::Vector2;
use photo::camera::Camera;
use serde::Deserialize;
use std::path::Path;

/// A `[[camera]]` section.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    /// The id the image list refers to.
    pub id: String,
    /// Principal distance, mm (or `focal_px`).
    #[serde(default)]
    pub focal_mm: Option<f64>,
    /// Principal distance, pixels (or `focal_mm`).
    #[serde(default)]
    pub focal_px: Option<f64>,
    /// Pixel size, µm.
    pub pixel_um: f64,
    /// Image width, pixels.
    pub width_px: usize,
    /// Image height, pixels.
    pub height_px: usize,
    /// Principal point x0, y0, mm from the image centre (x right, y up); default 0, 0.
    #[serde(default)]
    pub principal_point_mm: Option<[f64; 2]>,
    /// Principal point as a pixel position (column, row from the top-left corner).
    #[serde(default)]
    pub principal_point_px: Option<[f64; 2]>,
    /// Distortion centre, mm from the image centre (x right, y up); default: the principal
    /// point.
    #[serde(default)]
    pub distortion_centre_mm: Option<[f64; 2]>,
    /// Distortion centre as a pixel position (column, row).
    #[serde(default)]
    pub distortion_centre_px: Option<[f64; 2]>,
    /// Radial k1, k2, k3 (image coordinates in metres).
    #[serde(default)]
    pub k: [f64; 3],
    /// Decentring p1, p2.
    #[serde(default)]
    pub p: [f64; 2],
    /// Affinity b1 (scale of x) and shear b2.
    #[serde(default)]
    pub b: [f64; 2],
    /// Image measurement σ, pixels (default 0.5).
    #[serde(default = "default_sigma_px")]
    pub sigma_px: f64,
    /// Interior parameters to estimate: f, x0, y0, k1, k2, k3, p1, p2, b1, b2, or `all`.
    #[serde(default)]
    pub self_calibrate: Vec<String>,
    /// Interior parameters held fixed even when `self_calibrate` names them (e.g. with `all`).
    #[serde(default)]
    pub fixed: Vec<String>,
}

fn default_sigma_px() -> f64 {
    0.5
}

/// Names of the interior parameters in `photo::camera`'s order.
pub const INTERIOR_NAMES: [&str; 10] = ["f", "x0", "y0", "k1", "k2", "k3", "p1", "p2", "b1", "b2"];

/// One of two exclusive keys (mm or px) of a camera.
fn one_of<T: Copy>(
    path: &Path,
    id: &str,
    keys: [&str; 2],
    a: Option<T>,
    b: Option<T>,
) -> Result<Option<Result<T, T>>, AdjustError> {
    match (a, b) {
        (Some(_), Some(_)) => Err(perr(
            path,
            format!("camera {id}: give `{}` or `{}`, not both", keys[0], keys[1]),
        )),
        (Some(x), None) => Ok(Some(Ok(x))),
        (None, Some(y)) => Ok(Some(Err(y))),
        (None, None) => Ok(None),
    }
}

/// The indices of the parameters named (`all` for every one).
fn interior_indices(
    path: &Path,
    id: &str,
    key: &str,
    names: &[String],
) -> Result<Vec<usize>, AdjustError> {
    let mut out = Vec::new();
    for n in names {
        if n == "all" {
            out.extend(0..INTERIOR_NAMES.len());
            continue;
        }
        let i = INTERIOR_NAMES.iter().position(|x| x == n).ok_or_else(|| {
            perr(
                path,
                format!(
                    "camera {id}: {key} `{n}`: use all, {}",
                    INTERIOR_NAMES.join(", ")
                ),
            )
        })?;
        out.push(i);
    }
    out.sort();
    out.dedup();
    Ok(out)
}

/// A camera section as a camera with its estimation choices; `path` (the file the section
/// came from) names it in errors. Also used by `formats::import::patb` for `--camera FILE.toml`.
pub fn camera_def(c: &CameraSection, path: &Path) -> Result<CameraDef, AdjustError> {
    let focal = one_of(
        path,
        &c.id,
        ["focal_mm", "focal_px"],
        c.focal_mm,
        c.focal_px,
    )?;
    let f = match focal {
        Some(Ok(mm)) => mm * 1e-3,
        Some(Err(px)) => px * c.pixel_um * 1e-6,
        None => {
            return Err(perr(
                path,
                format!("camera {}: give `focal_mm` or `focal_px`", c.id),
            ));
        }
    };
    if !(f > 0.0 && c.pixel_um > 0.0 && c.width_px > 0 && c.height_px > 0 && c.sigma_px > 0.0) {
        return Err(perr(
            path,
            format!(
                "camera {}: the focal length, pixel_um, width_px, height_px and sigma_px must be positive",
                c.id
            ),
        ));
    }
    let mut cam = Camera::ideal(f, c.pixel_um * 1e-6, c.width_px, c.height_px);
    let position = |v: Option<Result<[f64; 2], [f64; 2]>>| {
        v.map(|v| match v {
            Ok(mm) => Vector2::new(mm[0], mm[1]) * 1e-3,
            Err(px) => cam.pixel_to_image(Vector2::new(px[0], px[1])),
        })
    };
    let pp = position(one_of(
        path,
        &c.id,
        ["principal_point_mm", "principal_point_px"],
        c.principal_point_mm,
        c.principal_point_px,
    )?)
    .unwrap_or_else(Vector2::zeros);
    let dc = position(one_of(
        path,
        &c.id,
        ["distortion_centre_mm", "distortion_centre_px"],
        c.distortion_centre_mm,
        c.distortion_centre_px,
    )?)
    .unwrap_or(pp);
    let values = [pp.x, pp.y, dc.x, dc.y]
        .into_iter()
        .chain(c.k)
        .chain(c.p)
        .chain(c.b);
    if values.clone().any(|v| !v.is_finite()) {
        return Err(perr(
            path,
            format!("camera {}: every value must be a finite number", c.id),
        ));
    }
    cam.x0 = pp.x;
    cam.y0 = pp.y;
    cam.dc = [dc.x - pp.x, dc.y - pp.y];
    cam.k = c.k;
    cam.p = c.p;
    cam.b = c.b;
    let fixed = interior_indices(path, &c.id, "fixed", &c.fixed)?;
    let calibrate = interior_indices(path, &c.id, "self_calibrate", &c.self_calibrate)?
        .into_iter()
        .filter(|i| !fixed.contains(i))
        .collect();
    Ok(CameraDef {
        id: c.id.clone(),
        camera: cam,
        calibrate,
        sigma_px: c.sigma_px,
    })
}
