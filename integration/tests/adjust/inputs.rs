//! The same adjustment from different input forms: PATB, ground-point formats, a trajectory.

use super::*;

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
                (a.position.local[k] - b.position.local[k]).abs() < 2e-3,
                "{} {:?} {:?}",
                a.id,
                a.position.local,
                b.position.local
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
    let tm = common::tmerc::TransverseMercator::utm(50, true);
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
                (a.position.local[k] - b.position.local[k]).abs() < 2e-3,
                "{} {:?} {:?}",
                a.id,
                a.position.local,
                b.position.local
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
