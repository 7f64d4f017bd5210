//! A block started from its tie points alone (issue 48): the textured block's photos matched
//! without positions, the block seeded by the relative orientation of its best pair, grown by
//! resection and placed on four corner control points, against the same ties with the GNSS
//! positions: check-point RMS within 1.5×.

use integration::adjust::{run, RunOptions};
use integration::simulate::textured::{textured_block, TexturedSpec};
use integration::tiepoints::{self, project, MatchJob};
use std::path::Path;
use testkit::scratch_path as tmp;

/// The project folder `out`: the matched ties (σ 0.3 px), the simulator's exact control and
/// check measurements, control G1–G4 (the corners; G5 becomes a check point) and, with
/// `gnss`, the simulator's antennas and `[gnss]` section.
fn project(sim: &Path, matched: &project::Written, out: &Path, gnss: bool) {
    std::fs::create_dir_all(out).unwrap();
    let ground = std::fs::read_to_string(sim.join("ground_points.csv"))
        .unwrap()
        .replace("G5,gcp", "G5,check");
    std::fs::write(out.join("ground_points.csv"), &ground).unwrap();
    let ids: Vec<&str> = ground
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').next())
        .collect();
    let exact = std::fs::read_to_string(sim.join("image_observations.csv")).unwrap();
    let mut text = String::from("image,point,x_px,y_px,sigma_px\n");
    for l in exact.lines().skip(1) {
        if l.split(',').nth(1).is_some_and(|p| ids.contains(&p)) {
            text += &format!("{l}\n");
        }
    }
    for (img, pt, x, y) in &matched.project.measurements {
        text += &format!("{img},{pt},{x:.4},{y:.4},0.3\n");
    }
    std::fs::write(out.join("image_observations.csv"), text).unwrap();
    std::fs::copy(sim.join("images.csv"), out.join("images.csv")).unwrap();
    let sim_toml = std::fs::read_to_string(sim.join("project.toml")).unwrap();
    let gnss_at = sim_toml.find("[gnss]").unwrap();
    let mut toml = sim_toml[..gnss_at].to_string();
    if gnss {
        std::fs::copy(sim.join("antennas.csv"), out.join("antennas.csv")).unwrap();
        toml += &sim_toml[gnss_at..];
    }
    std::fs::write(out.join("project.toml"), toml).unwrap();
}

