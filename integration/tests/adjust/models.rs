//! The block models beyond the classic case: self-calibration, drift per ambiguity segment,
//! float GNSS positions, measured distances (a new observation kind).

use super::*;

/// Self-calibration: the true camera has its principal distance 30 µm longer, the principal
/// point at (15, −10) µm and radial distortion of ~10 µm at the format edge; the project
/// gives the nominal camera. With f, x0, y0, k1 estimated they come back within 3σ and the
/// check points are as good as the adjustment says; without, they are not.
#[test]
fn self_calibration_recovers_the_camera() {
    let mut spec = BlockSpec::classic();
    spec.true_focal_delta_mm = 0.030;
    spec.true_principal_point_mm = [0.015, -0.010];
    spec.true_k1 = 6.5e-3;
    spec.project_options = gnss_options("linear");
    let (_, plain) = run(&spec, "selfcal-off");
    spec.camera_options = "self_calibrate = [\"f\", \"x0\", \"y0\", \"k1\"]\n".into();
    let (_, cal) = run(&spec, "selfcal-on");
    let i = &cal.interiors[0];
    let truth = [0.152030, 0.000015, -0.000010, 6.5e-3];
    for (k, t) in truth.iter().enumerate() {
        let z = (i.values[k] - t) / i.sigmas[k];
        assert!(
            z.abs() < 3.0,
            "{}: {} ± {} (truth {t})",
            i.labels[k],
            i.values[k],
            i.sigmas[k],
        );
    }
    let rms3 = |r: &Results| (r.checks.rms.iter().map(|x| x * x).sum::<f64>()).sqrt();
    let theo3 = |r: &Results| (r.checks.theoretical_rms.iter().map(|x| x * x).sum::<f64>()).sqrt();
    eprintln!(
        "self-calibration: f {:.4} ± {:.4} mm, x0 {:.1} ± {:.1} µm, y0 {:.1} ± {:.1} µm, k1 {:.2e} ± {:.1e}; check 3D RMS {:.3} m (theoretical {:.3}) vs {:.3} m without",
        i.values[0] * 1e3, i.sigmas[0] * 1e3, i.values[1] * 1e6, i.sigmas[1] * 1e6, i.values[2] * 1e6, i.sigmas[2] * 1e6, i.values[3], i.sigmas[3],
        rms3(&cal), theo3(&cal), rms3(&plain)
    );
    assert!(rms3(&cal) < 1.5 * theo3(&cal));
    assert!(
        plain.sigma0 > 1.2 * cal.sigma0 || rms3(&plain) > 1.5 * rms3(&cal),
        "σ0 {} vs {}",
        plain.sigma0,
        cal.sigma0
    );
}

/// Drift per ambiguity segment: the trajectory re-fixed its ambiguities in the middle of strip
/// 1, and the antenna positions after that carry another bias (25, −20, 35 cm). A drift offset
/// per segment (ids from the PPK output) absorbs it; one offset per block cannot.
#[test]
fn drift_per_ambiguity_segment() {
    let mut spec = BlockSpec::classic();
    spec.drift_b = [0.0; 3];
    spec.segment_jump = Some((8, [0.25, -0.20, 0.35]));
    spec.project_options =
        gnss_options("offset").replace("drift = \"block\"", "drift = \"segment\"");
    let (_, seg) = run(&spec, "segments");
    spec.project_options = gnss_options("offset");
    let (_, block) = run(&spec, "segments-block");
    assert_eq!(seg.drifts.len(), 2);
    let (d0, d1) = (&seg.drifts[0], &seg.drifts[1]);
    assert_eq!(
        (d0.name.as_str(), d1.name.as_str()),
        ("segment 0", "segment 1")
    );
    for a in 0..3 {
        let jump = d1.values[a] - d0.values[a];
        let sigma = d1.sigmas[a].hypot(d0.sigmas[a]);
        let truth = [0.25, -0.20, 0.35][a];
        assert!(
            (jump - truth).abs() < 3.0 * sigma,
            "axis {a}: jump {jump} ± {sigma}"
        );
    }
    let g = |r: &Results| {
        r.groups
            .iter()
            .find(|g| g.group == "GNSS centres")
            .unwrap()
            .sigma_factor
    };
    let rms3 = |r: &Results| (r.checks.rms.iter().map(|x| x * x).sum::<f64>()).sqrt();
    let theo3 = |r: &Results| (r.checks.theoretical_rms.iter().map(|x| x * x).sum::<f64>()).sqrt();
    eprintln!(
        "segments: check 3D RMS {:.3} m (theoretical {:.3}), GNSS σ factor {:.2}; one offset per block: {:.3} m (theoretical {:.3}), σ factor {:.2}, {} removed",
        rms3(&seg), theo3(&seg), g(&seg), rms3(&block), theo3(&block), g(&block), block.removed.len()
    );
    assert!(rms3(&seg) < 1.5 * theo3(&seg));
    assert!(rms3(&block) > 1.3 * rms3(&seg));
    // The same bias from the first photograph of strip 2 on: one offset per strip absorbs it.
    spec.segment_jump = Some((15, [0.25, -0.20, 0.35]));
    spec.project_options = gnss_options("offset").replace("drift = \"block\"", "drift = \"strip\"");
    let (_, strip) = run(&spec, "segments-strip");
    let (s1, s2) = (&strip.drifts[0], &strip.drifts[1]);
    assert_eq!((s1.name.as_str(), s2.name.as_str()), ("strip 1", "strip 2"));
    for a in 0..3 {
        let jump = s2.values[a] - s1.values[a];
        let sigma = s2.sigmas[a].hypot(s1.sigmas[a]);
        let truth = [0.25, -0.20, 0.35][a];
        assert!(
            (jump - truth).abs() < 3.0 * sigma,
            "strip axis {a}: jump {jump} ± {sigma}"
        );
    }
    assert!(rms3(&strip) < 1.5 * theo3(&strip));
}

