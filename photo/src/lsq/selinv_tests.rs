//! The selected inverse against the dense one on a block of 10 strips × 20 images with
//! GNSS centres and one offset shared by all of them (a dense global block).

use crate::camera::{Camera, Pose};
use crate::factors::{ImagePoint, Prior};
use crate::lsq::{
    CameraId, Factor, Group, ImageId, Key, Loss, Noise, Options, Params, PointId, Problem,
    SolveError, Value,
};
use crate::rotation::Angles;
use nalgebra::{DMatrix, DMatrixViewMut, Vector2, Vector3};

/// A GNSS centre with an offset common to all images: r = c + o − z.
struct Centre {
    keys: [Key; 2],
    z: Vector3<f64>,
}

impl Factor for Centre {
    crate::keys_in_field!();
    fn dim(&self) -> usize {
        3
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let (Some(p), Some(o)) = (x.pose(0), x.vector(1)) else {
            return false;
        };
        for i in 0..3 {
            r[i] = p.centre[i] + o[i] - self.z[i];
        }
        if let Some(m) = &mut j[0] {
            m.fill(0.0);
            for i in 0..3 {
                m[(i, 3 + i)] = 1.0;
            }
        }
        if let Some(m) = &mut j[1] {
            m.fill_with_identity();
        }
        true
    }
}

/// The block, adjusted with the given dense limit, with control points or without (a datum
/// defect: the common offset and the centres cannot be told apart).
fn block(dense_limit: usize, control: bool) -> Problem {
    let cam = Camera::ideal(0.035, 3.9e-6, 6000, 4000);
    let mut p = Problem::new(Options {
        dense_limit,
        ..Options::default()
    });
    let (strips, per) = (10, 20);
    let mut poses = Vec::new();
    for s in 0..strips {
        for i in 0..per {
            let pose = Pose {
                r: Angles::OmegaPhiKappa {
                    omega: 0.002 * (i % 3) as f64,
                    phi: -0.001 * (s % 2) as f64,
                    kappa: 0.01,
                }
                .matrix(),
                centre: Vector3::new(40.0 * i as f64, 60.0 * s as f64, 350.0),
            };
            let id = ImageId::from(poses.len());
            p.add_block(Key::Pose(id), Value::Pose(pose)).ok();
            poses.push(pose);
        }
    }
    let lever = Key::LeverArm(CameraId(0));
    p.add_block(lever, Value::Vector(nalgebra::DVector::zeros(3)))
        .ok();
    let mut k = 0;
    for gx in 0..(per * 2) {
        for gy in 0..(strips * 3) {
            let x = Vector3::new(
                20.0 * gx as f64 - 40.0,
                20.0 * gy as f64 - 40.0,
                ((gx * 7 + gy * 3) % 11) as f64,
            );
            let seen: Vec<(usize, Vector2<f64>)> = poses
                .iter()
                .enumerate()
                .filter_map(|(c, pose)| {
                    let xy = cam.project(pose, &x)?;
                    let px = cam.image_to_pixel(xy);
                    let inside = px.x >= 0.0 && px.y >= 0.0 && px.x < 6000.0 && px.y < 4000.0;
                    inside.then_some((c, xy))
                })
                .collect();
            if seen.len() < 2 {
                continue;
            }
            let id = PointId::from(k);
            k += 1;
            p.add_block(Key::Point(id), Value::point(&x)).ok();
            for (c, xy) in seen {
                let f = ImagePoint::new(cam, ImageId::from(c), id, xy);
                p.add_factor(f, Noise::isotropic(2, 3.9e-6), Loss::Trivial, Group(0))
                    .ok();
            }
            if control && k % 97 == 0 {
                let f = Prior::point(id, x);
                p.add_factor(f, Noise::isotropic(3, 0.02), Loss::Trivial, Group(1))
                    .ok();
            }
        }
    }
    for (c, pose) in poses.iter().enumerate() {
        let f = Centre {
            keys: [Key::Pose(ImageId::from(c)), lever],
            z: pose.centre,
        };
        p.add_factor(f, Noise::isotropic(3, 0.05), Loss::Trivial, Group(2))
            .ok();
    }
    p
}

