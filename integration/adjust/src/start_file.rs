//! Start orientations given by the project (`[images] start = "start.csv"`): written by
//! `ppkat import` from another tool's orientations, used before any other start value.
//!
//! Table `image,lat,lon,h,omega,phi,kappa`: the projection centre (WGS84 degrees,
//! ellipsoidal height) and the rotation camera → local ENU at the centre as ω, φ, κ in degrees
//! with R = Rω·Rφ·Rκ — the attitude convention of the antenna table. Images not listed get
//! their start as usual; rows of images not in the image list are an error.

use super::error::AdjustError;
use super::frame::LocalFrame;
use super::input::{perr, ImageDef};
use gnss::frame::{Ecef, Geodetic};
use nalgebra::Matrix3;
use photo::camera::Pose;
use photo::rotation::Angles;
use std::collections::BTreeMap;
use std::path::Path;

/// A given start orientation: the centre and the rotation camera → ENU at the centre.
#[derive(Clone, Copy, Debug)]
pub struct StartPose {
    /// Projection centre.
    pub centre: Ecef,
    /// Rotation camera → local ENU at the centre.
    pub r_enu: Matrix3<f64>,
}

/// Read the start table: start poses by image index.
pub(super) fn read_starts(
    path: &Path,
    images: &[ImageDef],
) -> Result<BTreeMap<usize, StartPose>, AdjustError> {
    let text =
        std::fs::read_to_string(path).map_err(|e| perr(path, format!("cannot read: {e}")))?;
    let bad = |line: usize, what: String| AdjustError::Input {
        path: path.display().to_string(),
        line,
        what,
    };
    let mut rows = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let head: Vec<String> = match rows.next() {
        Some((_, h)) => h
            .split(',')
            .map(|c| c.trim().to_ascii_lowercase())
            .collect(),
        None => return Err(perr(path, "empty table: a header line is needed")),
    };
    let want = ["image", "lat", "lon", "h", "omega", "phi", "kappa"];
    let cols: Vec<usize> = want
        .iter()
        .map(|w| {
            head.iter()
                .position(|c| c == w)
                .ok_or_else(|| perr(path, format!("no `{w}` column (need {})", want.join(","))))
        })
        .collect::<Result<_, _>>()?;
    let mut out = BTreeMap::new();
    for (n, l) in rows {
        let f: Vec<&str> = l.split(',').map(str::trim).collect();
        let id = f.get(cols[0]).copied().unwrap_or("");
        let i = images.iter().position(|im| im.id == id).ok_or_else(|| {
            bad(
                n + 1,
                format!("image `{id}` is not in the image list: add it there or remove this row"),
            )
        })?;
        let mut v = [0.0; 6];
        for (k, c) in cols[1..].iter().enumerate() {
            let s = f.get(*c).copied().unwrap_or("");
            v[k] = s
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    bad(
                        n + 1,
                        format!("`{s}` is not a number (column {})", want[k + 1]),
                    )
                })?;
        }
        let r_enu = Angles::OmegaPhiKappa {
            omega: v[3].to_radians(),
            phi: v[4].to_radians(),
            kappa: v[5].to_radians(),
        }
        .matrix();
        let start = StartPose {
            centre: Geodetic::from_degrees(v[0], v[1], v[2]).to_ecef(),
            r_enu,
        };
        if out.insert(i, start).is_some() {
            return Err(bad(
                n + 1,
                format!("image {id} has two start rows: keep one"),
            ));
        }
    }
    Ok(out)
}

/// The given start pose of image `i` in the adjustment's frame, if any.
pub(super) fn given_start(
    starts: &BTreeMap<usize, StartPose>,
    frame: &LocalFrame,
    i: usize,
) -> Option<Pose> {
    starts.get(&i).map(|s| Pose {
        r: frame.from_enu_at(&s.centre) * s.r_enu,
        centre: frame.to_local(&s.centre),
    })
}
