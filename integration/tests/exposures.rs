//! Exposures on simulated flights against exact truth: interpolation of the antenna, lever arm
//! rotated by the attitude, and the whole chain RINEX events → PPK → projection centres.

use gnss::frame::Ecef;
use gnss::ppk::PpkOptions;
use gnss::solution::{PosFormat, Quality};
use gnss::time::from_week_tow;
use gnss::trajectory::{Trajectory, TrajectoryEpoch};
use integration::demo::SimInputs;
use integration::exposure::attitude::{AngleConvention, AttitudeTable};
use integration::exposure::events::{self, ExposureEvent};
use integration::exposure::{compute, ExposureOptions};
use integration::simulate::{self, SimReport};
use nalgebra::{Matrix3, Vector3};
use std::path::{Path, PathBuf};

use testkit::scratch_path as tmp;

fn csv(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| l.chars().next().is_some_and(|c| c.is_ascii_digit()))
        .map(|l| {
            l.split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect()
}

struct Sim {
    dir: PathBuf,
    rep: SimReport,
    lever: Vector3<f64>,
}

fn sim(name: &str) -> Sim {
    let s = simulate::builtin("demo").unwrap();
    let dir = tmp(name);
    let rep = simulate::run(&s, &dir).unwrap();
    Sim {
        dir,
        rep,
        lever: Vector3::from(s.camera.lever_arm),
    }
}

/// Truth trajectory every `step`-th sample as a Trajectory, and the truth attitude.
fn truth_trajectory(dir: &Path, step: usize) -> (Trajectory, AttitudeTable) {
    let rows = csv(&dir.join("truth_trajectory.csv"));
    let pts = rows
        .iter()
        .step_by(step)
        .map(|r| {
            TrajectoryEpoch::new(
                from_week_tow(r[0] as u32, r[1]),
                Ecef::new(r[2], r[3], r[4]),
                Matrix3::identity() * 1e-6,
                Quality::Fixed,
            )
        })
        .collect();
    let att = AttitudeTable {
        conv: AngleConvention::YawPitchRoll,
        times: rows
            .iter()
            .map(|r| from_week_tow(r[0] as u32, r[1]))
            .collect(),
        angles: rows
            .iter()
            .map(|r| [r[10].to_radians(), r[9].to_radians(), r[8].to_radians()])
            .collect(),
        sigmas: None,
    };
    (Trajectory::with_derived_segments(pts, None), att)
}

/// Truth exposures: (event, antenna, centre).
fn truth_exposures(dir: &Path) -> Vec<(ExposureEvent, Vector3<f64>, Vector3<f64>)> {
    csv(&dir.join("truth_exposures.csv"))
        .iter()
        .map(|r| {
            (
                ExposureEvent {
                    id: format!("{}", r[0]),
                    time: from_week_tow(r[2] as u32, r[3]),
                    line: 0,
                    mrk: None,
                },
                Vector3::new(r[7], r[8], r[9]),
                Vector3::new(r[4], r[5], r[6]),
            )
        })
        .collect()
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

#[test]
fn interpolation_and_lever_arm_against_truth() {
    let s = sim("interp");
    let truth = truth_exposures(&s.dir);
    for (step, label) in [(1, "10 Hz"), (10, "1 Hz")] {
        let (traj, att) = truth_trajectory(&s.dir, step);
        let opts = ExposureOptions {
            lever_arm: Some(photo::lever::LeverArm::new(s.lever)),
            attitude: Some(att),
            ..Default::default()
        };
        let res = compute(truth.iter().map(|t| t.0.clone()).collect(), &traj, &opts);
        assert!(
            res.refused.is_empty(),
            "{:?}",
            &res.refused[..res.refused.len().min(3)]
        );
        let mut ea = Vec::new();
        let mut ec = Vec::new();
        for (st, t) in res.stations.iter().zip(&truth) {
            ea.push((st.antenna.0 - t.1).norm());
            ec.push((st.centre.0 - t.2).norm());
        }
        let (a, c) = (rms(&ea), rms(&ec));
        eprintln!("{label} trajectory: antenna RMS {:.2} mm, projection centre RMS {:.2} mm ({} exposures)", a * 1e3, c * 1e3, ea.len());
        if step == 1 {
            assert!(a <= 0.003, "antenna RMS {a}");
            assert!(c <= a + 0.003, "centre RMS {c}");
        } else {
            // Reported, with a bound that catches a broken interpolator (linear would be ~cm).
            assert!(a <= 0.02, "1 Hz antenna RMS {a}");
        }
    }
}

/// Interpolation anywhere on the photo flight (strips and the turns between them, 4 g in the
/// demo's tight turns) against the analytic path: 10 Hz and 1 Hz trajectories. The take-off
/// and the top of the climb are left out: the simulated path has velocity jumps there.
#[test]
fn interpolation_through_turns() {
    let sc = simulate::builtin("demo").unwrap();
    let s = sim("turns");
    let truth = simulate::truth_flight(&sc).unwrap();
    // The path is C1 but not C2: entering a turn the acceleration jumps by 4 g in an instant,
    // which costs centimetres next to the joints; elsewhere the error is sub-millimetre.
    for (step, label, bound) in [(1, "10 Hz", 0.005), (10, "1 Hz", 0.5)] {
        let (traj, _) = truth_trajectory(&s.dir, step);
        let (_, t1) = traj.span().unwrap();
        let first_photo = truth_exposures(&s.dir)[0].0.time;
        let mut e = Vec::new();
        let mut t = first_photo - hifitime::Duration::from_seconds(2.0 - 0.0137);
        while t < t1 {
            if let Ok(p) = traj.interpolate(t, 2.0) {
                e.push((p.pos.0 - truth(t).0).norm());
            }
            t += hifitime::Duration::from_seconds(0.2573);
        }
        let worst = e.iter().copied().fold(0.0, f64::max);
        eprintln!(
            "{label} trajectory, strips and turns: RMS {:.2} mm, worst {:.1} mm over {} times",
            rms(&e) * 1e3,
            worst * 1e3,
            e.len()
        );
        assert!(rms(&e) <= bound, "{label}: {}", rms(&e));
    }
}

#[test]
fn events_to_ppk_to_projection_centres() {
    let s = sim("e2e");
    let inputs = SimInputs::read(&s.rep).unwrap();
    let rover = &inputs.rover;
    let r = inputs.ppk(&s.rep, &PpkOptions::default()).unwrap();
    let pos = s.dir.join("ppk.pos");
    r.trajectory.write_pos(&pos, &[], PosFormat::Xyz).unwrap();
    let traj = Trajectory::read_pos(&pos).unwrap();
    let (evs, clock) = events::from_rinex(rover, &traj);
    let (_, att) = truth_trajectory(&s.dir, 1);
    let res = compute(
        evs,
        &traj,
        &ExposureOptions {
            lever_arm: Some(photo::lever::LeverArm::new(s.lever)),
            attitude: Some(att),
            ..Default::default()
        },
    );
    let truth = truth_exposures(&s.dir);
    assert_eq!(
        res.stations.len(),
        truth.len(),
        "refused: {:?}",
        res.refused
    );
    let e: Vec<f64> = res
        .stations
        .iter()
        .zip(&truth)
        .map(|(st, t)| (st.centre.0 - t.2).norm())
        .collect();
    eprintln!("events → PPK → centres: {} stations, 3D RMS {:.1} mm, max {:.1} mm; receiver clock correction up to {:.3} ms", e.len(), rms(&e) * 1e3, e.iter().copied().fold(0.0, f64::max) * 1e3, clock * 1e3);
    assert!(
        clock > 1e-4,
        "the simulated receiver clock offset was found and removed"
    );
    assert!(rms(&e) <= 0.03);
}

#[test]
fn bad_exposure_inputs_are_refused_or_flagged() {
    let s = sim("bad");
    let (traj, _) = truth_trajectory(&s.dir, 1);
    let truth = truth_exposures(&s.dir);
    let (t0, t1) = traj.span().unwrap();
    let mut evs: Vec<ExposureEvent> = truth.iter().take(5).map(|t| t.0.clone()).collect();
    // Outside the trajectory, a duplicate, and out of order.
    evs.push(ExposureEvent {
        id: "early".into(),
        time: t0 - hifitime::Duration::from_seconds(5.0),
        line: 0,
        mrk: None,
    });
    evs.push(ExposureEvent {
        id: "late".into(),
        time: t1 + hifitime::Duration::from_seconds(5.0),
        line: 0,
        mrk: None,
    });
    evs.push(truth[2].0.clone());
    evs.swap(0, 3);
    let res = compute(
        evs,
        &traj,
        &ExposureOptions {
            lever_arm: Some(photo::lever::LeverArm::new(s.lever)),
            ..Default::default()
        },
    );
    assert_eq!(res.stations.len(), 5);
    let why: Vec<&str> = res.refused.iter().map(|r| r.why.as_str()).collect();
    assert_eq!(
        why.iter()
            .filter(|w| w.contains("outside the trajectory"))
            .count(),
        2,
        "{why:?}"
    );
    assert_eq!(
        why.iter().filter(|w| w.contains("duplicate")).count(),
        1,
        "{why:?}"
    );
    assert!(
        res.warnings.iter().any(|w| w.contains("not in time order")),
        "{:?}",
        res.warnings
    );
    // Missing attitude: the heading is used and every station says so.
    assert!(res
        .stations
        .iter()
        .all(|s| s.flags.iter().any(|f| f.contains("heading"))));
    assert!(res.warnings.iter().any(|w| w.contains("no attitude")));
    // A gap in the trajectory longer than the limit.
    let mut pts = traj.epochs.clone();
    let cut = pts.iter().position(|p| p.time > truth[10].0.time).unwrap();
    pts.drain(cut - 20..cut + 20);
    let gappy = Trajectory::with_derived_segments(pts, None);
    let res = compute(
        vec![truth[10].0.clone()],
        &gappy,
        &ExposureOptions::default(),
    );
    assert!(res.refused[0].why.contains("gap"), "{:?}", res.refused);
    // UTC times declared as GPST in an MRK: the drone's own positions match 18 s later.
    let mrk = s.dir.join("Timestamp.MRK");
    let mut text = String::new();
    for (k, t) in truth.iter().enumerate() {
        let g = Ecef(t.1).to_geodetic();
        let wrong = t.0.time - hifitime::Duration::from_seconds(18.0);
        let (w, tow) = gnss::time::week_tow(wrong);
        text += &format!("{}\t{tow:.6}\t[{w}]\t0,N\t0,E\t0,V\t{:.9},Lat\t{:.9},Lon\t{:.3},Ellh\t0.02, 0.02, 0.03\t50,Q\n", k + 1, g.lat.to_degrees(), g.lon.to_degrees(), g.h);
    }
    std::fs::write(&mrk, text).unwrap();
    let res = compute(
        events::read_mrk(&mrk).unwrap(),
        &traj,
        &ExposureOptions::default(),
    );
    assert!(
        res.warnings
            .iter()
            .any(|w| w.contains("UTC declared as GPST")),
        "{:?}",
        res.warnings
    );
}

/// Photographs: matched to the exposures by their rhythm, geotagged copies carry the
/// projection centres, the originals stay byte for byte as they were; a missing photo is
/// found where it is missing.
#[test]
fn photos_are_matched_and_geotagged_copies_written() {
    use integration::exposure::photos;
    use integration::exposure::{AttitudeSource, CameraStation};
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/photo_16x16.jpg");
    let dir = tmp("photos");
    std::fs::create_dir_all(&dir).unwrap();
    let t0 = from_week_tow(2318, 291_700.0);
    let mut stations = Vec::new();
    for k in 0..6 {
        let name = dir.join(format!("IMG_{:04}.jpg", k + 1));
        std::fs::copy(&src, &name).unwrap();
        let mut m = little_exif::metadata::Metadata::new_from_path(&name).unwrap();
        m.set_tag(little_exif::exif_tag::ExifTag::DateTimeOriginal(format!(
            "2024:06:12 09:01:{:02}",
            10 + 3 * k
        )));
        m.write_to_file(&name).unwrap();
        let c =
            gnss::frame::Geodetic::from_degrees(47.3 + 0.001 * k as f64, 8.55, 830.0 + k as f64)
                .to_ecef();
        stations.push(CameraStation {
            id: format!("{}", k + 1),
            time: t0 + hifitime::Duration::from_seconds(3.0 * k as f64),
            antenna: c,
            velocity: nalgebra::Vector3::new(0.0, 33.0, 0.0),
            centre: c,
            cov: Matrix3::identity() * 1e-4,
            quality: Quality::Fixed,
            segment: 0,
            rotation: Matrix3::identity(),
            attitude: AttitudeSource::Heading,
            rotation_sigma: None,
            flags: vec![],
        });
    }
    let originals: Vec<Vec<u8>> = (0..6)
        .map(|k| std::fs::read(dir.join(format!("IMG_{:04}.jpg", k + 1))).unwrap())
        .collect();
    let list = photos::list(&dir).unwrap();
    assert_eq!(list.len(), 6);
    assert!(list.iter().all(|p| p.taken.is_some()), "capture times read");
    photos::check(&list, &stations).unwrap();
    let out = tmp("geotagged");
    let written = photos::geotag(&list, &stations, &out, &Default::default())
        .unwrap()
        .written;
    assert_eq!(written.len(), 6);
    for (k, w) in written.iter().enumerate() {
        let (lat, lon, h) = photos::read_position(w).expect("GPS tags written");
        let g = stations[k].centre.to_geodetic();
        assert!(
            (lat - g.lat.to_degrees()).abs() < 1e-7 && (lon - g.lon.to_degrees()).abs() < 1e-7,
            "{lat} {lon}"
        );
        assert!((h - g.h).abs() < 0.001);
        assert_eq!(
            std::fs::read(dir.join(format!("IMG_{:04}.jpg", k + 1))).unwrap(),
            originals[k],
            "original untouched"
        );
    }
    // The copies keep the photos' other EXIF fields (the capture times).
    let copies = photos::list(&out).unwrap();
    assert!(copies
        .iter()
        .zip(&list)
        .all(|(c, o)| c.taken.is_some() && c.taken == o.taken));
    // Writing into the photos' own folder is refused.
    assert!(photos::geotag(&list, &stations, &dir, &Default::default()).is_err());
    // A photo missing in the middle.
    std::fs::remove_file(dir.join("IMG_0003.jpg")).unwrap();
    let list = photos::list(&dir).unwrap();
    let why = photos::check(&list, &stations).unwrap_err();
    assert!(
        why.contains("5 photos, 6 exposures") && why.contains("IMG_0004.jpg (#3)"),
        "{why}"
    );
}
