//! "Bundle Adjustment in the Large" problems: the file format and the BAL camera factor; the
//! adjustment itself runs on [`crate::lsq`], the solver of every ppkat adjustment.
//!
//! BAL camera: Rodrigues rotation, translation, f, k1, k2; P = R·X + t, p = −P/P.z,
//! r(p) = 1 + k1‖p‖² + k2‖p‖⁴, predicted = f·r(p)·p. In the solver a camera is one block
//! `Key::Camera` holding the rotation (updated by a left perturbation R ← exp(δ)·R) and the
//! vector (t, f, k1, k2); points are `Key::Point` blocks, Schur-eliminated. The cost is the
//! file's, ½Σr² (unit weights).

use crate::lsq::{self, CameraId, Factor, Group, Key, Loss, Noise, Params, PointId, Value};
use crate::rotation::{exp_so3, log_so3, skew};
use nalgebra::{DMatrixViewMut, DVector, Matrix2x3, Matrix3, SMatrix, Vector2, Vector3};
use rayon::prelude::*;
use std::path::Path;

pub use crate::bal_text::BalError;
use crate::bal_text::Numbers;

/// A BAL camera as the solver holds it.
#[derive(Clone, Debug)]
pub struct BalCamera {
    /// Rotation world → camera (from the Rodrigues vector).
    pub r: Matrix3<f64>,
    /// Translation: P = R·X + t.
    pub t: Vector3<f64>,
    /// Focal length, pixels.
    pub f: f64,
    /// Radial distortion r(p) = 1 + k1‖p‖² + k2‖p‖⁴.
    pub k1: f64,
    /// See `k1`.
    pub k2: f64,
}

/// One observation: camera, point, measured image point.
#[derive(Clone, Copy, Debug)]
pub struct BalObs {
    /// Camera index.
    pub cam: usize,
    /// Point index.
    pub pt: usize,
    /// Measured image point (pixels, BAL's convention).
    pub uv: Vector2<f64>,
}

/// A BAL problem.
#[derive(Clone, Debug)]
pub struct BalProblem {
    /// The cameras.
    pub cameras: Vec<BalCamera>,
    /// The points.
    pub points: Vec<Vector3<f64>>,
    /// The observations.
    pub obs: Vec<BalObs>,
}

impl BalProblem {
    /// Read a BAL file (counts, observations, cameras, points), plain or gzip, streamed line by
    /// line (`common::lines`: no line over 1 MiB, the text never held whole); every number is
    /// checked, and an error names the file, the line and the element. Counts are whole
    /// numbers and nothing is reserved beyond what the file's size can hold. What follows the
    /// last point is not read.
    pub fn read(path: &Path) -> Result<BalProblem, BalError> {
        let p = path.display().to_string();
        let mut src = Numbers::open(path)?;
        let (nc, np, no) = (
            src.count("the camera count")?,
            src.count("the point count")?,
            src.count("the observation count")?,
        );
        // An observation takes at least 8 bytes, a camera 18, a point 6.
        let size = src.size;
        let room = |n: usize, bytes: usize| n.min(size / bytes + 1);
        let mut obs = Vec::with_capacity(room(no, 8));
        for k in 0..no {
            let (cam_v, pt_v) = (
                src.next("an observation's camera")?,
                src.next("an observation's point")?,
            );
            let (u, v) = (src.next("an image x")?, src.next("an image y")?);
            // A negative or fractional index is no index (`as usize` made it camera 0).
            let index = |x: f64, n: usize| {
                (x >= 0.0 && x.fract() == 0.0 && x < n as f64).then_some(x as usize)
            };
            let (Some(cam), Some(pt)) = (index(cam_v, nc), index(pt_v, np)) else {
                return Err(BalError::Format {
                    path: format!("{p}:{}", src.line),
                    what: format!(
                        "observation {k} names camera {cam_v} / point {pt_v}: not indices below {nc} / {np}"
                    ),
                });
            };
            obs.push(BalObs {
                cam,
                pt,
                uv: Vector2::new(u, v),
            });
        }
        let mut cameras = Vec::with_capacity(room(nc, 18));
        for _ in 0..nc {
            let mut c = [0.0; 9];
            for x in c.iter_mut() {
                *x = src.next("camera parameters")?;
            }
            cameras.push(BalCamera {
                r: exp_so3(&Vector3::new(c[0], c[1], c[2])),
                t: Vector3::new(c[3], c[4], c[5]),
                f: c[6],
                k1: c[7],
                k2: c[8],
            });
        }
        let mut points = Vec::with_capacity(room(np, 6));
        for _ in 0..np {
            points.push(Vector3::new(
                src.next("a point")?,
                src.next("a point")?,
                src.next("a point")?,
            ));
        }
        Ok(BalProblem {
            cameras,
            points,
            obs,
        })
    }

