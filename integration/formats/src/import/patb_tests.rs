//! The PATB readers on small hand-written files: units, kinds, σ, and errors that name the
//! file and the line.

use super::*;

/// A fresh temporary folder for one test.
fn dir(name: &str) -> PathBuf {
    testkit::scratch_dir(&format!("patb-{name}"))
}

/// A job on `images` (text) with a 100 × 80 px camera of 10 µm pixels and `control` (text).
fn job(d: &Path, images: &str, units: Units, control: Option<&str>) -> PatbJob {
    std::fs::write(d.join("block.im"), images).unwrap();
    let ground = control.map(|c| {
        std::fs::write(d.join("block.con"), c).unwrap();
        d.join("block.con")
    });
    PatbJob {
        images: d.join("block.im"),
        units,
        camera: CameraSource::Numbers(CameraNumbers {
            focal_mm: 50.0,
            pixel_um: 10.0,
            width_px: Some(100),
            height_px: Some(80),
            sigma_px: 0.5,
        }),
        ground,
        check: Vec::new(),
        ground_sigma: [0.02, 0.03],
        crs: Some("utm:50N".into()),
    }
}

#[test]
fn millimetres_and_pixels_become_the_same_pixels() {
    let d = dir("units");
    // 0.25 mm right and 0.1 mm up of the centre of a 1.0 × 0.8 mm image: pixel (75, 30).
    let mm = job(
        &d,
        "# a comment\n101\nP1 0.25 0.1\nP2 -0.5 -0.4\n-99\n",
        Units::Mm,
        None,
    );
    let (a, s) = import(&mm).unwrap();
    let px: Vec<(&str, f64, f64)> = a
        .measurements
        .iter()
        .map(|m| (m.1.as_str(), m.2, m.3))
        .collect();
    for (got, want) in px.iter().zip([("P1", 75.0, 30.0), ("P2", 0.0, 80.0)]) {
        assert_eq!(got.0, want.0);
        assert!(
            (got.1 - want.1).abs() < 1e-9 && (got.2 - want.2).abs() < 1e-9,
            "{got:?}"
        );
    }
    assert_eq!(s.count("image measurements"), 2);
    assert_eq!(s.count("tie points"), 2);
    let px = job(&d, "101\nP1 75 30\nP2 0 80\n-99\n", Units::Px, None);
    let (b, _) = import(&px).unwrap();
    for (m, n) in a.measurements.iter().zip(&b.measurements) {
        assert_eq!((&m.0, &m.1), (&n.0, &n.1));
        assert!((m.2 - n.2).abs() < 1e-9 && (m.3 - n.3).abs() < 1e-9);
    }
}

#[test]
fn control_kinds_sigmas_and_skips_are_counted() {
    let d = dir("control");
    let images = "101\nG1 0 0\nG2 0.1 0.1\nC1 0.2 0.2\nZ1 0.3 0.3\n-99\n102\n-99\n";
    let control = "G1 500000 3000000 40 0.01 0.01 0.02\nG2 500100 3000000 41 gcp\nC1 500000 3000100 42 0.05 0.06\nZ1 500100 3000100 43 gcp-z\nG9 1 2 3\n-99\n";
    let mut j = job(&d, images, Units::Mm, Some(control));
    j.check = vec!["G2".into()];
    let (p, s) = import(&j).unwrap();
    let kinds: Vec<(&str, &str, [f64; 3])> = p
        .ground
        .iter()
        .map(|g| (g.id.as_str(), g.kind, g.sigma))
        .collect();
    assert_eq!(
        kinds,
        [
            ("G1", "gcp", [0.01, 0.01, 0.02]),
            ("G2", "check", [0.02, 0.02, 0.03]),
            ("C1", "gcp", [0.05, 0.05, 0.06]),
            ("Z1", "gcp-z", [0.02, 0.02, 0.03]),
        ]
    );
    assert_eq!(
        (s.count("gcp points"), s.count("check points")),
        (3, 1),
        "G9 read, not measured"
    );
    assert_eq!(s.count("gcp-z points"), 1);
    assert_eq!(s.count("tie points"), 0);
    assert_eq!(s.count("images"), 1);
    let skipped: Vec<&str> = s.skipped.iter().map(|x| x.1.as_str()).collect();
    assert_eq!(skipped.len(), 2, "{:?}", s.skipped);
    assert!(s.skipped[0].0.starts_with("photo 102"), "{:?}", s.skipped);
    assert_eq!(skipped[0], "no measurements");
    assert!(
        s.skipped[1].0.starts_with("gcp point G9"),
        "{:?}",
        s.skipped
    );
    // UTM 50N back from ECEF: the same coordinates.
    let back = GroundFrame::Utm(50, true).from_ecef(&p.ground[0].pos);
    assert!((back - Vector3::new(500000.0, 3000000.0, 40.0)).norm() < 1e-6);
}

/// The error text of an import.
fn error(j: &PatbJob) -> String {
    import(j).expect_err("must fail").to_string()
}

