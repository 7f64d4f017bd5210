//! The general adjustment on a synthetic block with exact truth: data snooping finds injected
//! blunders without removing good observations; variance components recover group sigmas.

use nalgebra::{Vector2, Vector3};
use photo::camera::{Camera, Pose};
use photo::factors::{ImagePoint, Prior};
use photo::lsq::{
    FactorId, Group, ImageId, Key, KeyKind, Loss, Noise, Options, PointId, Problem, Value,
};
use photo::rotation::Angles;

/// Deterministic normal numbers (SplitMix64 + Box–Muller).
struct Rng(u64);
impl Rng {
    fn u(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn n(&mut self) -> f64 {
        (-2.0 * self.u().max(1e-300).ln()).sqrt() * (2.0 * std::f64::consts::PI * self.u()).cos()
    }
}

const PX: f64 = 3.9e-6;

struct Block3 {
    cam: Camera,
    poses: Vec<Pose>,
    points: Vec<Vector3<f64>>,
}

fn block() -> Block3 {
    let cam = Camera::ideal(0.035, PX, 6000, 4000);
    let mut poses = Vec::new();
    for i in 0..3 {
        for j in 0..3 {
            poses.push(Pose {
                r: Angles::OmegaPhiKappa {
                    omega: 0.01 * (i as f64 - 1.0),
                    phi: 0.01 * (j as f64 - 1.0),
                    kappa: 0.02,
                }
                .matrix(),
                centre: Vector3::new(60.0 * i as f64, 60.0 * j as f64, 350.0),
            });
        }
    }
    let mut rng = Rng(11);
    let points = (0..340)
        .map(|_| {
            Vector3::new(
                rng.u() * 160.0 - 20.0,
                rng.u() * 160.0 - 20.0,
                rng.u() * 10.0,
            )
        })
        .collect();
    Block3 { cam, poses, points }
}

/// Build the problem: image points (σ_true per camera, in groups), 12 control points, a
/// perturbed start, `blunders` image points shifted by 10–30 px, every factor with `loss`.
/// Returns the problem, the blunders' factors and the number of image points.
fn problem_with(
    b: &Block3,
    sigma_true: impl Fn(usize) -> f64,
    group_of: impl Fn(usize) -> usize,
    blunders: usize,
    loss: Loss,
) -> (Problem, Vec<FactorId>, usize) {
    let mut rng = Rng(5);
    let mut p = Problem::new(Options::default());
    for (i, t) in b.poses.iter().enumerate() {
        let r = photo::rotation::exp_so3(&Vector3::new(
            0.005 * rng.n(),
            0.005 * rng.n(),
            0.005 * rng.n(),
        )) * t.r;
        let pose = Pose {
            r,
            centre: t.centre + Vector3::new(rng.n(), rng.n(), rng.n()),
        };
        p.add_block(Key::Pose(ImageId::from(i)), Value::Pose(pose))
            .unwrap();
    }
    for (k, x) in b.points.iter().enumerate() {
        let v = Value::point(&(x + Vector3::new(rng.n(), rng.n(), rng.n())));
        p.add_block(Key::Point(PointId::from(k)), v).unwrap();
    }
    // Observations first, so that blunders can be placed before the factors are built.
    let mut obs: Vec<(usize, usize, Vector2<f64>)> = Vec::new();
    for (c, pose) in b.poses.iter().enumerate() {
        for (k, x) in b.points.iter().enumerate() {
            if let Some(xy) = b.cam.project(pose, x) {
                let px = b.cam.image_to_pixel(xy);
                if px.x >= 0.0 && px.y >= 0.0 && px.x < 6000.0 && px.y < 4000.0 {
                    obs.push((c, k, xy + Vector2::new(rng.n(), rng.n()) * sigma_true(c)));
                }
            }
        }
    }
    let chosen: Vec<usize> = (0..blunders).map(|i| (i * 397 + 50) % obs.len()).collect();
    for (n, &i) in chosen.iter().enumerate() {
        let size = (10.0 + 4.0 * n as f64) * PX * if n % 2 == 0 { 1.0 } else { -1.0 };
        obs[i].2.y += size;
    }
    let mut bl = Vec::new();
    for (i, (c, k, xy)) in obs.iter().enumerate() {
        let f = ImagePoint::new(b.cam, ImageId::from(*c), PointId::from(*k), *xy);
        let g = Group(group_of(*c));
        let f = p.add_factor(f, Noise::isotropic(2, PX), loss, g).unwrap();
        if chosen.contains(&i) {
            bl.push(f);
        }
    }
    for k in 0..12 {
        let f = Prior::point(PointId::from(k * 25), b.points[k * 25]);
        p.add_factor(f, Noise::isotropic(3, 0.02), loss, Group(1))
            .unwrap();
    }
    (p, bl, obs.len())
}

/// [`problem_with`] in plain least squares.
fn problem(
    b: &Block3,
    sigma_true: impl Fn(usize) -> f64,
    group_of: impl Fn(usize) -> usize,
    blunders: usize,
) -> (Problem, Vec<FactorId>, usize) {
    problem_with(b, sigma_true, group_of, blunders, Loss::Trivial)
}

#[test]
fn data_snooping_finds_five_blunders_among_two_thousand_points() {
    let b = block();
    let (mut p, blunders, n_image) = problem(&b, |_| PX, |_| 0, 5);
    assert!(n_image >= 1900, "{n_image} image points");
    // 5 % family-wise over all image coordinates (Bonferroni), not 0.1 % per test.
    let critical = photo::lsq::snooping_critical(0.05, 2 * n_image);
    p.options.max_iterations = 30;
    let rounds = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let seen = rounds.clone();
    p.set_observer(Some(std::sync::Arc::new(move |step| {
        if let photo::lsq::SolveStep::SnoopingRound(k) = step {
            seen.store(k, std::sync::atomic::Ordering::Relaxed);
        }
    })));
    let (stats, removed) = p.data_snooping(critical).unwrap();
    let rounds = rounds.load(std::sync::atomic::Ordering::Relaxed);
    let removed: Vec<FactorId> = removed.iter().map(|x| x.0).collect();
    let mut r = removed.clone();
    r.sort();
    let mut want = blunders.clone();
    want.sort();
    eprintln!("{n_image} image points, {} unknowns, critical |w| {critical:.2}, σ0 {:.3}, removed {:?} (blunders {:?}) in {rounds} rounds", stats.unknowns, stats.sigma0, removed, blunders);
    assert_eq!(r, want, "exactly the blunders are removed");
    assert!((stats.sigma0 - 1.0).abs() < 0.1, "σ0 {}", stats.sigma0);
    // Blunders whose tests hardly depend on each other go in the same round: fewer rounds
    // than one removal per round (five, and a last one that finds nothing).
    assert!(rounds < 6, "{rounds} rounds");
}

#[test]
fn variance_components_recover_two_group_sigmas() {
    let b = block();
    // Cameras 0–4 measured at 1 px, 5–8 at 2 px; both assumed 1 px.
    let (mut p, _, _) = problem(
        &b,
        |c| if c < 5 { PX } else { 2.0 * PX },
        |c| if c < 5 { 0 } else { 2 },
        0,
    );
    p.options.max_iterations = 30;
    let s = p.variance_components(10).unwrap();
    eprintln!("variance components: σ multipliers {s:?}");
    assert!((s[0] - 1.0).abs() < 0.1, "group 0: {}", s[0]);
    assert!((s[2] - 2.0).abs() < 0.2, "group 2: {}", s[2]);
}

#[test]
fn bad_problems_give_clear_errors() {
    let b = block();
    let (mut p, _, _) = problem(&b, |_| PX, |_| 0, 0);
    // A point seen once (an extra point block with a single ray): not determined.
    let lonely = PointId(9999);
    p.add_block(
        Key::Point(lonely),
        Value::point(&Vector3::new(50.0, 50.0, 0.0)),
    )
    .unwrap();
    let xy = b
        .cam
        .project(&b.poses[4], &Vector3::new(50.0, 50.0, 0.0))
        .unwrap();
    let f = ImagePoint::new(b.cam, ImageId(4), lonely, xy);
    p.add_factor(f, Noise::isotropic(2, PX), Loss::Trivial, Group(0))
        .unwrap();
    let e = p.solve().unwrap_err().to_string();
    assert!(
        e.contains("not determined") && e.contains("point 9999"),
        "{e}"
    );
    // A camera with no observations: not determined either.
    let (mut q, _, _) = problem(&b, |_| PX, |_| 0, 0);
    q.add_block(Key::Pose(ImageId(99)), Value::Pose(b.poses[0]))
        .unwrap();
    let e = q.solve().unwrap_err().to_string();
    assert!(
        e.contains("not determined") && e.contains("image 99"),
        "{e}"
    );
    // No control and nothing fixed: a datum defect.
    let mut d = Problem::new(Options::default());
    d.add_block(Key::Pose(ImageId(0)), Value::Pose(b.poses[0]))
        .unwrap();
    d.add_block(Key::Point(PointId(0)), Value::point(&b.points[0]))
        .unwrap();
    let xy = b.cam.project(&b.poses[0], &b.points[0]).unwrap();
    let f = ImagePoint::new(b.cam, ImageId(0), PointId(0), xy);
    d.add_factor(f, Noise::isotropic(2, PX), Loss::Huber(2.0), Group(0))
        .unwrap();
    assert!(d.solve().is_err());
    // Bad construction: a factor naming an unknown block, a key added twice.
    let f = ImagePoint::new(b.cam, ImageId(0), PointId(1), xy);
    let e = d.add_factor(f, Noise::isotropic(2, PX), Loss::Trivial, Group(0));
    assert!(e.unwrap_err().to_string().contains("point 1"));
    let e = d.add_block(Key::Point(PointId(0)), Value::point(&b.points[0]));
    assert!(e.unwrap_err().to_string().contains("twice"));
}

#[test]
fn bal_files_with_bad_numbers_are_refused() {
    let dir = testkit::scratch_dir("bad_numbers");
    let f = dir.join("nan.txt");
    std::fs::write(&f, "1 1 1\n0 0 1.0 NaN\n0 0 0 0 0 -1 500 0 0\n1 2 3\n").unwrap();
    let e = photo::bal::BalProblem::read(&f).unwrap_err().to_string();
    assert!(e.contains("nan.txt") && e.contains("not finite"), "{e}");
    std::fs::write(&f, "1 1 1\n0 3 1.0 2.0\n").unwrap();
    let e = photo::bal::BalProblem::read(&f).unwrap_err().to_string();
    assert!(e.contains("point 3"), "{e}");
}

/// A robust loss keeps blunders from dragging the block: with 5 blunders and no snooping, the
/// points come out closer to the truth under Huber and Cauchy than under plain least squares.
#[test]
fn robust_losses_resist_blunders() {
    let b = block();
    let point_rms = |loss: Loss| -> f64 {
        let (mut p, _, _) = problem_with(&b, |_| PX, |_| 0, 5, loss);
        p.solve().unwrap();
        let e: Vec<f64> = b
            .points
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let v = p.value(Key::Point(PointId::from(k))).unwrap();
                (v.as_point().unwrap() - t).norm_squared()
            })
            .collect();
        (e.iter().sum::<f64>() / e.len() as f64).sqrt()
    };
    let (plain, huber, cauchy) = (
        point_rms(Loss::Trivial),
        point_rms(Loss::Huber(2.0)),
        point_rms(Loss::Cauchy(2.0)),
    );
    eprintln!(
        "point RMS with 5 blunders: least squares {:.1} mm, Huber {:.1} mm, Cauchy {:.1} mm",
        plain * 1e3,
        huber * 1e3,
        cauchy * 1e3
    );
    assert!(huber < plain && cauchy < plain, "{plain} {huber} {cauchy}");
}

