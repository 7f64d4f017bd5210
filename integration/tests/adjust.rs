//! The joint GNSS-supported adjustment on simulated blocks with known truth: the classic
//! 2-strip block with and without control, blunders, a close-range pair, bad input.

use integration::adjust::{self, results::Results};
use integration::simulate::block::{self, BlockSpec, BlockTruth};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ppkat-adjust-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn run(spec: &BlockSpec, name: &str) -> (BlockTruth, Results) {
    let dir = tmp(name);
    let truth = block::aerial(spec, &dir).unwrap();
    let res = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    (truth, res)
}

/// The tape-measured lever arm: truth + (1.5, −1.0, 1.5) cm, σ 2 cm.
fn gnss_options(drift_model: &str) -> String {
    block::gnss_section(
        &BlockSpec::classic(),
        block::TAPE_ERROR,
        "block",
        drift_model,
    )
}

/// One case over several seeds: the pooled check-point RMS against the pooled theoretical
/// RMS per axis, lever-arm errors, drift errors in σ.
struct Summary {
    ratio: [f64; 3],
    rms: [f64; 3],
    theo: [f64; 3],
    worst_lever: f64,
    lever_rms: [f64; 3],
    lever_sigma: [f64; 3],
    drift_z: Vec<f64>,
    /// Mean square of (ω, φ, κ error)/σ over all images and realisations.
    angle_z2: [f64; 3],
    removed: usize,
}

fn monte_carlo(gcps: bool, seeds: std::ops::Range<u64>) -> Summary {
    let (mut e2, mut t2, mut n) = ([0.0; 3], [0.0; 3], 0.0);
    let mut worst_lever: f64 = 0.0;
    let (mut l2, mut ls) = ([0.0; 3], [0.0; 3]);
    let mut drift_z = Vec::new();
    let mut removed = 0;
    let mut runs = 0.0;
    let (mut az2, mut an) = ([0.0; 3], 0.0);
    for seed in seeds {
        let mut spec = BlockSpec::classic();
        spec.seed = seed;
        spec.corner_gcps = gcps;
        if !gcps {
            // Without control a constant GNSS offset is a datum shift nobody can see: the
            // simulated drift starts at zero and only its rate is estimated.
            spec.drift_a = [0.0; 3];
        }
        spec.project_options = gnss_options(if gcps { "linear" } else { "rate" });
        // The statistics of the estimator itself: no reweighting, no removal.
        spec.project_options += "[adjustment]\nvariance_components = false\nsnooping = false\n";
        let (truth, r) = run(&spec, &format!("mc-{gcps}-{seed}"));
        assert_eq!(truth.images.len(), 29);
        let c = &r.checks;
        let k = c.points.len() as f64;
        assert!(k >= 30.0, "{k} check points");
        for a in 0..3 {
            e2[a] += c.rms[a].powi(2) * k;
            t2[a] += c.theoretical_rms[a].powi(2) * k;
        }
        n += k;
        for (i, l) in r.lever_arms[0].values.iter().enumerate() {
            worst_lever = worst_lever.max((l - spec.lever_arm[i]).abs());
            l2[i] += (l - spec.lever_arm[i]).powi(2);
            ls[i] += r.lever_arms[0].sigmas[i].powi(2);
        }
        runs += 1.0;
        let d = &r.drifts[0];
        let dt = d.t0 - truth.t_first;
        for a in 0..3 {
            let b_true = spec.drift_b[a];
            if d.values.len() == 6 {
                let a_true = spec.drift_a[a] + b_true * dt;
                drift_z.push((d.values[a] - a_true) / d.sigmas[a]);
                drift_z.push((d.values[a + 3] - b_true) / d.sigmas[a + 3]);
            } else {
                drift_z.push((d.values[a] - b_true) / d.sigmas[a]);
            }
        }
        removed += r.removed.len();
        // Orientation angles against truth, the truth rotated into the adjustment's frame.
        let o = r.origin_deg;
        let frame = gnss::frame::Geodetic::from_degrees(o[0], o[1], o[2]);
        let f = gnss::frame::enu_rotation(&frame)
            * gnss::frame::enu_rotation(&truth.origin).transpose();
        for (im, (_, _, pose, _)) in r.images.iter().zip(&truth.images) {
            let photo::rotation::Angles::OmegaPhiKappa { omega, phi, kappa } =
                photo::rotation::Angles::omega_phi_kappa(&(f * pose.r))
            else {
                unreachable!()
            };
            for (a, t) in [omega, phi, kappa].iter().enumerate() {
                let d = (im.opk_deg[a] - t.to_degrees() + 180.0).rem_euclid(360.0) - 180.0;
                az2[a] += (d / im.sigma_angles_deg[a]).powi(2);
            }
            an += 1.0;
        }
    }
    let rms = e2.map(|x| (x / n).sqrt());
    let theo = t2.map(|x| (x / n).sqrt());
    Summary {
        ratio: [0, 1, 2].map(|a| rms[a] / theo[a]),
        rms,
        theo,
        worst_lever,
        lever_rms: l2.map(|x| (x / runs).sqrt()),
        lever_sigma: ls.map(|x| (x / runs).sqrt()),
        drift_z,
        angle_z2: az2.map(|x| x / an),
        removed,
    }
}

