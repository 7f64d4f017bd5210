#![deny(missing_docs)]
//! # photo — the photogrammetric half of ppkat
//!
//! Cameras, rotation conventions, collinearity, resection, intersection and the one
//! least-squares core every adjustment runs on. It knows nothing of GNSS.
//!
//! - [`rotation`]: SO(3) exponential and logarithm, ω-φ-κ / φ-ω-κ / yaw-pitch-roll.
//! - [`camera`]: interior orientation (Brown distortion, affinity), collinearity with analytic
//!   Jacobians, pixel ↔ image coordinates.
//! - [`camera_convert`]: MicMac (`ModRad`, `ModPhgrStd`) and OpenCV/COLMAP camera models
//!   converted into [`camera::Camera`], with the conversion's error.
//! - [`datum`]: inner constraints over the image centres, the datum of a free network.
//! - [`lever`]: the GNSS lever arm, X_A = X_S + R·(u, v, w).
//! - [`resection`], [`intersection`]: closed-form starts and least-squares refinement.
//! - [`relative`]: the relative orientation of two images (five-point essential matrix, RANSAC).
//! - [`lsq`]: the least-squares core — typed keys, factors with their own noise model and
//!   loss, Levenberg–Marquardt with the Schur complement, statistics, data snooping, variance
//!   components.
//! - [`factors`]: image points (with self-calibration), priors, distances on [`lsq`].
//! - [`bal`]: the "Bundle Adjustment in the Large" file format and camera factor on [`lsq`]
//!   (the file's text read by `bal_text` through `common::lines`).
//!
//! Its one ppkat dependency is `common`, for bounded text input; it writes no files.
//!
//! Conventions (see the house plan): R maps the camera frame into the object frame; image
//! coordinates are metric with x right, y up, origin at the image centre; a rotation step is a
//! left perturbation R ← exp(\[δ\]×)·R.

pub mod bal;
mod bal_text;
pub mod camera;
pub mod camera_convert;
pub mod datum;
pub mod factors;
pub mod features;
pub mod intersection;
pub mod lever;
pub mod lsq;
pub mod relative;
pub mod resection;
mod resection_triples;
pub mod rotation;
mod sample;
