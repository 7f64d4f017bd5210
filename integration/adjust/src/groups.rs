//! The observation groups of the adjustment (variance components, one per kind of
//! observation) and their names for the reports.

use photo::lsq::Group;

/// Observation groups (variance components).
pub const GROUP_IMAGE: Group = Group(0);
/// Control points.
pub const GROUP_CONTROL: Group = Group(1);
/// GNSS antenna positions.
pub const GROUP_GNSS: Group = Group(2);
/// Lever-arm priors.
pub const GROUP_PRIOR: Group = Group(3);
/// Measured distances.
pub const GROUP_DISTANCE: Group = Group(4);
/// Attitude observations.
pub const GROUP_ATTITUDE: Group = Group(5);
/// Double-difference carrier phase (tight coupling).
pub const GROUP_PHASE: Group = Group(6);
/// Double-difference code (tight coupling).
pub const GROUP_CODE: Group = Group(7);
/// Priors of the double-difference ionosphere (tight coupling).
pub const GROUP_IONO: Group = Group(8);
/// Integer constraints of fixed combinations of ambiguities (tight coupling).
pub const GROUP_FIX: Group = Group(9);
/// The inner constraints of a free network.
pub const GROUP_DATUM: Group = Group(10);
/// Beyond this σ factor (or below its inverse) a group's σ are plainly wrong: said so
/// (`quality::misweighted`), and estimated before data snooping (`solve`).
pub const MISWEIGHTED: f64 = 3.0;

/// Names of the groups, by index.
pub const GROUP_NAMES: [&str; 11] = [
    "image points",
    "control points",
    "GNSS centres",
    "lever-arm prior",
    "distances",
    "attitude",
    "GNSS phase (DD)",
    "GNSS code (DD)",
    "ionosphere prior",
    "ambiguity constraints",
    "datum (inner constraints)",
];