/// Float GNSS positions are used with their covariance, and the report says how many.
#[test]
fn float_positions_are_reported() {
    let dir = project_dir("float");
    edit(&dir, "antennas.csv", |t| {
        t.lines()
            .map(|l| {
                if l.starts_with("103,") || l.starts_with("207,") {
                    l.replace(",1,0", ",2,0")
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    });
    let r = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap();
    assert!(
        r.warnings.iter().any(
            |w| w.starts_with("2 of 29 GNSS positions are not ambiguity-fixed")
                && w.contains("103, 207")
        ),
        "{:?}",
        r.warnings
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A new observation kind through the project file: distances between points (the factor is
/// `photo::factors::Distance`; the solver was not touched to add it). Measured at 5 cm — about
/// the block's own relative precision, so each is controlled by the images (r ≈ 0.5) — a good
/// distance fits; one 1 m off is found and removed by data snooping, named with its file line.
#[test]
fn measured_distances_join_the_adjustment() {
    let dir = tmp("distances");
    let mut spec = BlockSpec::classic();
    spec.project_options = gnss_options("linear");
    let truth = block::aerial(&spec, &dir).unwrap();
    let of = |kind: &str| -> Vec<&(String, &'static str, nalgebra::Vector3<f64>)> {
        truth.points.iter().filter(|p| p.1 == kind).collect()
    };
    // Tie points: check points never enter the adjustment.
    let checks = of("tie");
    let d = |a: &(String, &str, nalgebra::Vector3<f64>),
             b: &(String, &str, nalgebra::Vector3<f64>)| { (a.2 - b.2).norm() };
    let good = d(checks[0], checks[1]);
    let wrong = d(checks[2], checks[3]) + 1.0;
    std::fs::write(
        dir.join("distances.csv"),
        format!(
            "point_a,point_b,distance,sigma\n{},{},{good:.4},0.05\n{},{},{wrong:.4},0.05\n",
            checks[0].0, checks[1].0, checks[2].0, checks[3].0
        ),
    )
    .unwrap();
    edit(&dir, "project.toml", |t| {
        t.replace(
            "file = \"ground_points.csv\"",
            "file = \"ground_points.csv\"\ndistances = \"distances.csv\"",
        )
    });
    let r = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!(
        "distances: kept {:?}; removed {:?}",
        r.distance_residuals, r.removed
    );
    let removed: Vec<_> = r.removed.iter().filter(|x| x.kind == "distance").collect();
    assert_eq!(removed.len(), 1, "{:?}", r.removed);
    assert!(removed[0].what.contains(&checks[2].0) && removed[0].source.ends_with(":3"));
    assert!(removed[0].w > 10.0, "{:?}", removed[0]);
    assert_eq!(r.distance_residuals.len(), 1);
    let g = &r.distance_residuals[0];
    assert!(
        g.points[0] == checks[0].0 && g.v.abs() < 3.0 * 0.05,
        "{g:?}"
    );
    assert!(g.r > 0.2 && g.w.abs() < r.critical_w, "{g:?}");
    assert!(r
        .groups
        .iter()
        .any(|q| q.group == "distances" && q.observations == 1));
    // The adjusted check points agree with the measured distance (v is adjusted − measured).
    let pos = |id: &str| r.points.iter().find(|p| p.id == id).unwrap().position.local;
    let (a, b) = (pos(&checks[0].0), pos(&checks[1].0));
    let adjusted = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    assert!(
        (adjusted - good - g.v).abs() < 1e-4,
        "{adjusted} vs {good} + {}",
        g.v
    );
}
