//! The solve stage: the problem built from a project is adjusted with data snooping, variance
//! components and snooping again; solver errors are renamed with the project's ids.

use super::build::{self, Built};
use super::error::AdjustError;
use super::project::Project;

/// The adjusted problem with what was removed and estimated on the way.
pub struct Solved {
    /// The problem and how to read it.
    pub built: Built,
    /// The last solve.
    pub stats: photo::lsq::Summary,
    /// Factors removed by data snooping, in order, with |w|.
    pub removed: Vec<(photo::lsq::FactorId, f64)>,
    /// σ multiplier per observation group (variance components; 1 when not estimated).
    pub components: Vec<f64>,
    /// Critical |w| of data snooping (5 % family-wise).
    pub critical: f64,
}

/// How to run an adjustment (what is not the project's own business).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunOptions {
    /// Threads for the solver's factorisations (`None`: rayon's pool). Results are the same
    /// bits whatever the number.
    pub threads: Option<usize>,
}

/// Adjust a loaded project.
pub fn solve(project: &Project, opts: &RunOptions) -> Result<Solved, AdjustError> {
    solve_with_progress(project, opts, None)
}

/// Progress shared with the solver (it outlives the call, so it is shared, not borrowed).
pub type SharedProgress = std::sync::Arc<dyn common::progress::Progress + Send>;

/// [`solve`], telling `progress` each solve and snooping round as a stage whose steps (the
/// Levenberg–Marquardt iterations) are not known beforehand.
pub fn solve_with_progress(
    project: &Project,
    opts: &RunOptions,
    progress: Option<SharedProgress>,
) -> Result<Solved, AdjustError> {
    let t0 = std::time::Instant::now();
    let mut built = build::build(project)?;
    built
        .problem
        .record_time("build", t0.elapsed().as_secs_f64());
    built.problem.options.threads = opts.threads;
    if let Some(p) = progress.clone() {
        built
            .problem
            .set_observer(Some(std::sync::Arc::new(move |step| match step {
                photo::lsq::SolveStep::SnoopingRound(k) => p.set_len(
                    &format!("adjustment: data snooping round {k}, iteration"),
                    0,
                ),
                photo::lsq::SolveStep::Iteration(..) => p.inc(1),
            })));
    }
    let stage = |name: &str| {
        if let Some(p) = &progress {
            p.set_len(name, 0);
        }
    };
    let mut removed = Vec::new();
    let result = solve_leaving_out(project, &mut built, &stage, &mut removed);
    if let Some(p) = &progress {
        p.finish();
    }
    built.problem.set_observer(None);
    let name = |e: photo::lsq::SolveError| {
        use photo::lsq::SolveError;
        match e {
        SolveError::Undetermined(k) => AdjustError::Solve(format!(
            "{} is not determined by its observations (too few rays, or rays too close to parallel): remove it or measure it in more images",
            block_name(project, &built, k)
        )),
        SolveError::Dependent(k) => AdjustError::Solve(format!(
            "the normal equations are singular at {}: a datum defect (too little control or GNSS) or unknowns that cannot be told apart (e.g. a drift offset without control, or offsets per strip with a free lever arm)",
            block_name(project, &built, k)
        )),
        e => AdjustError::from(e),
    }
    };
    match result {
        Ok((stats, components, critical)) => Ok(Solved {
            built,
            stats,
            removed,
            components,
            critical,
        }),
        Err(e) => Err(name(e)),
    }
}

/// A readable name of a parameter block, with the project's ids.
fn block_name(p: &Project, b: &Built, key: photo::lsq::Key) -> String {
    use photo::lsq::Key;
    let camera = |c: photo::lsq::CameraId| {
        p.cameras
            .get(c.index())
            .map_or(c.to_string(), |c| c.id.clone())
    };
    match key {
        Key::Pose(i) => format!(
            "the orientation of image {}",
            p.images
                .get(i.index())
                .map_or(i.to_string(), |x| x.id.clone())
        ),
        Key::Point(k) => format!(
            "point {}",
            b.point_names.get(k.index()).cloned().unwrap_or_default()
        ),
        Key::Drift(d) => format!(
            "the drift of {}",
            b.drifts
                .get(d.index())
                .map_or(d.to_string(), |x| x.name.clone())
        ),
        Key::Latency(l) => format!(
            "the GNSS latency of {}",
            b.latencies
                .get(l.index())
                .map_or(l.to_string(), |x| x.name.clone())
        ),
        Key::LeverArm(c) => format!("the lever arm of camera {}", camera(c)),
        Key::Camera(c) => format!("the interior orientation of camera {}", camera(c)),
        k => k.to_string(),
    }
}