    /// Residual (predicted − observed) of one observation.
    pub fn residual(&self, o: &BalObs) -> Vector2<f64> {
        predict(&self.cameras[o.cam], &self.points[o.pt]) - o.uv
    }

    /// ½Σr².
    pub fn cost(&self) -> f64 {
        self.obs
            .par_iter()
            .map(|o| 0.5 * self.residual(o).norm_squared())
            .collect::<Vec<f64>>()
            .iter()
            .sum()
    }

    /// Rodrigues vector of a camera (for writing back in BAL form).
    pub fn rodrigues(&self, cam: usize) -> Vector3<f64> {
        log_so3(&self.cameras[cam].r)
    }
}

type CamJ = SMatrix<f64, 2, 9>;

/// The predicted image point alone.
fn predict(c: &BalCamera, x: &Vector3<f64>) -> Vector2<f64> {
    let pc = c.r * x + c.t;
    let p = Vector2::new(-pc.x / pc.z, -pc.y / pc.z);
    let n = p.norm_squared();
    p * (c.f * (1.0 + c.k1 * n + c.k2 * n * n))
}

/// Prediction and the Jacobians with respect to (δ, t, f, k1, k2) and X.
fn project(c: &BalCamera, x: &Vector3<f64>) -> (Vector2<f64>, CamJ, Matrix2x3<f64>) {
    let rx = c.r * x;
    let pc = rx + c.t;
    let z = pc.z;
    let p = Vector2::new(-pc.x / z, -pc.y / z);
    let n = p.norm_squared();
    let r = 1.0 + c.k1 * n + c.k2 * n * n;
    let pred = p * (c.f * r);
    let dpred_dp = (nalgebra::Matrix2::identity() * r
        + p * p.transpose() * (2.0 * (c.k1 + 2.0 * c.k2 * n)))
        * c.f;
    let dp_dpc = Matrix2x3::new(-1.0 / z, 0.0, pc.x / (z * z), 0.0, -1.0 / z, pc.y / (z * z));
    let a = dpred_dp * dp_dpc; // 2×3: d pred / d P
    let mut jc = CamJ::zeros();
    jc.fixed_view_mut::<2, 3>(0, 0)
        .copy_from(&(a * (-skew(&rx))));
    jc.fixed_view_mut::<2, 3>(0, 3).copy_from(&a);
    jc.set_column(6, &(p * r));
    jc.set_column(7, &(p * (c.f * n)));
    jc.set_column(8, &(p * (c.f * n * n)));
    (pred, jc, a * c.r)
}

/// One BAL observation as a factor: r = predicted − measured (pixels), blocks
/// `Key::Camera(cam)` and `Key::Point(pt)`.
pub struct BalFactor {
    keys: [Key; 2],
    uv: Vector2<f64>,
}

impl BalFactor {
    /// The factor of an observation.
    pub fn new(o: &BalObs) -> BalFactor {
        BalFactor {
            keys: [
                Key::Camera(CameraId::from(o.cam)),
                Key::Point(PointId::from(o.pt)),
            ],
            uv: o.uv,
        }
    }
}

