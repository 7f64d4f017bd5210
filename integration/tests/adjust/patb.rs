//! `import patb` on the classic block: its measurements written as PATB in millimetres and in
//! pixels, its control as a PATB control file in UTM; both imports adjust to the same
//! orientations, and to those of the simulated project itself.

use super::*;
use integration::gnss::frame::Geodetic;
use integration::import::patb::{self, CameraNumbers, CameraSource, PatbJob, Units};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The classic block's format: 23 000 px of 10 µm (230 mm).
const SIDE_PX: f64 = 23000.0;
const PIXEL_MM: f64 = 0.010;

/// Rows of a CSV written by the simulation, as maps column → text.
fn rows(path: &Path) -> Vec<BTreeMap<String, String>> {
    let t = std::fs::read_to_string(path).unwrap();
    let mut lines = t.lines();
    let head: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            head.iter()
                .cloned()
                .zip(l.split(',').map(String::from))
                .collect()
        })
        .collect()
}

/// The simulated measurements as PATB image coordinates, photos in the image list's order:
/// in pixels (column, row as simulated) or in millimetres from the image centre, y up.
fn write_patb_images(sim: &Path, units: Units, out: &Path) {
    let mut by_image: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for r in rows(&sim.join("image_observations.csv")) {
        let (x, y) = (&r["x_px"], &r["y_px"]);
        let line = match units {
            Units::Px => format!("{} {x} {y}", r["point"]),
            Units::Mm => {
                let (c, w): (f64, f64) = (x.parse().unwrap(), y.parse().unwrap());
                let mm = [
                    (c - SIDE_PX / 2.0) * PIXEL_MM,
                    (SIDE_PX / 2.0 - w) * PIXEL_MM,
                ];
                format!("{} {:.5} {:.5}", r["point"], mm[0], mm[1])
            }
        };
        by_image.entry(r["image"].clone()).or_default().push(line);
    }
    let mut s = String::from("# classic block, image coordinates\n");
    for im in rows(&sim.join("images.csv")) {
        let id = &im["image"];
        let _ = writeln!(s, "{id} cam\n{}\n-99", by_image[id].join("\n"));
    }
    std::fs::write(out, s).unwrap();
}

/// The simulated ground points as a PATB control file in UTM zone 50 N: `ID E N h σxy σz`,
/// with the kind column when `kinds`.
fn write_patb_control(sim: &Path, kinds: bool, out: &Path) {
    let tm = common::tmerc::TransverseMercator::utm(50, true);
    let mut s = String::new();
    for r in rows(&sim.join("ground_points.csv")) {
        let num = |k: &str| r[k].parse::<f64>().unwrap();
        let g = Geodetic::from_degrees(num("lat"), num("lon"), num("h"));
        let p = tm.forward(&g);
        let kind = if kinds { r["kind"].as_str() } else { "" };
        let _ = writeln!(
            s,
            "{} {:.7} {:.7} {:.7} {} {} {kind}",
            r["point"], p.easting, p.northing, g.h, r["sigma_xy"], r["sigma_z"]
        );
    }
    s += "-99\n";
    std::fs::write(out, s).unwrap();
}

/// Import a job into `dir` and adjust it.
fn import_and_adjust(job: &PatbJob, dir: &Path) -> (integration::import::Summary, Results) {
    let (p, s) = patb::import(job).unwrap();
    p.write(dir).unwrap();
    let r = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap();
    (s, r)
}

/// Largest differences between two adjustments' orientations: centre (m, ECEF) and angles
/// (rad).
fn differences(a: &Results, b: &Results) -> (f64, f64) {
    assert_eq!(a.images.len(), b.images.len());
    let (mut dc, mut da): (f64, f64) = (0.0, 0.0);
    for (x, y) in a.images.iter().zip(&b.images) {
        assert_eq!(x.id, y.id);
        let ecef =
            |p: &adjust::results::Position| Geodetic::from_degrees(p.lat, p.lon, p.h).to_ecef().0;
        dc = dc.max((ecef(&x.position) - ecef(&y.position)).norm());
        for k in 0..3 {
            da = da.max((x.opk_deg[k] - y.opk_deg[k]).to_radians().abs());
        }
    }
    (dc, da)
}

