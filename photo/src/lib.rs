//! # photo — the photogrammetric half of ppkat
//!
//! Cameras, rotation conventions, collinearity, resection, intersection and bundle adjustment.
//! It knows nothing of GNSS. Today: [`rotation`] (SO(3) exponential and logarithm) and
//! [`bal`] (Bundle Adjustment in the Large: reader and a Levenberg–Marquardt solver with
//! Schur elimination of the points).

pub mod bal;
pub mod camera;
pub mod factors;
pub mod intersection;
pub mod lever;
pub mod lsq;
pub mod resection;
pub mod rotation;
