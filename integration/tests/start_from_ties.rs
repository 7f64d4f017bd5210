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
    let mut job = MatchJob::new(dir.join("photos"));
    job.camera = Some(dir.join("camera.toml"));
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
