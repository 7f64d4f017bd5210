//! The ground points of a simulated adjustment project (the aerial block and the close-range
//! pair): their record, ENU → geodetic, and `ground_points.csv` with noisy control.
//!
//! What enters: points in the ENU frame at a geodetic origin (metres), the control σ and a
//! random stream. What leaves: the file, and the id of the control point given a wrong
//! coordinate.

use super::error::SimError;
use super::io::write;
use super::rng::Rng;
use gnss::frame::{Enu, Geodetic};
use nalgebra::Vector3;
use std::fmt::Write as _;
use std::path::Path;

/// A ground point: id, kind (`gcp`, `check` or `tie`), ENU at the origin.
pub(super) type Point = (String, &'static str, Vector3<f64>);

/// Geodetic coordinates of a point of the ENU frame at `origin`.
pub(super) fn geodetic(origin: &Geodetic, v: &Vector3<f64>) -> Geodetic {
    Enu(*v).to_ecef(&origin.to_ecef()).to_geodetic()
}

/// Write `ground_points.csv` (point, kind, lat, lon in degrees, h and sigmas in metres) for
/// the control and check points given (ENU at `origin`). Control and check points are
/// observed with noise of σ = (σ_xy, σ_xy, σ_z) = `sigma` per ENU axis drawn from `rng`; the
/// first control point also carries the `wrong` shift (E, N, U, metres) when given — its id
/// is returned.
pub(super) fn write_ground_points<'a>(
    dir: &Path,
    points: impl IntoIterator<Item = &'a Point>,
    sigma: (f64, f64),
    wrong: Option<[f64; 3]>,
    origin: &Geodetic,
    rng: &mut Rng,
) -> Result<Option<String>, SimError> {
    let (sx, sz) = sigma;
    let mut s = String::from("point,kind,lat,lon,h,sigma_xy,sigma_z\n");
    let mut wrong_id = None;
    for (id, kind, x) in points {
        let mut v = *x;
        // Surveyed coordinates carry their σ: control and check points alike.
        if *kind == "gcp" || *kind == "check" {
            v += Vector3::new(sx * rng.normal(), sx * rng.normal(), sz * rng.normal());
        }
        if *kind == "gcp" {
            if let (Some(d), None) = (wrong, &wrong_id) {
                v += Vector3::from(d);
                wrong_id = Some(id.clone());
            }
        }
        let g = geodetic(origin, &v);
        let _ = writeln!(
            s,
            "{id},{kind},{:.10},{:.10},{:.4},{sx},{sz}",
            g.lat.to_degrees(),
            g.lon.to_degrees(),
            g.h
        );
    }
    write(dir, "ground_points.csv", &s)?;
    Ok(wrong_id)
}