/// Whether `x` equals `y` within `tol` of the scale of each entry (√(yᵢᵢ·yⱼⱼ) for a
/// cofactor block whose own diagonals are `da`, `db`).
fn close(x: &DMatrix<f64>, y: &DMatrix<f64>, da: &[f64], db: &[f64], tol: f64) -> bool {
    x.shape() == y.shape()
        && (0..y.nrows()).all(|i| {
            (0..y.ncols()).all(|j| (x[(i, j)] - y[(i, j)]).abs() <= tol * (da[i] * db[j]).sqrt())
        })
}

/// Every cofactor block the statistics read (between blocks sharing a factor or a point,
/// and of every point), a few outside the pattern, every redundancy number: the selected
/// inverse (sparse path forced) equals the dense inverse to 1e-9 of each entry's scale.
#[test]
fn selected_inverse_equals_the_dense_inverse() {
    let (mut dense, mut sparse) = (block(usize::MAX, true), block(100, true));
    let (a, b) = (dense.solve(), sparse.solve());
    let (Ok(a), Ok(b)) = (a, b) else {
        panic!("the block does not solve");
    };
    assert_eq!(a.unknowns, b.unknowns);
    let (qd, qs) = (dense.cofactors(), sparse.cofactors());
    let (Ok(qd), Ok(qs)) = (qd, qs) else {
        panic!("no cofactors");
    };
    let st = &qd.st;
    assert!(st.nr > 1000 && st.nr <= 3000, "{}", st.nr);
    let diag: Vec<Vec<f64>> = st
        .cblocks
        .iter()
        .map(|&b| {
            qd.cross(b, b)
                .map(|m| m.diagonal().iter().copied().collect())
        })
        .collect::<Option<_>>()
        .unwrap_or_default();
    let check = |ca: usize, cb: usize| {
        let (ba, bb) = (st.cblocks[ca], st.cblocks[cb]);
        let (x, y) = (qs.cross(ba, bb), qd.cross(ba, bb));
        let (Some(x), Some(y)) = (x, y) else {
            return false;
        };
        close(&x, &y, &diag[ca], &diag[cb], 1e-9)
    };
    let mut pairs = 0;
    for eb in &st.eblocks {
        let nb = st.nbrs(eb);
        for &ca in nb {
            for &cb in nb {
                assert!(check(ca, cb), "blocks {ca} {cb}");
                pairs += 1;
            }
        }
        let (x, y) = (qs.block(eb.block, eb.dim), qd.block(eb.block, eb.dim));
        let (Some(x), Some(y)) = (x, y) else {
            panic!("no point cofactors");
        };
        let d: Vec<f64> = y.diagonal().iter().copied().collect();
        assert!(close(&x, &y, &d, &d, 1e-9), "{x} {y}");
    }
    assert!(pairs > 10_000, "{pairs}");
    // Outside the pattern (first and last strips), and the shared offset with all.
    let nc = st.cblocks.len();
    for (ca, cb) in [(0, nc - 2), (5, nc - 7), (nc - 1, 0), (nc - 1, nc / 2)] {
        assert!(check(ca, cb), "blocks {ca} {cb}");
    }
    for k in 0..st.active.len() {
        let (x, y) = (qs.hat_diag(k), qd.hat_diag(k));
        assert!((x - y).amax() < 1e-9, "factor {k}");
    }
}

/// A datum defect on the sparse path is an error value naming a block, never a panic.
#[test]
fn sparse_datum_defect_is_an_error() {
    match block(100, false).solve() {
        Err(SolveError::Dependent(_)) => {}
        other => panic!("{other:?}"),
    }
}