/// The sparse reduced system (faer, symbolic factorisation kept) gives the dense answer.
#[test]
fn sparse_and_dense_reduced_systems_agree() {
    let b = block();
    let (mut dense, _, _) = problem(&b, |_| PX, |_| 0, 0);
    let (mut sparse, _, _) = problem(&b, |_| PX, |_| 0, 0);
    sparse.options.dense_limit = 0;
    let a = dense.solve().unwrap();
    let s = sparse.solve().unwrap();
    assert!(
        (a.sigma0 - s.sigma0).abs() < 1e-9 * a.sigma0,
        "{} {}",
        a.sigma0,
        s.sigma0
    );
    for k in dense.keys().to_vec() {
        if let (Some(x), Some(y)) = (
            dense.value(k).and_then(Value::vector),
            sparse.value(k).and_then(Value::vector),
        ) {
            assert!((x - y).norm() < 1e-6, "{x} {y}");
        }
    }
}

/// The statistics through the Schur complement (reduced inverse + per-point blocks) equal
/// those from the full inverse normal matrix (points not eliminated).
#[test]
fn schur_cofactors_equal_the_full_inverse() {
    let b = block();
    let (mut schur, _, _) = problem(&b, |_| PX, |_| 0, 0);
    let (mut full, _, _) = problem(&b, |_| PX, |_| 0, 0);
    full.options.eliminate = Vec::new();
    let s0 = schur.solve().unwrap().sigma0;
    full.solve().unwrap();
    assert_eq!(schur.options.eliminate, vec![KeyKind::Point]);
    let probe: Vec<Key> = [0, 4, 8]
        .map(|i| Key::Pose(ImageId(i)))
        .into_iter()
        .chain([0, 51, 191, 339].map(|k| Key::Point(PointId(k))))
        .collect();
    let a = schur.covariances(&probe, s0).unwrap();
    let c = full.covariances(&probe, s0).unwrap();
    for (x, y) in a.iter().zip(&c) {
        let (x, y) = (x.as_ref().unwrap(), y.as_ref().unwrap());
        assert!((x - y).norm() < 1e-6 * y.norm(), "{x} {y}");
    }
    let ra = schur.reliability().unwrap();
    let rc = full.reliability().unwrap();
    assert_eq!(ra.len(), rc.len());
    for (x, y) in ra.iter().zip(&rc) {
        assert!((&x.redundancy - &y.redundancy).amax() < 1e-6);
        assert!((&x.normalised - &y.normalised).amax() < 1e-5);
    }
}