#[test]
fn bad_input_names_file_and_line() {
    let d = dir("bad");
    let e = error(&job(&d, "101\nP1 0.1\n-99\n", Units::Mm, None));
    assert!(
        e.contains("block.im:2:") && e.contains("2 field(s) in photo 101"),
        "{e}"
    );
    let e = error(&job(&d, "101\nP1 0.1 0,2\n-99\n", Units::Mm, None));
    assert!(
        e.contains("block.im:2:") && e.contains("`0,2` is not a number"),
        "{e}"
    );
    let e = error(&job(&d, "101\nP1 0.1 0.2\nP1 0 0\n-99\n", Units::Mm, None));
    assert!(
        e.contains("block.im:3:") && e.contains("measured twice"),
        "{e}"
    );
    let e = error(&job(&d, "101\nP1 -0.1 0.2\n-99\n", Units::Px, None));
    assert!(e.contains("block.im:2:") && e.contains("outside"), "{e}");
    let e = error(&job(&d, "101\nP1 0 0\n", Units::Mm, Some("G1 1 2\n")));
    assert!(
        e.contains("block.con:1:") && e.contains("3 field(s)"),
        "{e}"
    );
    let e = error(&job(&d, "101\nP1 0 0\n", Units::Mm, Some("G1 1 2 x\n")));
    assert!(
        e.contains("block.con:1:") && e.contains("`x` is not a number"),
        "{e}"
    );
    let e = error(&job(
        &d,
        "101\nP1 0 0\n",
        Units::Mm,
        Some("\nG1 1 2 3 tie\n"),
    ));
    assert!(
        e.contains("block.con:2:") && e.contains("`tie` is not a number nor a kind"),
        "{e}"
    );
    let e = error(&job(&d, "101\nP1 0 0\n", Units::Mm, Some("G1 1 2 3 1\n")));
    assert!(
        e.contains("block.con:1:") && e.contains("1 σ values"),
        "{e}"
    );
    let mut j = job(&d, "101\nP1 0 0\n", Units::Mm, Some("G1 1 2 3\n"));
    j.check = vec!["G7".into()];
    assert!(error(&j).contains("--check G7: no such point"));
    // A camera without its size cannot place pixels: the photo's line is named.
    let mut j = job(&d, "\n101\nP1 1 1\n", Units::Px, None);
    j.camera = CameraSource::Numbers(CameraNumbers {
        focal_mm: 50.0,
        pixel_um: 10.0,
        width_px: None,
        height_px: Some(80),
        sigma_px: 0.5,
    });
    let e = error(&j);
    assert!(
        e.contains("block.im:2:") && e.contains("camera cam has no image size"),
        "{e}"
    );
}

#[test]
fn cameras_from_a_file_are_chosen_by_the_header() {
    let d = dir("cams");
    std::fs::write(
        d.join("cams.toml"),
        "[[camera]]\nid = \"a\"\nfocal_mm = 50\npixel_um = 10\nwidth_px = 100\nheight_px = 80\nprincipal_point_mm = [0.01, 0]\nself_calibrate = [\"f\"]\n\n[[camera]]\nid = \"b\"\nfocal_px = 2000\npixel_um = 5\nwidth_px = 200\nheight_px = 160\n\n[[camera]]\nid = \"c\"\nfocal_mm = 9\npixel_um = 5\nwidth_px = 20\nheight_px = 20\n",
    )
    .unwrap();
    let mut j = job(
        &d,
        "101 a\nP1 0 0\n-99\n102 b\nP1 0 0\n-99\n",
        Units::Mm,
        None,
    );
    j.camera = CameraSource::File(d.join("cams.toml"));
    let (p, s) = import(&j).unwrap();
    assert_eq!(
        p.images,
        [("101".into(), "a".into()), ("102".into(), "b".into())]
    );
    // The image centre, whatever the principal point: (50, 40) and (100, 80).
    assert_eq!((p.measurements[0].2, p.measurements[0].3), (50.0, 40.0));
    assert_eq!((p.measurements[1].2, p.measurements[1].3), (100.0, 80.0));
    assert_eq!(p.cameras.len(), 2);
    assert_eq!(p.cameras[0].self_calibrate, ["f"]);
    assert!((p.cameras[1].camera.f - 0.010).abs() < 1e-15);
    assert!((p.cameras[0].camera.x0 - 1e-5).abs() < 1e-15);
    assert_eq!(s.skipped, [("camera c".into(), "no photo uses it".into())]);
    // Several cameras and a photo that names none: its line is named.
    let mut j = job(
        &d,
        "101 a\nP1 0 0\n-99\n102\nP1 0 0\n-99\n",
        Units::Mm,
        None,
    );
    j.camera = CameraSource::File(d.join("cams.toml"));
    let e = error(&j);
    assert!(
        e.contains("block.im:4:") && e.contains("name its camera (a, b, c)"),
        "{e}"
    );
}