/// The residual correlations of data snooping (`correl`): on the diagonal they give back
/// the hat matrix's diagonal (1 − r), and the sparse path gives the dense path's values.
#[test]
fn residual_correlations_agree() {
    let (mut dense, mut sparse) = (block(usize::MAX, true), block(100, true));
    let (Ok(_), Ok(_)) = (dense.solve(), sparse.solve()) else {
        panic!("the block does not solve");
    };
    let (Ok(qd), Ok(qs)) = (dense.cofactors(), sparse.cofactors()) else {
        panic!("no cofactors");
    };
    let (Ok(rd), Ok(rs)) = (dense.reliability(), sparse.reliability()) else {
        panic!("no reliability");
    };
    let n = qd.st.active.len();
    // Image points here and there, and GNSS centres (the last factors).
    let ks: Vec<usize> = (0..12)
        .map(|i| i * 97 % (n - 200))
        .chain([n - 1, n - 50])
        .collect();
    let r: Vec<_> = ks.iter().map(|&k| &rd[k].redundancy).collect();
    let (Some(cd), Some(cs)) = (qd.correlations(&ks, &r), qs.correlations(&ks, &r)) else {
        panic!("no correlations");
    };
    for (j, &k) in ks.iter().enumerate() {
        let h = qd.hat_diag(k);
        for a in 0..h.len() {
            let back = cd[j][j][(a, a)] * r[j][a];
            assert!((back - h[a].abs()).abs() < 1e-9, "{k} {a}: {back} {}", h[a]);
        }
        for i in 0..ks.len() {
            assert!((&cd[j][i] - &cs[j][i]).amax() < 1e-7, "{i} {j}");
        }
    }
    assert!((&rd[5].normalised - &rs[5].normalised).amax() < 1e-7);
}

/// The sparse statistics are the same bits whatever the thread count.
#[test]
fn selected_inverse_ignores_the_thread_count() {
    let run = |threads: usize| {
        let mut p = block(100, true);
        p.options.threads = Some(threads);
        p.solve().ok()?;
        let rel = p.reliability().ok()?;
        let key = Key::LeverArm(CameraId(0));
        let cov = p.covariance(key, 1.0).ok()??;
        Some((rel, cov))
    };
    let (Some(a), Some(b)) = (run(1), run(3)) else {
        panic!("no statistics");
    };
    assert_eq!(a, b);
}

/// The one-block test data snooping asks after each removal agrees with the test of the
/// whole problem: on the block above (used here for its mix of poses, points and a shared
/// offset), with every third point's rays but one removed and one image's last points
/// removed, the same blocks are undetermined.
#[test]
fn one_block_determinedness_agrees_with_the_whole_problem() {
    let mut p = block(3000, true);
    let mut by_point: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (k, e) in p.model.entries.iter().enumerate() {
        if let Some(&b) = e
            .blocks
            .iter()
            .find(|&&b| matches!(p.model.keys[b], Key::Point(_)))
        {
            if e.blocks.len() == 2 {
                by_point.entry(b).or_default().push(k);
            }
        }
    }
    for (n, (_, rays)) in by_point.iter().enumerate() {
        if n % 3 == 0 {
            for &k in &rays[1..] {
                p.model.entries[k].removed = true;
            }
        }
    }
    // Image 0 keeps only two of its rays: its pose is not determined.
    let image0 = p.model.index[&Key::Pose(ImageId::from(0))];
    let rays0: Vec<usize> = (p.model.entries.iter().enumerate())
        .filter(|(_, e)| !e.removed && e.blocks.len() == 2 && e.blocks[0] == image0)
        .map(|(k, _)| k)
        .collect();
    assert!(rays0.len() > 3);
    for &k in &rays0[2..] {
        p.model.entries[k].removed = true;
    }
    let whole: Vec<Key> = p.undetermined().unwrap();
    let one: Vec<Key> = (0..p.model.keys.len())
        .filter(|&b| {
            !p.model.fixed[b] && !crate::lsq::lin::regular(p.model.block_normals(b).unwrap().0)
        })
        .map(|b| p.model.keys[b])
        .collect();
    assert!(whole.contains(&Key::Pose(ImageId::from(0))));
    assert!(whole.len() > 10, "{}", whole.len());
    let (mut a, mut b) = (whole.clone(), one.clone());
    a.sort_by_key(|k| format!("{k:?}"));
    b.sort_by_key(|k| format!("{k:?}"));
    assert_eq!(a, b);
}