fn check(s: &Summary, what: &str) {
    eprintln!(
        "{what}: check RMS E/N/U {:.3} {:.3} {:.3} m, theoretical {:.3} {:.3} {:.3} m, ratio {:.2} {:.2} {:.2}; worst lever-arm error {:.4} m; lever-arm error RMS {:.4} {:.4} {:.4} m (σ {:.4} {:.4} {:.4}); drift |z| max {:.2}; removed {}",
        s.rms[0], s.rms[1], s.rms[2], s.theo[0], s.theo[1], s.theo[2], s.ratio[0], s.ratio[1], s.ratio[2],
        s.worst_lever, s.lever_rms[0], s.lever_rms[1], s.lever_rms[2], s.lever_sigma[0], s.lever_sigma[1], s.lever_sigma[2], s.drift_z.iter().fold(0.0f64, |m, z| m.max(z.abs())), s.removed
    );
    for a in 0..3 {
        assert!(
            s.ratio[a] < 1.2 && s.ratio[a] > 0.7,
            "{what}: check-point RMS / theoretical = {:?}",
            s.ratio
        );
    }
    // The 2-strip block cannot separate the lever arm from drift and datum much better than
    // its tape prior (σ 2 cm, the tape 1–1.5 cm off): the estimate must stay within 2 cm RMS
    // and its σ must say how weak it is.
    for a in 0..3 {
        assert!(
            s.lever_rms[a] < 0.02,
            "{what}: lever-arm error RMS {:?}",
            s.lever_rms
        );
        assert!(
            s.lever_sigma[a] > 0.5 * s.lever_rms[a],
            "{what}: lever-arm σ {:?} too optimistic",
            s.lever_sigma
        );
    }
    let within2 =
        s.drift_z.iter().filter(|z| z.abs() < 2.0).count() as f64 / s.drift_z.len() as f64;
    let mean_sq = s.drift_z.iter().map(|z| z * z).sum::<f64>() / s.drift_z.len() as f64;
    eprintln!(
        "{what}: drift parameters within 2σ of truth: {:.1} %, mean square of error/σ {mean_sq:.2}",
        within2 * 100.0
    );
    assert!(
        within2 >= 0.85,
        "{what}: drift within 2σ in {:.0} % only",
        within2 * 100.0
    );
    assert!(
        mean_sq < 1.6,
        "{what}: drift errors/σ mean square {mean_sq}"
    );
    eprintln!(
        "{what}: mean square of angle error/σ (ω, φ, κ): {:.2} {:.2} {:.2}",
        s.angle_z2[0], s.angle_z2[1], s.angle_z2[2]
    );
    for z2 in s.angle_z2 {
        assert!(
            z2 > 0.6 && z2 < 1.5,
            "{what}: angle errors/σ {:?}",
            s.angle_z2
        );
    }
    assert_eq!(s.removed, 0, "{what}: good observations removed");
}

/// Classic block, 4 corner GCPs, linear drift per block, 64 noise realisations (a block's
/// check-point errors are dominated by a few common modes, so one realisation says little).
#[test]
fn classic_block_with_four_corner_gcps() {
    let s = monte_carlo(true, 101..165);
    check(&s, "4 GCPs");
}