/// A camera block's value: the rotation and (t, f, k1, k2).
fn camera_value(c: &BalCamera) -> Value {
    Value::Rotated {
        r: c.r,
        v: DVector::from_column_slice(&[c.t.x, c.t.y, c.t.z, c.f, c.k1, c.k2]),
    }
}

/// A camera from its block's value.
fn camera_of(r: &Matrix3<f64>, v: &DVector<f64>) -> BalCamera {
    BalCamera {
        r: *r,
        t: Vector3::new(v[0], v[1], v[2]),
        f: v[3],
        k1: v[4],
        k2: v[5],
    }
}

impl Factor for BalFactor {
    crate::keys_in_field!();
    fn dim(&self) -> usize {
        2
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let (Some((rot, v)), Some(pt)) = (x.rotated(0), x.point(1)) else {
            return false;
        };
        if v.len() != 6 {
            return false;
        }
        let cam = camera_of(rot, v);
        if j.iter().all(Option::is_none) {
            r.copy_from_slice((predict(&cam, &pt) - self.uv).as_slice());
            return true;
        }
        let (pred, jc, jp) = project(&cam, &pt);
        r.copy_from_slice((pred - self.uv).as_slice());
        if let Some(m) = &mut j[0] {
            m.copy_from(&jc);
        }
        if let Some(m) = &mut j[1] {
            m.copy_from(&jp);
        }
        true
    }
}

/// Options of a BAL adjustment.
#[derive(Clone, Debug)]
pub struct LmOptions {
    /// Iterations, accepted or not.
    pub max_iterations: usize,
    /// Stop when the relative cost decrease of an accepted step falls below this.
    pub function_tolerance: f64,
    /// Initial trust-region radius (damping = 1/radius on the scaled diagonal).
    pub initial_radius: f64,
    /// Largest reduced camera system solved densely; larger ones go to faer's sparse
    /// Cholesky with the symbolic factorisation computed once.
    pub dense_limit: usize,
    /// Threads for the factorisations (`None`: rayon's pool).
    pub threads: Option<usize>,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            max_iterations: 100,
            function_tolerance: 1e-6,
            initial_radius: 1e4,
            dense_limit: 2000,
            threads: None,
        }
    }
}

/// What the solver did.
#[derive(Clone, Debug)]
pub struct LmReport {
    /// ½Σr² before.
    pub initial_cost: f64,
    /// ½Σr² after.
    pub final_cost: f64,
    /// Iterations, accepted or not.
    pub iterations: usize,
    /// Accepted steps.
    pub successful: usize,
    /// Wall time of the adjustment, seconds.
    pub seconds: f64,
    /// RMS reprojection error per coordinate, pixels.
    pub rms_px: f64,
}

/// The problem on the least-squares core.
fn to_problem(p: &BalProblem, opts: &LmOptions) -> Result<lsq::Problem, lsq::BuildError> {
    let mut pr = lsq::Problem::new(lsq::Options {
        max_iterations: opts.max_iterations,
        function_tolerance: opts.function_tolerance,
        initial_radius: opts.initial_radius,
        dense_limit: opts.dense_limit,
        threads: opts.threads,
        unique: false,
        ..lsq::Options::default()
    });
    for (i, c) in p.cameras.iter().enumerate() {
        pr.add_block(Key::Camera(CameraId::from(i)), camera_value(c))?;
    }
    for (j, x) in p.points.iter().enumerate() {
        pr.add_block(Key::Point(PointId::from(j)), Value::point(x))?;
    }
    for o in &p.obs {
        pr.add_factor(BalFactor::new(o), Noise::Unit, Loss::Trivial, Group(0))?;
    }
    Ok(pr)
}

