//! Progress of a long stage, reported to whoever runs it (the command line draws a bar with an
//! ETA; libraries print nothing). Reporting never changes a result.
//!
//! Enters: nothing. Leaves: the [`Progress`] trait that `ppk`, `ppp`, the raw-log conversion
//! and the adjustment call as they go, and [`NoProgress`] for callers that do not watch.

/// Where a long stage reports how far it is. Implementations must be cheap and must not
/// panic; calls may come from several threads at once (the PPK passes run in parallel).
pub trait Progress: Sync {
    /// A stage of `len` steps begins, named `stage`; the count restarts at 0. A `len` of 0
    /// means the number of steps is not known beforehand.
    fn set_len(&self, stage: &str, len: u64);
    /// `n` more steps are done.
    fn inc(&self, n: u64);
    /// The stage is over.
    fn finish(&self);
}

/// Progress nobody watches.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn set_len(&self, _stage: &str, _len: u64) {}
    fn inc(&self, _n: u64) {}
    fn finish(&self) {}
}