/// Classic block without any control: GNSS centres carry the datum.
#[test]
fn classic_block_without_gcps() {
    let s = monte_carlo(false, 101..165);
    check(&s, "no GCP");
}

/// Five image blunders (6–12 px, 12–24 σ) and one wrong control point, default options (variance components,
/// data snooping at 5 % family-wise): exactly those six are removed.
#[test]
fn blunders_and_a_wrong_gcp_are_found() {
    let mut spec = BlockSpec::classic();
    spec.image_blunders = 5;
    // A control point 1 m off in height (a wrong antenna height in its survey): about twice
    // the minimal detectable blunder of a control point in this block (≈ 0.5 m).
    spec.wrong_gcp = Some([0.0, 0.0, 1.0]);
    spec.project_options = gnss_options("linear");
    let (truth, r) = run(&spec, "blunders");
    let mut found: Vec<String> = r.removed.iter().map(|x| x.what.clone()).collect();
    found.sort();
    let mut want: Vec<String> = truth
        .blunders
        .iter()
        .map(|(im, pt)| format!("point {pt} in image {im}"))
        .collect();
    want.push(format!(
        "control point {} (kept as a tie point)",
        truth.wrong_gcp.clone().unwrap()
    ));
    want.sort();
    assert_eq!(want.len(), 6);
    assert_eq!(
        found, want,
        "critical {} removed: {:#?}",
        r.critical_w, r.removed
    );
    // After the removals the block is as good as a clean one.
    assert!((r.sigma0 - 1.0).abs() < 0.1, "σ0 {}", r.sigma0);
    for a in 0..3 {
        assert!(
            r.checks.rms[a] < 2.0 * r.checks.theoretical_rms[a],
            "{:?}",
            r.checks
        );
    }
    // Reliability is reported per group, with the minimal detectable blunders.
    let img = r.groups.iter().find(|g| g.group == "image points").unwrap();
    assert!(
        img.mean_redundancy > 0.2 && img.mean_redundancy < 0.8,
        "{img:?}"
    );
    assert!(img.max_mdb > 1.0 && img.max_mdb < 50.0, "{img:?}");
    // Per observation: what remains passes the test; the control's MDB says which GCP errors
    // this block can see (the 1 m one was well above it).
    let wmax = r
        .image_residuals
        .iter()
        .flat_map(|v| v.w)
        .fold(0.0f64, |m, w| m.max(w.abs()));
    assert!(wmax < r.critical_w, "{wmax}");
    assert_eq!(r.control_residuals.len(), 3);
    for c in &r.control_residuals {
        for m in c.mdb {
            let m = m.expect("a control point's MDB");
            assert!(m > 0.2 && m < 1.2, "{c:?}");
        }
    }
}

/// A written classic project to break in one way.
fn project_dir(name: &str) -> PathBuf {
    let dir = tmp(name);
    let mut spec = BlockSpec::classic();
    spec.project_options = gnss_options("linear");
    block::aerial(&spec, &dir).unwrap();
    dir
}

fn edit(dir: &std::path::Path, file: &str, f: impl Fn(&str) -> String) {
    let p = dir.join(file);
    let t = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, f(&t)).unwrap();
}

fn fails(dir: &std::path::Path) -> String {
    let e = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .err()
    .expect("must fail");
    assert!(
        !dir.join("out/report.json").exists(),
        "no output on failure"
    );
    e.to_string()
}