/// Minimise ½Σr² by Levenberg–Marquardt on [`crate::lsq`] (points eliminated by the Schur
/// complement) and write the adjusted cameras and points back into `problem`.
pub fn solve(problem: &mut BalProblem, opts: &LmOptions) -> Result<LmReport, BalError> {
    let mut pr = to_problem(problem, opts).map_err(|e| BalError::Solve(e.to_string()))?;
    let s = pr.solve().map_err(|e| BalError::Solve(e.to_string()))?;
    for (i, c) in problem.cameras.iter_mut().enumerate() {
        if let Some((r, v)) = pr
            .value(Key::Camera(CameraId::from(i)))
            .and_then(Value::rotated)
        {
            *c = camera_of(r, v);
        }
    }
    for (j, x) in problem.points.iter_mut().enumerate() {
        if let Some(v) = pr
            .value(Key::Point(PointId::from(j)))
            .and_then(Value::as_point)
        {
            *x = v;
        }
    }
    Ok(LmReport {
        initial_cost: s.initial_cost,
        final_cost: s.final_cost,
        iterations: s.iterations,
        successful: s.successful,
        seconds: s.seconds,
        rms_px: (2.0 * s.final_cost / problem.obs.len().max(1) as f64).sqrt(),
    })
}

/// A BAL file read and adjusted by [`run`]: the problem's size, the thread count and the
/// solver's [`LmReport`].
///
/// Its `Display` is the `ppkat bal` report, one line each (scripts parse these lines, so they
/// are stable): `PATH: C cameras, P points, O observations`, `initial cost: …`,
/// `iterations: N (M successful)`, `wall time: S s on T thread(s)`,
/// `RMS reprojection error: … px`, `final cost: …`. Costs are ½Σr² in the file's units
/// (pixels²), printed with six decimals in scientific notation.
#[derive(Clone, Debug)]
pub struct BalRun {
    /// The file, as given.
    pub path: std::path::PathBuf,
    /// Cameras in the file.
    pub cameras: usize,
    /// Points in the file.
    pub points: usize,
    /// Observations (image points) in the file.
    pub observations: usize,
    /// Threads the adjustment ran on: [`LmOptions::threads`], or rayon's current pool size.
    pub threads: usize,
    /// What the solver did.
    pub report: LmReport,
}

impl std::fmt::Display for BalRun {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let r = &self.report;
        writeln!(
            f,
            "{}: {} cameras, {} points, {} observations",
            self.path.display(),
            self.cameras,
            self.points,
            self.observations
        )?;
        writeln!(f, "initial cost: {:.6e}", r.initial_cost)?;
        writeln!(
            f,
            "iterations: {} ({} successful)",
            r.iterations, r.successful
        )?;
        writeln!(
            f,
            "wall time: {:.3} s on {} thread(s)",
            r.seconds, self.threads
        )?;
        writeln!(f, "RMS reprojection error: {:.4} px", r.rms_px)?;
        writeln!(f, "final cost: {:.6e}", r.final_cost)
    }
}

/// Read the BAL file at `path` and adjust it with [`solve`] on the current rayon pool.
///
/// The adjusted problem is not kept (nothing is written); the result says what was done.
/// Errors: the file cannot be read or is malformed ([`BalError::Io`], [`BalError::Format`],
/// both naming the file), or the adjustment fails ([`BalError::Solve`]).
pub fn run(path: &Path, opts: &LmOptions) -> Result<BalRun, BalError> {
    let mut problem = BalProblem::read(path)?;
    let report = solve(&mut problem, opts)?;
    Ok(BalRun {
        path: path.to_path_buf(),
        cameras: problem.cameras.len(),
        points: problem.points.len(),
        observations: problem.obs.len(),
        threads: opts.threads.unwrap_or_else(rayon::current_num_threads),
        report,
    })
}

#[cfg(test)]
mod run_tests {
    use super::*;

