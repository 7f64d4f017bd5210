//! `sparse-control` (issue 48): 290 images shaped like a real film block, most measuring one
//! control point, navigation-grade GNSS 14 m off and 0.8 s late, no tie points. The solve
//! never aborts: it adjusts every image its observations determine and names the rest.

use super::tmp;
use integration::adjust::{self, results::Results};
use integration::simulate::block::nav::LATENCY_S;
use integration::simulate::block::{nav_block, NavSpec};
use std::collections::BTreeMap;

/// The control measurements (pixels) of each image, from the project's table.
fn control_pixels(dir: &std::path::Path) -> BTreeMap<String, Vec<(f64, f64)>> {
    let text = std::fs::read_to_string(dir.join("image_observations.csv")).unwrap();
    let mut out: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for l in text.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        if f[1].starts_with('G') {
            let xy = (f[2].parse().unwrap(), f[3].parse().unwrap());
            out.entry(f[0].to_string()).or_default().push(xy);
        }
    }
    out
}

/// Three of `pts` spread over the image (a triangle of at least 5 % of the format) whose
/// circle keeps away from the principal point (`pp`; on it, a resection is critical).
fn well_spread(pts: &[(f64, f64)], pp: (f64, f64), format: f64) -> bool {
    let n = pts.len();
    (0..n).any(|a| {
        (a + 1..n).any(|b| {
            (b + 1..n).any(|c| {
                let (p, q, r) = (pts[a], pts[b], pts[c]);
                let area = ((q.0 - p.0) * (r.1 - p.1) - (r.0 - p.0) * (q.1 - p.1)).abs() / 2.0;
                let d = 2.0 * (p.0 * (q.1 - r.1) + q.0 * (r.1 - p.1) + r.0 * (p.1 - q.1));
                if area < 0.05 * format || d == 0.0 {
                    return false;
                }
                let s = |u: (f64, f64)| u.0 * u.0 + u.1 * u.1;
                let ux = (s(p) * (q.1 - r.1) + s(q) * (r.1 - p.1) + s(r) * (p.1 - q.1)) / d;
                let uy = (s(p) * (r.0 - q.0) + s(q) * (p.0 - r.0) + s(r) * (q.0 - p.0)) / d;
                let radius = ((p.0 - ux).powi(2) + (p.1 - uy).powi(2)).sqrt();
                let to_pp = ((pp.0 - ux).powi(2) + (pp.1 - uy).powi(2)).sqrt();
                (to_pp - radius).abs() > 0.15 * radius
            })
        })
    })
}

fn adjusted(r: &Results) -> Vec<&str> {
    r.images.iter().map(|i| i.id.as_str()).collect()
}