#[test]
fn bad_input_gives_clear_errors() {
    // A strip without GNSS: its antenna records are missing.
    let d = project_dir("bad-strip");
    edit(&d, "antennas.csv", |t| {
        t.lines()
            .filter(|l| !l.starts_with('2'))
            .collect::<Vec<_>>()
            .join("\n")
    });
    let e = fails(&d);
    assert!(e.contains("strip 2 (14 images) without any GNSS"), "{e}");
    // An image with no points.
    let d = project_dir("bad-image");
    edit(&d, "images.csv", |t| format!("{t}999,cam,1\n"));
    let e = fails(&d);
    assert!(e.contains("image(s) 999 have no measured points"), "{e}");
    // Control ids that are not in the measurements.
    let d = project_dir("bad-gcp");
    edit(&d, "ground_points.csv", |t| t.replacen("G2,", "G2x,", 1));
    let e = fails(&d);
    assert!(e.contains("G2x are not measured in any image"), "{e}");
    // A datum defect: no control, no GNSS.
    let d = project_dir("bad-datum");
    edit(&d, "project.toml", |t| {
        t[..t.find("[gnss]").unwrap()].to_string()
    });
    edit(&d, "ground_points.csv", |t| {
        t.lines()
            .filter(|l| !l.contains(",gcp,"))
            .collect::<Vec<_>>()
            .join("\n")
    });
    let e = fails(&d);
    assert!(
        e.contains("datum defect: 0 control point(s) and no GNSS"),
        "{e}"
    );
    // A measurement naming an unknown image: file and line.
    let d = project_dir("bad-meas");
    edit(&d, "image_observations.csv", |t| {
        format!("{t}777,T1,10,10,0.5\n")
    });
    let e = fails(&d);
    assert!(
        e.contains("image_observations.csv, line")
            && e.contains("image `777` is not in the image list"),
        "{e}"
    );
    // A coordinate that is not a finite number.
    let d = project_dir("bad-nan");
    edit(&d, "ground_points.csv", |t| {
        let mut l: Vec<String> = t.lines().map(String::from).collect();
        let f: Vec<&str> = l[1].split(',').collect();
        l[1] = format!("{},{},NaN,{}", f[0], f[1], f[3..].join(","));
        l.join("\n")
    });
    let e = fails(&d);
    assert!(
        e.contains("ground_points.csv, line 2") && e.contains("`NaN` is not a number"),
        "{e}"
    );
    // An unknown key in the project file.
    let d = project_dir("bad-key");
    edit(&d, "project.toml", |t| {
        t.replace("drift_model", "drift_modle")
    });
    let e = fails(&d);
    assert!(e.contains("drift_modle"), "{e}");
    for n in [
        "bad-strip",
        "bad-image",
        "bad-gcp",
        "bad-datum",
        "bad-meas",
        "bad-key",
    ] {
        let _ = std::fs::remove_dir_all(tmp(n));
    }
}

