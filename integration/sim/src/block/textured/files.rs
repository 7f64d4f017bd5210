//! The text files of a textured block besides those shared with the other blocks: the
//! camera as a `[[camera]]` table (`camera.toml`, also inside `project.toml`), the exact image
//! measurements, the true ground points and `project.toml`.
//!
//! What enters: the spec and the simulated records (site ENU metres, pixels). What leaves:
//! file texts; nothing is written here.

use super::TexturedSpec;
use crate::ground_points::Point;
use std::fmt::Write as _;

/// σ written with each exact image measurement, pixels (they are exact to 1e-6 px).
pub(super) const EXACT_SIGMA_PX: f64 = 0.1;

/// The camera as a `[[camera]]` table of a ppkat project (every number written so that it
/// reads back to the same bits).
pub(super) fn camera_toml(spec: &TexturedSpec) -> String {
    let [x0, y0] = spec.principal_point_mm;
    format!(
        "[[camera]]\nid = \"cam\"\nfocal_mm = {:?}\npixel_um = {:?}\nwidth_px = {}\nheight_px = {}\nprincipal_point_mm = [{x0:?}, {y0:?}]\nk = [{:?}, 0.0, 0.0]\nsigma_px = 0.5\n",
        spec.focal_mm, spec.pixel_um, spec.width_px, spec.height_px, spec.k1
    )
}

/// `image_observations.csv`: the exact pixel of every point in every image measuring it.
pub(super) fn measurements_csv(
    meas: &[super::Measurement],
    ids: &[String],
    points: &[Point],
) -> String {
    let mut s = String::from("image,point,x_px,y_px,sigma_px\n");
    for (i, k, px) in meas {
        let _ = writeln!(
            s,
            "{},{},{:.6},{:.6},{EXACT_SIGMA_PX}",
            ids[*i], points[*k].0, px.x, px.y
        );
    }
    s
}

/// `truth_points.csv`: the exact ground points written (site ENU, m).
pub(super) fn truth_points_csv(points: &[&Point]) -> String {
    let mut s =
        String::from("# true ground points, site ENU (m), on the terrain\npoint,kind,e,n,u\n");
    for (id, kind, x) in points {
        let _ = writeln!(s, "{id},{kind},{:?},{:?},{:?}", x.x, x.y, x.z);
    }
    s
}

/// `project.toml`: the exact camera, the tables, and the `[gnss]` section given.
pub(super) fn project_toml(spec: &TexturedSpec, gnss: &str) -> String {
    format!(
        "name = \"textured block (seed {})\"\noutput = \"utm\"\n\n{}\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n\n{gnss}",
        spec.seed,
        camera_toml(spec)
    )
}
