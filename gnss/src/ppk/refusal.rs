//! Why an epoch that could have been fixed was not: the check that refused its fix, so that
//! a user can tell from the summary which of them held the run back, and when.
//!
//! What enters: the integer resolution ([`super::ar`]), the filter's checks of a fix
//! (`filter::resolution`) and the combination of the two passes ([`super::combine`]) each
//! name the check that refused. What leaves: a [`Refusal`] on each float epoch
//! ([`super::EpochSol::refused`]) and, over the run, [`PpkResult::refusals`](super::PpkResult).

use std::fmt;

/// The check that refused an epoch's fix, in the order the checks run (a later one got
/// closer to a fix).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Refusal {
    /// Fewer ambiguities than `min_fix_ambiguities` could be tried: locked too briefly,
    /// below the AR mask, with an unresolved half cycle, GLONASS, or kept float on purpose.
    Candidates,
    /// Not even `min_fix_ambiguities` of the decorrelated ambiguities are precise enough to
    /// reach the success rate: the float is too loose to try.
    SuccessRate,
    /// Every subset tried failed the ratio test.
    Ratio,
    /// The fixed subset did not determine the position, or its σ exceeds
    /// [`PpkOptions::fixed_sigma_limit`](super::PpkOptions::fixed_sigma_limit).
    SigmaLimit,
    /// The data before or after the epoch alone fixed an ambiguity to another integer.
    HalvesDisagree,
    /// On a long baseline, the fix lay farther from the float than its covariance allows.
    FarFromFloat,
    /// The two passes' solutions of the epoch contradict each other: the combination took
    /// the float.
    PassesDisagree,
}

impl Refusal {
    /// Every refusal, in check order.
    pub const ALL: [Refusal; 7] = [
        Refusal::Candidates,
        Refusal::SuccessRate,
        Refusal::Ratio,
        Refusal::SigmaLimit,
        Refusal::HalvesDisagree,
        Refusal::FarFromFloat,
        Refusal::PassesDisagree,
    ];

    /// What a user reads.
    pub fn name(self) -> &'static str {
        match self {
            Refusal::Candidates => "too few ambiguities to try (short locks, half cycles, mask)",
            Refusal::SuccessRate => "float too loose (success rate)",
            Refusal::Ratio => "ratio test",
            Refusal::SigmaLimit => "fixed σ limit",
            Refusal::HalvesDisagree => "halves disagree",
            Refusal::FarFromFloat => "far from the float",
            Refusal::PassesDisagree => "passes disagree",
        }
    }
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
