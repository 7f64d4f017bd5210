//! An estimated parameter block as the results give it ([`Estimated`]): lever arm, boresight,
//! drift, latency or interior orientation, with σ and labels.

use serde::Serialize;

/// An estimated parameter block (lever arm, drift, interior orientation).
#[derive(Clone, Debug, Serialize)]
pub struct Estimated {
    /// Its name.
    pub name: String,
    /// The values.
    pub values: Vec<f64>,
    /// Their σ (0 when fixed).
    pub sigmas: Vec<f64>,
    /// A label per value.
    pub labels: Vec<String>,
    /// Reference time t0 of a drift (GPST seconds), 0 otherwise.
    pub t0: f64,
    /// Whether the block was held fixed.
    pub fixed: bool,
}