#[test]
fn patb_mm_and_px_adjust_like_the_simulated_project() {
    let sim = tmp("patb-sim");
    let truth = block::aerial(&BlockSpec::classic(), &sim).unwrap();
    // No GNSS in PATB: three in four check points become control so that the block starts
    // and adjusts from control alone (the four corners are too few for a start); C4, C8, …
    // stay check points.
    edit(&sim, "ground_points.csv", |t| {
        let control = |id: &str| {
            id.strip_prefix('C')
                .and_then(|n| n.parse::<u32>().ok())
                .is_some_and(|n| n % 4 != 0)
        };
        t.lines()
            .map(|l| match l.split_once(',') {
                Some((id, rest)) if control(id) => {
                    format!("{id},{}\n", rest.replacen("check", "gcp", 1))
                }
                _ => format!("{l}\n"),
            })
            .collect()
    });
    let direct = adjust::run(
        &sim.join("project.toml"),
        &sim.join("out"),
        &Default::default(),
    )
    .unwrap();
    write_patb_images(&sim, Units::Mm, &sim.join("block_mm.im"));
    write_patb_images(&sim, Units::Px, &sim.join("block_px.im"));
    write_patb_control(&sim, true, &sim.join("control_kinds.con"));
    write_patb_control(&sim, false, &sim.join("control.con"));
    let checks: Vec<String> = rows(&sim.join("ground_points.csv"))
        .into_iter()
        .filter(|r| r["kind"] == "check")
        .map(|r| r["point"].clone())
        .collect();
    let checks_made_control = rows(&sim.join("ground_points.csv")).len() - 4 - checks.len();
    // Millimetres, the camera from the simulated project file, kinds from the column.
    let mm = PatbJob {
        images: sim.join("block_mm.im"),
        units: Units::Mm,
        camera: CameraSource::File(sim.join("project.toml")),
        ground: Some(sim.join("control_kinds.con")),
        check: Vec::new(),
        ground_sigma: [1.0, 1.0],
        crs: Some("EPSG:32650".into()),
    };
    // Pixels, the camera from its numbers, check points from --check.
    let px = PatbJob {
        images: sim.join("block_px.im"),
        units: Units::Px,
        camera: CameraSource::Numbers(CameraNumbers {
            focal_mm: 152.0,
            pixel_um: 10.0,
            width_px: Some(23000),
            height_px: Some(23000),
            sigma_px: 0.5,
        }),
        ground: Some(sim.join("control.con")),
        check: checks.clone(),
        ground_sigma: [1.0, 1.0],
        crs: Some("utm:50N".into()),
    };
    let (s_mm, r_mm) = import_and_adjust(&mm, &sim.join("mm"));
    let (s_px, r_px) = import_and_adjust(&px, &sim.join("px"));
    for s in [&s_mm, &s_px] {
        assert_eq!(s.count("photos"), 29);
        assert_eq!(s.count("images"), 29);
        assert_eq!(s.count("image measurements"), truth.measurements);
        assert_eq!(s.count("gcp points"), 4 + checks_made_control);
        assert_eq!(s.count("check points"), checks.len());
        assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    }
    assert_eq!(
        std::fs::read(sim.join("mm/image_observations.csv")).unwrap(),
        std::fs::read(sim.join("px/image_observations.csv")).unwrap(),
        "mm and px give the same pixels"
    );
    let (dc, da) = differences(&r_mm, &r_px);
    eprintln!("patb mm vs px: centres {dc:.2e} m, angles {da:.2e} rad");
    assert!(dc < 1e-6 && da < 1e-9, "mm vs px: {dc} m, {da} rad");
    assert_eq!(r_mm.observations, direct.observations);
    assert_eq!(r_mm.unknowns, direct.unknowns);
    let (dc, da) = differences(&r_mm, &direct);
    eprintln!("patb vs simulated project: centres {dc:.2e} m, angles {da:.2e} rad");
    assert!(dc < 1e-6 && da < 1e-9, "patb vs direct: {dc} m, {da} rad");
    // And against truth: each camera centre within 4 of its σ (|error| / |σ E, N, U|).
    let r = gnss::frame::enu_rotation(&truth.origin).transpose();
    let (mut worst, mut worst_z): (f64, f64) = (0.0, 0.0);
    for (t, x) in truth.images.iter().zip(&r_mm.images) {
        assert_eq!(t.0, x.id);
        let p = &x.position;
        let got = Geodetic::from_degrees(p.lat, p.lon, p.h).to_ecef().0;
        let e = (got - (truth.origin.to_ecef().0 + r * t.2.centre)).norm();
        worst = worst.max(e);
        worst_z = worst_z.max(e / nalgebra::Vector3::from(x.sigma_centre).norm());
    }
    eprintln!("patb: camera centres against truth: largest {worst:.3} m, {worst_z:.2} σ");
    assert!(worst_z < 4.0, "{worst} m, {worst_z} σ");
    assert_eq!(r_mm.checks.points.len(), direct.checks.points.len());
    for k in 0..3 {
        assert!((r_mm.checks.rms[k] - direct.checks.rms[k]).abs() < 1e-6);
    }
    let _ = std::fs::remove_dir_all(&sim);
}