/// Images or points the solver may leave out, one at a time, before the solve gives up.
const MAX_LEFT_OUT_BY_SOLVER: usize = 1000;

/// What a solve produced: the last summary, the variance components, the critical |w|.
type SolveOutput = (photo::lsq::Summary, Vec<f64>, f64);

/// [`solve_built`], again after leaving out each image or point the solver finds singular
/// (named in `built.left_out`); a singular block of any other kind, or a leave-out that would
/// take the block apart, is the solver's error.
fn solve_leaving_out(
    project: &Project,
    built: &mut Built,
    stage: &dyn Fn(&str),
    removed: &mut Vec<(photo::lsq::FactorId, f64)>,
) -> Result<SolveOutput, photo::lsq::SolveError> {
    use photo::lsq::{Key, SolveError};
    for _ in 0..MAX_LEFT_OUT_BY_SOLVER {
        let result = solve_built(project, built, stage, removed);
        let (key, why) = match &result {
            Err(SolveError::Undetermined(k)) => (*k, "not determined by the observations left to it (after data snooping or other images left out)"),
            Err(SolveError::Dependent(k)) => (*k, "its observations do not fix its unknowns together with the rest of the block (too few points, in line with the GNSS centre or each other)"),
            _ => return result,
        };
        let Built {
            problem,
            point_names,
            left_out,
            drifts,
            ..
        } = built;
        let names = super::leave_out::Names {
            project,
            points: point_names,
            drifts,
        };
        let images_out = |pr: &photo::lsq::Problem| {
            pr.keys()
                .iter()
                .filter(|k| matches!(k, Key::Pose(_)) && pr.is_fixed(**k))
                .count()
        };
        let before = images_out(problem);
        let done = super::leave_out::singular(&names, problem, key, why, left_out);
        // Leaving it out must not take the block apart: when it drags more than a tenth of
        // the images with it, the block itself is ill-conditioned and the solver's error is
        // the honest answer.
        let cascade = images_out(problem) - before;
        if !matches!(done, Ok(true)) || cascade > (project.images.len() / 10).max(3) {
            return result;
        }
    }
    solve_built(project, built, stage, removed)
}

/// Snooping, variance components, snooping again, final solve; what snooping removed is
/// added to `removed`.
fn solve_built(
    project: &Project,
    built: &mut Built,
    stage: &dyn Fn(&str),
    removed: &mut Vec<(photo::lsq::FactorId, f64)>,
) -> Result<SolveOutput, photo::lsq::SolveError> {
    let opts = &project.file.adjustment;
    let (pr, tight) = (&mut built.problem, &mut built.tight);
    let tests: usize = pr.factors().map(|(_, f)| f.dim()).sum();
    let critical = photo::lsq::snooping_critical(opts.alpha, tests);
    let snoop = |pr: &mut photo::lsq::Problem,
                 removed: &mut Vec<(photo::lsq::FactorId, f64)>|
     -> Result<(), photo::lsq::SolveError> {
        if opts.snooping {
            removed.extend(pr.data_snooping(critical)?.1);
        } else {
            stage("adjustment: solve, iteration");
            pr.solve()?;
        }
        Ok(())
    };
    let mut components = vec![1.0; GROUPS];
    if opts.variance_components && tight.is_none() {
        // First σ that are wrong by far (navigation-grade centres given survey σ): data
        // snooping would otherwise remove or weigh down the right observations of that group
        // one by one and leave the block ill-conditioned. Not with tight coupling: float
        // ambiguities would be taken for noise of the phase.
        stage("adjustment: variance components, iteration");
        components = pr.gross_variance_components(10, super::groups::MISWEIGHTED)?;
    }
    snoop(pr, removed)?;
    if let Some(t) = tight.as_mut() {
        // Integers with the image geometry in the ambiguities' covariance, then snooping
        // again with them.
        stage("adjustment: ambiguity resolution, iteration");
        t.sigma_float = super::tight::centre_sigmas(pr, t)?;
        super::tight::resolve(pr, t, RATIO_MIN, SUCCESS_MIN)?;
        snoop(pr, removed)?;
    }
    if opts.variance_components {
        stage("adjustment: variance components, iteration");
        components = pr.variance_components(10)?;
        // Snoop again with the estimated weights.
        snoop(pr, removed)?;
    }
    stage("adjustment: final solve, iteration");
    let stats = pr.solve()?;
    Ok((stats, components, critical))
}

/// Tight coupling: the ratio test's threshold.
const RATIO_MIN: f64 = 3.0;
/// Tight coupling: the bootstrapped success rate a fixed subset must reach.
const SUCCESS_MIN: f64 = 0.999;

/// Number of observation groups (see `build::GROUP_NAMES`).
const GROUPS: usize = build::GROUP_NAMES.len();
