//! # photo — the photogrammetric half of ppkat
//!
//! Cameras, rotation conventions, collinearity, resection, intersection and bundle adjustment
//! (issue "Photogrammetric core"). It knows nothing of GNSS.