/// The Schur complement for any block size: eliminating the 6-D poses instead of the 3-D
/// points gives the same solution (to the convergence tolerance: the same cost to 1e-14),
/// σ0 and covariances (the reduced system is then over the points, solved sparse).
#[test]
fn eliminating_poses_instead_of_points_gives_the_same_adjustment() {
    let b = block();
    let (mut points, _, _) = problem(&b, |_| PX, |_| 0, 0);
    let (mut poses, _, _) = problem(&b, |_| PX, |_| 0, 0);
    poses.options.eliminate = vec![KeyKind::Pose];
    poses.options.dense_limit = 0; // the reduced system over the points goes sparse
    let a = points.solve().unwrap();
    let c = poses.solve().unwrap();
    assert!((a.sigma0 - c.sigma0).abs() < 1e-9 * a.sigma0, "{a:?} {c:?}");
    assert!((a.final_cost - c.final_cost).abs() < 1e-9 * a.final_cost);
    for k in points.keys().to_vec() {
        let (x, y) = (points.value(k).unwrap(), poses.value(k).unwrap());
        match (x, y) {
            (Value::Pose(p), Value::Pose(q)) => {
                let (dc, dr) = ((p.centre - q.centre).norm(), (p.r - q.r).norm());
                assert!(dc < 1e-5 && dr < 1e-8, "{k:?}: {dc} {dr}")
            }
            (Value::Vector(p), Value::Vector(q)) => assert!((p - q).norm() < 1e-5, "{k:?}"),
            _ => unreachable!(),
        }
    }
    let probe = [Key::Pose(ImageId(4)), Key::Point(PointId(100))];
    let ca = points.covariances(&probe, a.sigma0).unwrap();
    let cc = poses.covariances(&probe, c.sigma0).unwrap();
    for (x, y) in ca.iter().zip(&cc) {
        let (x, y) = (x.as_ref().unwrap(), y.as_ref().unwrap());
        assert!((x - y).norm() < 1e-6 * y.norm(), "{x} {y}");
    }
}