    #[test]
    fn the_report_lines_scripts_parse() {
        let run = BalRun {
            path: "p.txt".into(),
            cameras: 2,
            points: 3,
            observations: 6,
            threads: 1,
            report: LmReport {
                initial_cost: 851234.5,
                final_cost: 13344.29,
                iterations: 5,
                successful: 4,
                seconds: 0.25,
                rms_px: 0.91554,
            },
        };
        assert_eq!(
            run.to_string(),
            "p.txt: 2 cameras, 3 points, 6 observations\n\
             initial cost: 8.512345e5\n\
             iterations: 5 (4 successful)\n\
             wall time: 0.250 s on 1 thread(s)\n\
             RMS reprojection error: 0.9155 px\n\
             final cost: 1.334429e4\n"
        );
    }

    #[test]
    fn negative_or_fractional_indices_are_errors_not_camera_0() {
        let cam = "0 0 0 0 0 0 1000 0 0\n";
        for obs in ["-1 0 1.0 2.0", "0 0.5 1.0 2.0", "1 0 1.0 2.0"] {
            let path = testkit::scratch_path("bal-idx.txt");
            std::fs::write(&path, format!("1 1 1\n{obs}\n{cam}0 0 5\n")).unwrap();
            let e = BalProblem::read(&path).unwrap_err().to_string();
            assert!(
                e.contains(":2") && e.contains("not indices below 1 / 1"),
                "{obs}: {e}"
            );
        }
    }

    #[test]
    fn a_malformed_file_is_named() {
        let path = testkit::scratch_path("bal-run.txt");
        std::fs::write(&path, "1 1 1\n0 0 1.0 x\n").unwrap();
        let e = run(&path, &LmOptions::default()).unwrap_err();
        assert!(matches!(e, BalError::Format { .. }), "{e}");
        assert!(e.to_string().contains("bal-run.txt"), "{e}");
    }

    #[test]
    fn gzip_reads_as_plain_and_an_overlong_line_or_binary_is_refused_by_line() {
        let text = "2 2 3\n0 0 1.5 -2.5\n1 1 3.0 4.0\n1 0  5.0\t6.0\n\
                    0 0 0 0 0 -10 1000 0 0\n0.1 0 0 1 2 -10 900 1e-3 0\n1 2 3\n4 5 6\n";
        let plain = testkit::scratch_file("bal-plain.txt", text);
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut enc, text.as_bytes()).unwrap();
        let gz = testkit::scratch_file("bal-plain.txt.gz", enc.finish().unwrap());
        let (a, b) = (
            BalProblem::read(&plain).unwrap(),
            BalProblem::read(&gz).unwrap(),
        );
        for p in [&a, &b] {
            assert_eq!((p.cameras.len(), p.points.len(), p.obs.len()), (2, 2, 3));
            assert_eq!((p.obs[2].cam, p.obs[2].pt, p.obs[2].uv.y), (1, 0, 6.0));
            assert_eq!((p.cameras[1].f, p.cameras[1].k1), (900.0, 1e-3));
            assert_eq!(p.points[1], Vector3::new(4.0, 5.0, 6.0));
        }
        let long = format!("1 1 1\n{}\n", "0 ".repeat(common::lines::MAX_LINE));
        let e = BalProblem::read(&testkit::scratch_file("bal-long.txt", long)).unwrap_err();
        assert!(
            e.to_string()
                .contains("bal-long.txt:2: a line longer than 1024 KiB"),
            "{e}"
        );
        let binary = testkit::scratch_file("bal-binary.txt", b"1 1 1\n0 0 \xff\xfe 2\n");
        let e = BalProblem::read(&binary).unwrap_err().to_string();
        assert!(e.contains("bal-binary.txt:2: it is not text"), "{e}");
        let nbsp = testkit::scratch_file("bal-nbsp.txt", "1 1 1\n0 0 1.0\u{a0}2.0\n");
        let e = BalProblem::read(&nbsp).unwrap_err().to_string();
        assert!(
            e.contains("bal-nbsp.txt:2: '1.0\u{a0}2.0' is not a number"),
            "{e}"
        );
    }
}
