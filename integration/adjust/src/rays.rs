//! The rays of the tie and control points: measurements grouped by point ([`Rays`]) and a
//! point intersected from the images that have a pose (`intersect_point`), which the start
//! values (`start`, `start_relative`) and the assembly share.

use super::project::Project;
use nalgebra::Vector3;
use photo::camera::Pose;
use photo::intersection::{intersect, Ray};
use std::collections::BTreeMap;

/// Measurements by point id (indices into the project's measurements), in id order.
pub(super) type Rays<'a> = BTreeMap<&'a str, Vec<usize>>;

/// A point intersected from its measurements (indices) in the images that have a pose; `None`
/// with fewer than two such rays or when the rays do not meet.
pub(super) fn intersect_point<'a>(
    p: &'a Project,
    measurements: &[usize],
    pose_of: impl Fn(usize) -> Option<&'a Pose>,
) -> Option<Vector3<f64>> {
    let rays: Vec<Ray> = measurements
        .iter()
        .filter_map(|&k| {
            let m = &p.measurements[k];
            pose_of(m.image).map(|pose| Ray {
                camera: &p.cameras[p.images[m.image].camera].camera,
                pose,
                xy: m.xy,
                sigma: m.sigma,
            })
        })
        .collect();
    if rays.len() < 2 {
        return None;
    }
    intersect(&rays).ok().map(|x| x.point)
}