#[test]
fn textured_block_from_tie_points_and_four_corners_checks_like_gnss() {
    let dir = tmp("start-from-ties");
    textured_block(&TexturedSpec::builtin(), &dir).unwrap();
    // The allocator as the ppkat binary sets it (large buffers reused, not mapped each time).
    common::memory::keep_large_buffers();
    let mut job = MatchJob::new(dir.join("photos"));
    job.camera = Some(dir.join("camera.toml"));
    // Features shared with the other tests of these photos (the same bytes as extracted).
    job.shared_cache =
        Some(std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("feature-cache"));
    let m = tiepoints::run(&job, &|_, _, _| {}).unwrap();
    let mut w = project::build(&job, &m).unwrap();
    assert!(w.project.free_datum && w.project.gnss.is_empty());
    // The free project as match writes it: every photo gets a start from the ties.
    let free = dir.join("free");
    w.project.write(&free).unwrap();
    let started = project::tie_starts(&mut w.project, &free).unwrap();
    assert_eq!(started, w.project.images.len());
    assert_eq!(started, 24);
    let opts = RunOptions::default();
    let f = run(&free.join("project.toml"), &free.join("out"), &opts).unwrap();
    assert_eq!(f.images.len(), 24);
    assert!(f.warnings.iter().any(|x| x.contains("a free network")));
    assert!(
        f.images.iter().all(|i| i.rms_px < 0.6),
        "free network image RMS"
    );

    let (ties, gnss) = (dir.join("corners"), dir.join("gnss"));
    project(&dir, &w, &ties, false);
    project(&dir, &w, &gnss, true);
    let a = run(&ties.join("project.toml"), &ties.join("out"), &opts).unwrap();
    let b = run(&gnss.join("project.toml"), &gnss.join("out"), &opts).unwrap();
    let norm = |r: [f64; 3]| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    let (ea, eb) = (norm(a.checks.rms), norm(b.checks.rms));
    eprintln!(
        "check points 3D RMS: from ties on 4 corners {ea:.3} m ({:.3?}), with GNSS {eb:.3} m ({:.3?}): {:.2}×",
        a.checks.rms,
        b.checks.rms,
        ea / eb
    );
    assert_eq!((a.images.len(), b.images.len()), (24, 24));
    let note = a.start_note.as_deref().unwrap_or("");
    assert!(
        note.contains("grown to 24 images") && note.contains("placed on 4 control points"),
        "{note}"
    );
    assert!(
        b.start_note.is_none(),
        "the GNSS run starts from its strips"
    );
    assert_eq!(a.checks.points.len(), 5);
    assert!(ea <= 1.5 * eb, "from ties {ea} m vs GNSS {eb} m");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A longer block (2 strips of 14 photos of 800 × 600 px, 365 m) matched without positions
/// and adjusted as a free network from its tie points alone: every photo in, and after a
/// similarity onto the true centres (a free network's coordinates are arbitrary) every centre
/// within 10 cm — the local bundle adjustments keep the growth from drifting (without them
/// the starts were 134 m off and the adjustment ended singular).
#[test]
fn a_longer_block_from_its_ties_alone_keeps_its_shape() {
    let dir = tmp("start-from-ties-long");
    let spec = TexturedSpec {
        strips: 2,
        per_strip: 14,
        width_px: 800,
        height_px: 600,
        pixel_um: 8.0,
        ..TexturedSpec::builtin()
    };
    textured_block(&spec, &dir).unwrap();
    // The allocator as the ppkat binary sets it (large buffers reused, not mapped each time).
    common::memory::keep_large_buffers();
    let mut job = MatchJob::new(dir.join("photos"));
    job.camera = Some(dir.join("camera.toml"));
    // Features shared with the other tests of these photos (the same bytes as extracted).
    job.shared_cache =
        Some(std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("feature-cache"));
    let m = tiepoints::run(&job, &|_, _, _| {}).unwrap();
    let w = project::build(&job, &m).unwrap();
    let free = dir.join("free");
    w.project.write(&free).unwrap();
    let r = run(
        &free.join("project.toml"),
        &free.join("out"),
        &RunOptions::default(),
    )
    .unwrap_or_else(|e| panic!("free network: {e}"));
    assert_eq!(r.images.len(), 28);
    let truth = std::fs::read_to_string(dir.join("truth_exposures.csv")).unwrap();
    let true_centre = |id: &str| -> nalgebra::Vector3<f64> {
        let l = truth
            .lines()
            .find(|l| l.starts_with(&format!("{id},")))
            .unwrap();
        let f: Vec<f64> = l
            .split(',')
            .skip(4)
            .take(3)
            .map(|x| x.parse().unwrap())
            .collect();
        nalgebra::Vector3::new(f[0], f[1], f[2])
    };
    let from: Vec<_> = r
        .images
        .iter()
        .map(|i| nalgebra::Vector3::from(i.position.local))
        .collect();
    let to: Vec<_> = r.images.iter().map(|i| true_centre(&i.id)).collect();
    let (s, rot, t) = photo::relative::similarity(&from, &to).unwrap();
    let worst = from
        .iter()
        .zip(&to)
        .map(|(a, b)| (s * rot * a + t - b).norm())
        .fold(0.0, f64::max);
    eprintln!("free network of 28 photos: worst centre {worst:.3} m after a similarity");
    assert!(worst < 0.10, "worst centre {worst} m");
    let _ = std::fs::remove_dir_all(&dir);
}
