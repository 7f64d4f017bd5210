//! # lsq — the one least-squares core
//!
//! Every adjustment of ppkat runs here: the joint GNSS-supported block adjustment, BAL
//! problems, and any new observation kind. In the Ceres / gtsam pattern:
//!
//! - **Parameter blocks** of any size are named by typed [`Key`]s (`Key::Pose(ImageId)`,
//!   `Key::Point(PointId)`, `Key::LeverArm(CameraId)` …) and hold a [`Value`] (a vector, a
//!   pose, or a rotation followed by a vector) updated on its manifold. A block can be fixed
//!   ([`Problem::set_fixed`]), bounded by a prior (a factor like any other), and blocks of the
//!   kinds in [`Options::eliminate`] are eliminated by the Schur complement while solving.
//! - **Factors** ([`Factor`]) name their keys and return r = h(x) − z and its Jacobians; each
//!   is added with its own [`Noise`] model (σ per component or a full covariance), robust
//!   [`Loss`] and [`Group`] (for variance components). Factors keep their own observation
//!   bookkeeping (which image, which point, which file line); [`Problem::factor_as`] gives
//!   them back by type, so results are read from the factors. Adding an observation kind
//!   never touches this module.
//! - **Solving** ([`Problem::solve`]): Levenberg–Marquardt with a trust region; the reduced
//!   system over the non-eliminated blocks (any eliminated block size) is built row by row in
//!   parallel and solved by dense Cholesky when small, faer's sparse Cholesky (symbolic
//!   factorisation kept) when large. Results are bit-identical whatever the thread count.
//! - **Statistics** at the solution without the full inverse: covariances of chosen blocks,
//!   redundancy numbers, normalised residuals ([`Problem::statistics`]), from the dense
//!   inverse of the reduced system when small and from its selected inverse (Takahashi's
//!   recurrences on the sparse Cholesky factor's pattern) when large; data snooping with
//!   removal, several nearly independent suspects per round ([`Problem::data_snooping`]);
//!   Förstner variance components
//!   ([`Problem::variance_components`]).
//!
//! Units: whatever the factors use; σ0 is dimensionless. Cost = ½Σρ(‖L⁻¹r‖²).

mod cofactor;
mod correl;
mod elim;
mod error;
mod factor;
mod key;
mod lin;
mod linear;
mod lm;
mod model;
mod options;
mod pattern;
mod problem;
mod reduced;
mod selinv;
mod slots;
mod snoop;
mod stats;
mod structure;
mod value;

pub use cofactor::Reliability;
pub use error::SolveError;
pub use factor::{Factor, FactorId, Group, Loss, Noise, Params};
pub use key::{CameraId, DriftId, ImageId, Key, KeyKind, LatencyId, PointId};
pub use lm::Summary;
pub use options::Options;
pub use problem::{BuildError, Observer, Problem, SolveStep, Timing, MAX_FACTOR_KEYS};
pub use snoop::{normal_quantile, snooping_critical, MIN_VCE_REDUNDANCY};
pub use stats::Covariances;
pub use value::Value;