/// Close range: two stations 120 m apart, 380 m from the target, positions from GNSS,
/// compass angles 2° off refined by three-angle resection on 3 control points, then the
/// adjustment; check points reported as latitude/longitude/height differences.
#[test]
fn close_range_pair() {
    use integration::simulate::closerange::{close_range, CloseRangeSpec};
    let (mut e2, mut t2, mut n) = ([0.0; 3], [0.0; 3], 0.0);
    let mut worst_h: f64 = 0.0;
    for seed in 1..17u64 {
        let spec = CloseRangeSpec {
            seed,
            ..Default::default()
        };
        let dir = tmp(&format!("cr-{seed}"));
        close_range(&spec, &dir).unwrap();
        let r = adjust::run(
            &dir.join("project.toml"),
            &dir.join("out"),
            &Default::default(),
        )
        .unwrap();
        let c = &r.checks;
        assert_eq!(c.points.len(), 12);
        for a in 0..3 {
            e2[a] += c.rms[a].powi(2) * 12.0;
            t2[a] += c.theoretical_rms[a].powi(2) * 12.0;
        }
        n += 12.0;
        // The geodetic differences agree with the local ones (1″ of latitude ≈ 30.9 m).
        for q in &c.points {
            assert!(
                (q.dlat_arcsec * 30.87 - q.d[1]).abs() < 0.01 * q.d[1].abs().max(0.01) + 1e-3,
                "{q:?}"
            );
            assert!((q.dh - q.d[2]).abs() < 2e-3, "{q:?}");
            worst_h = worst_h.max(q.dh.abs());
        }
        if seed == 1 {
            let html = std::fs::read_to_string(dir.join("out/report.html")).unwrap();
            assert!(
                html.contains("Δlat ″") && html.contains("<svg"),
                "close-range report"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    let ratio: Vec<f64> = (0..3).map(|a| (e2[a] / t2[a]).sqrt()).collect();
    eprintln!(
        "close range: check RMS E/N/U {:.3} {:.3} {:.3} m, theoretical {:.3} {:.3} {:.3} m, worst |Δh| {worst_h:.3} m",
        (e2[0] / n).sqrt(), (e2[1] / n).sqrt(), (e2[2] / n).sqrt(), (t2[0] / n).sqrt(), (t2[1] / n).sqrt(), (t2[2] / n).sqrt()
    );
    for r in &ratio {
        assert!(*r < 1.25 && *r > 0.75, "check RMS / theoretical {ratio:?}");
    }
    // Three stations (−60, 0, +60 m): the middle one adds rays, the depth error shrinks.
    let spec = CloseRangeSpec {
        seed: 3,
        stations: vec![-60.0, 0.0, 60.0],
        ..Default::default()
    };
    let dir = tmp("cr-three");
    close_range(&spec, &dir).unwrap();
    let r = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap();
    assert_eq!(r.images.len(), 3);
    assert!(r.checks.theoretical_rms[1] < (t2[1] / n).sqrt());
    for a in 0..3 {
        assert!(
            r.checks.rms[a] < 2.0 * r.checks.theoretical_rms[a],
            "{:?}",
            r.checks
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

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
    for k in 0..4 {
        let z = (i.values[k] - truth[k]) / i.sigmas[k];
        assert!(
            z.abs() < 3.0,
            "{}: {} ± {} (truth {})",
            i.labels[k],
            i.values[k],
            i.sigmas[k],
            truth[k]
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

/// The same measurements as a PATB-style image-coordinate file (mm, y up) give the same
/// adjustment as the CSV in pixels.
#[test]
fn patb_measurements_equal_csv() {
    let dir = project_dir("patb");
    let csv = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out-csv"),
        &Default::default(),
    )
    .unwrap();
    let text = std::fs::read_to_string(dir.join("image_observations.csv")).unwrap();
    let (w, h, px) = (23000.0 / 2.0, 23000.0 / 2.0, 0.010);
    let mut by_image: std::collections::BTreeMap<String, Vec<String>> = Default::default();
    for l in text.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let (x, y): (f64, f64) = (f[2].parse().unwrap(), f[3].parse().unwrap());
        by_image.entry(f[0].to_string()).or_default().push(format!(
            "{} {:.4} {:.4}",
            f[1],
            (x - w) * px,
            (h - y) * px
        ));
    }
    let mut patb = String::new();
    for (im, rows) in &by_image {
        patb += &format!("{im}\n{}\n-99\n", rows.join("\n"));
    }
    std::fs::write(dir.join("block.im"), patb).unwrap();
    edit(&dir, "project.toml", |t| {
        t.replace(
            "measurements = \"image_observations.csv\"",
            "patb = \"block.im\"",
        )
    });
    let pat = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out-patb"),
        &Default::default(),
    )
    .unwrap();
    assert_eq!(pat.observations, csv.observations);
    for (a, b) in pat.points.iter().zip(&csv.points) {
        assert_eq!(a.id, b.id);
        for k in 0..3 {
            assert!(
                (a.local[k] - b.local[k]).abs() < 2e-3,
                "{} {:?} {:?}",
                a.id,
                a.local,
                b.local
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Ground points given as UTM easting/northing (with `crs`) or as ECEF x/y/z give the same
/// adjustment as latitude/longitude; `as_check` turns a control point into a check point.
#[test]
fn ground_point_formats_agree() {
    let dir = project_dir("formats");
    let base = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out-geo"),
        &Default::default(),
    )
    .unwrap();
    let text = std::fs::read_to_string(dir.join("ground_points.csv")).unwrap();
    let tm = gnss::tmerc::TransverseMercator::utm(50, true);
    let (mut utm, mut xyz) = (
        String::from("point,kind,easting,northing,h,sigma_xy,sigma_z\n"),
        String::from("point,kind,x,y,z,sigma_xy,sigma_z\n"),
    );
    for l in text.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let g = gnss::frame::Geodetic::from_degrees(
            f[2].parse().unwrap(),
            f[3].parse().unwrap(),
            f[4].parse().unwrap(),
        );
        let p = tm.forward(&g);
        let e = g.to_ecef();
        utm += &format!(
            "{},{},{:.4},{:.4},{},{},{}\n",
            f[0], f[1], p.easting, p.northing, f[4], f[5], f[6]
        );
        xyz += &format!(
            "{},{},{:.4},{:.4},{:.4},{},{}\n",
            f[0], f[1], e.0.x, e.0.y, e.0.z, f[5], f[6]
        );
    }
    std::fs::write(dir.join("utm.csv"), utm).unwrap();
    std::fs::write(dir.join("xyz.csv"), xyz).unwrap();
    let src = std::fs::read_to_string(dir.join("project.toml")).unwrap();
    for (name, ground) in [
        ("utm", "file = \"utm.csv\"\ncrs = \"utm:50N\""),
        ("xyz", "file = \"xyz.csv\""),
    ] {
        std::fs::write(
            dir.join("project.toml"),
            src.replace("file = \"ground_points.csv\"", ground),
        )
        .unwrap();
        let r = adjust::run(
            &dir.join("project.toml"),
            &dir.join(format!("out-{name}")),
            &Default::default(),
        )
        .unwrap();
        for a in 0..3 {
            assert!(
                (r.checks.rms[a] - base.checks.rms[a]).abs() < 2e-3,
                "{name}: {:?} vs {:?}",
                r.checks.rms,
                base.checks.rms
            );
        }
    }
    // G1 as a check point: one more check point, three control points left.
    std::fs::write(
        dir.join("project.toml"),
        src.replace(
            "file = \"ground_points.csv\"",
            "file = \"ground_points.csv\"\nas_check = [\"G1\"]",
        ),
    )
    .unwrap();
    let r = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out-ascheck"),
        &Default::default(),
    )
    .unwrap();
    assert_eq!(r.checks.points.len(), base.checks.points.len() + 1);
    assert!(r.checks.points.iter().any(|c| c.id == "G1"));
    let ctl = r
        .groups
        .iter()
        .find(|g| g.group == "control points")
        .unwrap();
    assert_eq!(ctl.observations, 9);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The GNSS input as a trajectory (`.pos`) interpolated at the image times of the image list
/// gives the adjustment of the antenna table; images outside the trajectory are reported, and
/// so is where its ambiguity segments came from.
#[test]
fn trajectory_input_equals_the_antenna_table() {
    let dir = project_dir("trajectory");
    let table = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out-table"),
        &Default::default(),
    )
    .unwrap();
    edit(&dir, "project.toml", |t| {
        t.replace(
            "antennas = \"antennas.csv\"",
            "trajectory = \"trajectory.pos\"",
        )
    });
    let traj = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out-traj"),
        &Default::default(),
    )
    .unwrap();
    assert!(
        traj.warnings
            .iter()
            .all(|w| !w.contains("without a GNSS position")),
        "{:?}",
        traj.warnings
    );
    // A .pos carries no segments: the report says they were derived from it.
    assert!(
        traj.warnings.iter().any(|w| w
            .contains("ambiguity segments derived from Q changes and gaps of")
            && w.contains("trajectory.pos")),
        "{:?}",
        traj.warnings
    );
    for (a, b) in traj.images.iter().zip(&table.images) {
        for k in 0..3 {
            assert!(
                (a.local[k] - b.local[k]).abs() < 2e-3,
                "{} {:?} {:?}",
                a.id,
                a.local,
                b.local
            );
        }
    }
    for a in 0..3 {
        assert!((traj.checks.rms[a] - table.checks.rms[a]).abs() < 2e-3);
    }
    // An image later than the trajectory: named in a warning, adjusted without GNSS.
    edit(&dir, "images.csv", |t| {
        let mut l: Vec<String> = t.lines().map(String::from).collect();
        let last = l.len() - 1;
        let f: Vec<String> = l[last].split(',').map(String::from).collect();
        l[last] = format!(
            "{},{},{},{},{}",
            f[0],
            f[1],
            f[2],
            f[3],
            f[4].parse::<f64>().unwrap() + 500.0
        );
        l.join("\n")
    });
    let late = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out-late"),
        &Default::default(),
    )
    .unwrap();
    assert!(
        late.warnings
            .iter()
            .any(|w| w.contains("1 image(s) without a GNSS position")
                && w.contains("outside the trajectory")),
        "{:?}",
        late.warnings
    );
    let _ = std::fs::remove_dir_all(&dir);
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