/// With the GNSS: every image that measures two or more control points adjusts, every other
/// one is named with its reason; the latency within 0.05 s, the offset within 0.5 m, the
/// check points within 1.3× of their theoretical RMS. Control only: every image with three
/// or more well-spread control points adjusts. Neither run fails.
#[test]
fn sparse_control_adjusts_what_its_observations_determine() {
    let dir = tmp("sparse-control");
    let spec = NavSpec::sparse_control();
    let t = nav_block(&spec, &dir).unwrap();
    let per = |n: usize| t.control_per_image.iter().filter(|&&c| c == n).count();
    assert_eq!(t.images.len(), 290);
    assert!(
        per(1) >= 195 && per(2) + per(3) + per(4) + per(5) >= 80,
        "{:?}",
        (per(1), per(2), per(3))
    );

    let r = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap_or_else(|e| panic!("with GNSS: {e}"));
    let ids = adjusted(&r);
    for (im, &n) in t.images.iter().zip(&t.control_per_image) {
        if n >= 2 {
            assert!(
                ids.contains(&im.0.as_str()),
                "image {} with {n} control points",
                im.0
            );
        }
    }
    assert_eq!(
        ids.len() + r.left_out.len(),
        290,
        "every image adjusted or named"
    );
    assert!(r
        .left_out
        .iter()
        .any(|w| w.contains("5 equations for its six unknowns")));
    let (dl, sl) = (
        r.latencies[0].values[0] - LATENCY_S,
        r.latencies[0].sigmas[0],
    );
    assert!(
        dl.abs() < 0.05 && dl.abs() < 3.0 * sl,
        "latency error {dl} ± {sl}"
    );
    for a in 0..3 {
        let e = r.drifts[0].values[a] - spec.offset_enu[a];
        assert!(e.abs() < 0.5, "offset error {a}: {e} m");
    }
    assert!(
        r.checks.points.len() >= 12,
        "{} check points",
        r.checks.points.len()
    );
    for a in 0..3 {
        let ratio = r.checks.rms[a] / r.checks.theoretical_rms[a];
        assert!(ratio < 1.3, "check RMS / theoretical, axis {a}: {ratio:.2}");
    }
    println!(
        "with GNSS: {} images adjusted, {} named; latency {:+.4} ± {sl:.4}; checks {} RMS {:?} theoretical {:?}",
        ids.len(), r.left_out.len(), dl, r.checks.points.len(), r.checks.rms, r.checks.theoretical_rms
    );

    // As a time-less import gets it (`import micmac --gnss-kind nav`): no latency, one offset
    // per strip, which takes up the 14 m and the ±45 m along-track shift of the latency.
    let toml = std::fs::read_to_string(dir.join("project.toml")).unwrap();
    let strip = toml
        .replace("drift = \"block\"", "drift = \"strip\"")
        .replace("latency = \"block\"\n", "");
    std::fs::write(dir.join("strip.toml"), strip).unwrap();
    let s = adjust::run(
        &dir.join("strip.toml"),
        &dir.join("out3"),
        &Default::default(),
    )
    .unwrap_or_else(|e| panic!("offsets per strip: {e}"));
    assert!(
        s.latencies.is_empty() && s.drifts.len() == 10,
        "{}",
        s.drifts.len()
    );
    assert_eq!(adjusted(&s).len(), ids.len(), "the same images adjust");
    for a in 0..3 {
        let ratio = s.checks.rms[a] / s.checks.theoretical_rms[a];
        assert!(
            ratio < 1.3,
            "offsets per strip: check RMS / theoretical, axis {a}: {ratio:.2}"
        );
    }

    let c = adjust::run(
        &dir.join("project_gcp_only.toml"),
        &dir.join("out2"),
        &Default::default(),
    )
    .unwrap_or_else(|e| panic!("control only: {e}"));
    let ids = adjusted(&c);
    let pixels = control_pixels(&dir);
    let mut spread = 0;
    for (im, pts) in &pixels {
        if pts.len() >= 3 && well_spread(pts, (2700.0, 4000.0), 5400.0 * 8000.0) {
            spread += 1;
            assert!(ids.contains(&im.as_str()), "image {im}: {pts:?}");
        }
    }
    assert_eq!(ids.len() + c.left_out.len(), 290);
    println!(
        "control only: {} images adjusted ({spread} with 3+ well-spread control), {} named",
        ids.len(),
        c.left_out.len()
    );
    // 28 images measure 3+ control points; one (708) is critical for a resection.
    assert!(
        spread >= 12 && ids.len() >= 25,
        "{spread} well spread, {} adjusted",
        ids.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Offsets per strip where a strip cannot carry its own (issue 67): three images measuring one
/// control point each form strip 97 (all left out, the strip's drift measured by nothing) and
/// an image with two control points forms strip 98 alone (its drift not determined with it).
/// Before, the run stopped ("the drift of strip 97 is not determined …", nothing adjusted);
/// now both drifts are left out with their centres and named, and the rest adjusts as before.
#[test]
fn a_strip_whose_offset_nothing_determines_is_left_out_not_fatal() {
    let dir = tmp("sparse-lone-strips");
    let t = nav_block(&NavSpec::sparse_control(), &dir).unwrap();
    let per_image: BTreeMap<&str, usize> = t
        .images
        .iter()
        .zip(&t.control_per_image)
        .map(|(im, &n)| (im.0.as_str(), n))
        .collect();
    let ids: Vec<&str> = t.images.iter().map(|im| im.0.as_str()).collect();
    let run = ids
        .windows(3)
        .find(|w| w.iter().all(|i| per_image[i] == 1))
        .expect("three consecutive images with one control point")
        .to_vec();
    let two = *ids.iter().find(|i| per_image[**i] == 2).unwrap();
    let list = std::fs::read_to_string(dir.join("images.csv")).unwrap();
    let mut out = String::new();
    for (k, l) in list.lines().enumerate() {
        let mut f: Vec<String> = l.split(',').map(String::from).collect();
        if k > 0 && run.contains(&f[0].as_str()) {
            f[2] = "97".into();
        } else if k > 0 && f[0] == two {
            f[2] = "98".into();
        }
        out += &(f.join(",") + "\n");
    }
    std::fs::write(dir.join("images_lone.csv"), out).unwrap();
    let toml = std::fs::read_to_string(dir.join("project.toml")).unwrap();
    let lone = toml
        .replace("drift = \"block\"", "drift = \"strip\"")
        .replace("latency = \"block\"\n", "")
        .replace("images.csv", "images_lone.csv");
    std::fs::write(dir.join("lone.toml"), lone).unwrap();
    let r = adjust::run(
        &dir.join("lone.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap_or_else(|e| panic!("a strip's drift stopped the run: {e}"));
    for (strip, why) in [("97", "nothing measures it"), ("98", "not determined")] {
        assert!(
            r.left_out
                .iter()
                .any(|w| w.contains(&format!("GNSS drift of strip {strip}")) && w.contains(why)),
            "strip {strip}: {:#?}",
            r.left_out
        );
    }
    assert!(r
        .drifts
        .iter()
        .all(|d| d.name != "strip 97" && d.name != "strip 98"));
    assert_eq!(r.drifts.len(), 10);
    let adjusted = adjusted(&r);
    for (im, &n) in &per_image {
        if n >= 2 && *im != two {
            assert!(adjusted.contains(im), "image {im} with {n} control points");
        }
    }
    for a in 0..3 {
        let ratio = r.checks.rms[a] / r.checks.theoretical_rms[a];
        assert!(ratio < 1.3, "check RMS / theoretical, axis {a}: {ratio:.2}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Navigation-grade centres (σ 2 m, no offset, no latency) imported as survey-grade (σ 5 cm
/// horizontal, 10 cm vertical, as `import micmac` assumes without `--gnss-kind`): the GNSS
/// group's variance component finds them out, the adjustment uses it, the warning says what
/// they behave like and what to do, and the check points stay within their theoretical RMS.
#[test]
fn nav_grade_centres_taken_for_survey_grade_are_found_out() {
    let dir = tmp("sparse-survey-sigma");
    let spec = NavSpec {
        offset_enu: [0.0; 3],
        latency_s: 0.0,
        ..NavSpec::sparse_control()
    };
    nav_block(&spec, &dir).unwrap();
    let ant = std::fs::read_to_string(dir.join("antennas.csv")).unwrap();
    let mut out = String::new();
    for l in ant.lines() {
        let mut f: Vec<String> = l.split(',').map(String::from).collect();
        if f.len() > 11 && f[0] != "id" && !f[0].starts_with('#') {
            // c_ee c_en c_eu c_nn c_nu c_uu
            for (k, v) in [(6, 0.0025), (9, 0.0025), (11, 0.01)] {
                f[k] = format!("{v}");
            }
        }
        out += &(f.join(",") + "\n");
    }
    std::fs::write(dir.join("antennas_survey.csv"), out).unwrap();
    let toml = std::fs::read_to_string(dir.join("project.toml")).unwrap();
    let survey = toml
        .replace("drift = \"block\"", "drift = \"none\"")
        .replace("latency = \"block\"\n", "")
        .replace("drift_model = \"offset\"\n", "")
        .replace("antennas.csv", "antennas_survey.csv");
    std::fs::write(dir.join("survey.toml"), survey).unwrap();
    // Before: "the normal equations are singular" (data snooping weighed the centres down
    // one by one until the block fell apart).
    let r = adjust::run(
        &dir.join("survey.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let factor = |name: &str| {
        r.groups
            .iter()
            .find(|g| g.group == name)
            .map(|g| g.sigma_factor)
            .unwrap()
    };
    // 2 m against 5 cm / 10 cm: 40× and 20×.
    let gnss = factor("GNSS centres");
    assert!((15.0..50.0).contains(&gnss), "GNSS σ factor {gnss}");
    let image = factor("image points");
    assert!((0.7..1.4).contains(&image), "image σ factor {image}");
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("GNSS centres behave like σ ≈") && w.contains("--gnss-kind nav")),
        "{:#?}",
        r.warnings
    );
    for a in 0..3 {
        let ratio = r.checks.rms[a] / r.checks.theoretical_rms[a];
        assert!(ratio < 1.3, "check RMS / theoretical, axis {a}: {ratio:.2}");
    }
    println!(
        "survey σ on nav-grade centres: GNSS σ factor {gnss:.1}, image {image:.2}; checks RMS {:?} theoretical {:?}",
        r.checks.rms, r.checks.theoretical_rms
    );
    let _ = std::fs::remove_dir_all(&dir);
}
