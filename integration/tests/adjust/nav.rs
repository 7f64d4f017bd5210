//! The nav-block (issue 14): navigation-grade GPS (σ 2 m) with a 0.8 s latency and a 15 m
//! constant offset, no tie points, control measured in a few images each. The awkward block
//! as simulated, and its resectable variant (≥ 4 control points in every image, none empty)
//! on which the latency and the offset are recovered.

use super::tmp;
use integration::adjust::{self, results::Results};
use integration::simulate::block::nav::{LATENCY_S, OFFSET_ENU};
use integration::simulate::block::{nav_block, NavSpec, NavTruth};

fn adjust_nav(spec: &NavSpec, name: &str, project: &str) -> (NavTruth, Results) {
    let dir = tmp(name);
    let truth = nav_block(spec, &dir).unwrap();
    let res = adjust::run(&dir.join(project), &dir.join("out"), &Default::default())
        .unwrap_or_else(|e| panic!("{project}: {e}"));
    let _ = std::fs::remove_dir_all(&dir);
    (truth, res)
}

/// The awkward block is as the issue describes it: ~70 control and ~16 check points, each
/// measured in 1–6 images, images with no point and with only one or two, velocities in the
/// antenna table, both project files.
#[test]
fn nav_block_is_awkward() {
    let dir = tmp("nav-awkward");
    let t = nav_block(&NavSpec::awkward(), &dir).unwrap();
    assert_eq!(t.images.len(), 60);
    let gcp = t.points.iter().filter(|p| p.1 == "gcp").count();
    let chk = t.points.iter().filter(|p| p.1 == "check").count();
    assert!(
        (60..=70).contains(&gcp) && (12..=16).contains(&chk),
        "{gcp} {chk}"
    );
    let empty = t.per_image.iter().filter(|n| **n == 0).count();
    let few = t.per_image.iter().filter(|n| (1..=2).contains(*n)).count();
    assert!(
        empty >= 3 && few >= 5,
        "{empty} empty, {few} with 1–2 points"
    );
    let text = std::fs::read_to_string(dir.join("image_observations.csv")).unwrap();
    for (id, _, _) in &t.points {
        let n = text
            .lines()
            .filter(|l| l.split(',').nth(1) == Some(id))
            .count();
        assert!((1..=6).contains(&n), "{id} measured {n} times");
    }
    let ant = std::fs::read_to_string(dir.join("antennas.csv")).unwrap();
    assert!(ant.lines().nth(1).unwrap().ends_with(",ve,vn,vu"));
    assert!(dir.join("project_gcp_only.toml").exists() && dir.join("truth.toml").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// With the GNSS (block offset, block latency) on the resectable variant: the latency within
/// 0.05 s and the offset within 0.5 m of truth, each error inside 3σ.
#[test]
fn nav_block_latency_and_offset_recovered() {
    let (t, r) = adjust_nav(&NavSpec::resectable(), "nav-gnss", "project.toml");
    assert!(t.control_per_image.iter().all(|n| *n >= 4));
    let l = &r.latencies[0];
    let (dl, sl) = (l.values[0] - LATENCY_S, l.sigmas[0]);
    let d = &r.drifts[0];
    let da: Vec<f64> = (0..3).map(|a| d.values[a] - OFFSET_ENU[a]).collect();
    println!(
        "latency {:.4} ± {sl:.4} s (error {dl:+.4}); offset {:.3} {:.3} {:.3} ± {:.3} {:.3} {:.3} m (errors {:+.3} {:+.3} {:+.3}); σ0 {:.3}; checks RMS {:.3} {:.3} {:.3} theoretical {:.3} {:.3} {:.3}",
        l.values[0], d.values[0], d.values[1], d.values[2], d.sigmas[0], d.sigmas[1], d.sigmas[2],
        da[0], da[1], da[2], r.sigma0, r.checks.rms[0], r.checks.rms[1], r.checks.rms[2],
        r.checks.theoretical_rms[0], r.checks.theoretical_rms[1], r.checks.theoretical_rms[2]
    );
    assert_eq!(r.latencies.len(), 1);
    assert!(dl.abs() < 0.05, "latency error {dl} s");
    assert!(
        dl.abs() < 3.0 * sl && sl < 0.05,
        "latency error {dl} s, σ {sl} s"
    );
    // The drift is in the ENU at the block centre, the truth in the ENU at the first image:
    // 2 km apart, the frames differ by 0.3 mrad, 5 mm on 15 m.
    for (a, (e, s)) in da.iter().zip(&d.sigmas).enumerate() {
        assert!(e.abs() < 0.5, "offset error {a}: {e} m");
        assert!(e.abs() < 3.0 * s, "offset error {a}: {e} m, σ {s}");
    }
    assert!((0.7..1.3).contains(&r.sigma0), "σ0 {}", r.sigma0);
}

/// Control only on the resectable variant: the block adjusts without the GNSS (the
/// determinability test is unit-free: a pose with four well-spread control points is
/// determined).
#[test]
fn nav_block_control_only() {
    let (_, r) = adjust_nav(&NavSpec::resectable(), "nav-gcp", "project_gcp_only.toml");
    println!(
        "σ0 {:.3}; checks {} RMS {:.3} {:.3} {:.3} theoretical {:.3} {:.3} {:.3}",
        r.sigma0,
        r.checks.points.len(),
        r.checks.rms[0],
        r.checks.rms[1],
        r.checks.rms[2],
        r.checks.theoretical_rms[0],
        r.checks.theoretical_rms[1],
        r.checks.theoretical_rms[2]
    );
    assert!(r.latencies.is_empty() && r.drifts.is_empty());
    assert!((0.7..1.3).contains(&r.sigma0), "σ0 {}", r.sigma0);
}

/// The awkward block as simulated (images without points, many with one or two, no ties):
/// with the GNSS every image that cannot be determined is named and left out and the rest
/// adjusts, the latency within 0.05 s and the offset within 3σ; control only, the images
/// with ≥ 3 control points adjust and every other one is named.
#[test]
fn nav_block_awkward_adjusts_what_it_can() {
    let (t, r) = adjust_nav(&NavSpec::awkward(), "nav-awkward-gnss", "project.toml");
    let named = |r: &Results| {
        r.warnings
            .iter()
            .filter(|w| w.starts_with("image ") && w.contains("is left out"))
            .count()
    };
    let empty = t.per_image.iter().filter(|n| **n == 0).count();
    println!(
        "awkward with GNSS: {} of {} images adjusted, {} named; latency {:.4} ± {:.4}; offset {:?} ± {:?}; checks {} RMS {:?} theoretical {:?}",
        r.images.len(),
        t.images.len(),
        named(&r),
        r.latencies[0].values[0],
        r.latencies[0].sigmas[0],
        r.drifts[0].values,
        r.drifts[0].sigmas,
        r.checks.points.len(),
        r.checks.rms,
        r.checks.theoretical_rms
    );
    assert_eq!(
        r.images.len() + named(&r),
        t.images.len(),
        "every image adjusted or named"
    );
    assert!(named(&r) >= empty && r.images.len() >= t.images.len() * 3 / 4);
    let (dl, sl) = (
        r.latencies[0].values[0] - LATENCY_S,
        r.latencies[0].sigmas[0],
    );
    assert!(
        dl.abs() < 0.05 && dl.abs() < 3.0 * sl,
        "latency error {dl} ± {sl}"
    );
    for (a, truth) in OFFSET_ENU.iter().enumerate() {
        let (e, s) = (r.drifts[0].values[a] - truth, r.drifts[0].sigmas[a]);
        assert!(e.abs() < 3.0 * s && s < 1.0, "offset error {a}: {e} ± {s}");
    }
    let (_, c) = adjust_nav(
        &NavSpec::awkward(),
        "nav-awkward-gcp",
        "project_gcp_only.toml",
    );
    println!(
        "awkward control only: {} images adjusted, {} named",
        c.images.len(),
        named(&c)
    );
    assert_eq!(c.images.len() + named(&c), t.images.len());
    // Images with ≥ 3 control points start by resection (27 of 60).
    assert!(c.images.len() >= 24, "{} images", c.images.len());
}

/// Over twelve simulated awkward blocks, the σ the adjustment reports are honest: the check
/// points' RMS over their theoretical value averages 1 (each block has only 5–12 checks, so
/// single ratios scatter from 0.45 to 1.6), the offset errors over their σ have a mean square
/// near 1, and every latency is within 0.05 s.
#[test]
fn nav_block_sigmas_are_honest_over_seeds() {
    let (mut ratios, mut z2, mut n) = (Vec::new(), 0.0, 0);
    for seed in 2025..2037u64 {
        let spec = NavSpec {
            seed,
            ..NavSpec::awkward()
        };
        let dir = tmp(&format!("nav-seed-{seed}"));
        nav_block(&spec, &dir).unwrap();
        let r = adjust::run(
            &dir.join("project.toml"),
            &dir.join("out"),
            &Default::default(),
        )
        .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let _ = std::fs::remove_dir_all(&dir);
        for (a, truth) in OFFSET_ENU.iter().enumerate() {
            ratios.push(r.checks.rms[a] / r.checks.theoretical_rms[a]);
            let z = (r.drifts[0].values[a] - truth) / r.drifts[0].sigmas[a];
            z2 += z * z;
            n += 1;
        }
        let dl = r.latencies[0].values[0] - LATENCY_S;
        assert!(dl.abs() < 0.05, "seed {seed}: latency error {dl}");
    }
    let mean_ratio = ratios.iter().sum::<f64>() / ratios.len() as f64;
    let z2 = z2 / n as f64;
    println!("mean check RMS / theoretical {mean_ratio:.3}; offset mean z² {z2:.2}");
    assert!((0.8..1.2).contains(&mean_ratio), "{mean_ratio}");
    assert!((0.5..2.0).contains(&z2), "{z2}");
}
