//! The joint GNSS-supported bundle adjustment (`ppkat adjust`): image points, control and
//! check points, GNSS antenna positions with their full covariance, an unknown lever arm,
//! drift per block, strip or ambiguity segment, optional self-calibration — all factors on
//! `photo::solver`. Then data snooping with removal, variance components, covariances,
//! reliability and the check-point table; outputs in geodetic and UTM / Gauss–Krüger.
//!
//! Stages: [`project`] (TOML + tables) → [`build`] (frame, start values, factors) → [`solve`]
//! here → [`results`] (numbers for the report) → [`report`] (CSV, JSON, HTML with SVG plots).

pub mod build;
pub mod factors;
pub mod project;
pub mod report;
pub mod residuals;
pub mod results;
mod tables;

use build::Built;
use project::Project;
use std::path::Path;

/// Why an adjustment cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum AdjustError {
    #[error("{path}: {what}")]
    Project { path: String, what: String },
    #[error("{path}, line {line}: {what}")]
    Input {
        path: String,
        line: usize,
        what: String,
    },
    #[error("{0}")]
    Problem(String),
    #[error("the adjustment failed: {0}")]
    Solve(String),
    #[error("{path}: cannot write: {what}")]
    Write { path: String, what: String },
}

impl From<photo::solver::SolveError> for AdjustError {
    fn from(e: photo::solver::SolveError) -> Self {
        AdjustError::Solve(e.to_string())
    }
}

/// The adjusted problem with what was removed and estimated on the way.
pub struct Solved {
    pub built: Built,
    pub stats: photo::solver::Stats,
    /// Factors removed by data snooping (indices into `built.obs`), in order, with |w|.
    pub removed: Vec<(usize, f64)>,
    /// σ multiplier per observation group (variance components; 1 when not estimated).
    pub components: Vec<f64>,
    pub critical: f64,
}

/// Adjust a loaded project.
pub fn solve(project: &Project) -> Result<Solved, AdjustError> {
    let built = build::build(project)?;
    let names = block_names(project, &built);
    let name = |e: photo::solver::SolveError| {
        match e {
        photo::solver::SolveError::Undetermined(b) => AdjustError::Solve(format!(
            "{} is not determined by its observations (too few rays, or rays too close to parallel): remove it or measure it in more images",
            names.get(b).cloned().unwrap_or_else(|| format!("block {b}"))
        )),
        photo::solver::SolveError::Dependent(b) => AdjustError::Solve(format!(
            "the normal equations are singular at {}: a datum defect (too little control or GNSS) or unknowns that cannot be told apart (e.g. a drift offset without control, or offsets per strip with a free lever arm)",
            names.get(b).cloned().unwrap_or_else(|| format!("block {b}"))
        )),
        e => AdjustError::from(e),
    }
    };
    solve_built(project, built).map_err(name)
}

/// A readable name per parameter block.
fn block_names(p: &Project, b: &Built) -> Vec<String> {
    let mut n = vec![String::new(); b.problem.blocks.len()];
    for (i, &k) in b.poses.iter().enumerate() {
        n[k] = format!("the orientation of image {}", p.images[i].id);
    }
    for (id, &k) in &b.points {
        n[k] = format!("point {id}");
    }
    for d in &b.drifts {
        n[d.block] = format!("the drift of {}", d.name);
    }
    for (c, l) in b.levers.iter().enumerate() {
        if let Some(l) = l {
            n[*l] = format!("the lever arm of camera {}", p.cameras[c].id);
        }
    }
    for (c, l) in b.interiors.iter().enumerate() {
        if let Some(l) = l {
            n[*l] = format!("the interior orientation of camera {}", p.cameras[c].id);
        }
    }
    n
}

fn solve_built(project: &Project, mut built: Built) -> Result<Solved, photo::solver::SolveError> {
    let opts = &project.file.adjustment;
    let it = opts.max_iterations;
    let tests: usize = built.problem.factors.iter().map(|f| f.sigmas().len()).sum();
    let critical = photo::solver::snooping_critical(opts.alpha, tests);
    let mut removed = Vec::new();
    let pr = &mut built.problem;
    let snoop = |pr: &mut photo::solver::Problem,
                 removed: &mut Vec<(usize, f64)>|
     -> Result<(), photo::solver::SolveError> {
        if opts.snooping {
            removed.extend(pr.data_snooping(critical, it)?.1);
        } else {
            pr.solve(it)?;
        }
        Ok(())
    };
    snoop(pr, &mut removed)?;
    let mut components = vec![1.0; pr.group_scale.len()];
    if opts.variance_components {
        components = pr.variance_components(10, it)?;
        // Snoop again with the estimated weights.
        snoop(pr, &mut removed)?;
    }
    let stats = pr.solve(it)?;
    Ok(Solved {
        built,
        stats,
        removed,
        components,
        critical,
    })
}

/// Load, adjust and write every output into `out`; returns the report.
pub fn run(project_path: &Path, out: &Path) -> Result<results::Results, AdjustError> {
    let project = Project::load(project_path)?;
    let solved = solve(&project)?;
    let res = results::collect(&project, &solved)?;
    report::write_all(&project, &res, out)?;
    Ok(res)
}
