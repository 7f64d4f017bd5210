//! GNSS/INS on real sensors (`../shared/data/ins/rtklibexplorer-gnss-imu-2025`): the car
//! drive's MEMS IMU loosely coupled on the receiver's own RTK positions, with the issue's
//! eleven 15 s outages (40–55 s after the first GNSS epoch, then every 45 s), the bridged
//! positions compared with the withheld RTK fixes; and the IMU log's time tags against the
//! data's own converted walk.

use hifitime::Epoch;
use integration::gnss::frame::enu_rotation;
use integration::gnss::solution::{read_pos, PosRecord};
use integration::ins::attitude::Euler;
use integration::ins::errstate::{idx, Mat};
use integration::ins::filter::Estimate;
use integration::ins::job::{run_job, InsJob};
use integration::ins::spec::{Grade, ImuSpec};
use integration::ins::{gnss_pos, rtklib_imu};
use nalgebra::Vector3;
use std::path::Path;

const SET: &str = "ins/rtklibexplorer-gnss-imu-2025";

/// The walk's IMU times agree with the data's own conversion (`imu_1730_sf.csv`, GPST
/// seconds since 1970 in its first column) to a microsecond.
#[test]
fn the_imu_log_is_timed_as_its_own_tools_time_it() {
    let Some(dir) = testkit::shared_data(&format!("{SET}/walk_0827")) else {
        return;
    };
    let log = rtklib_imu::read(&dir.join("imu_1730.csv"), &dir.join("imu_1730.csv.tag")).unwrap();
    let theirs: Vec<f64> = std::fs::read_to_string(dir.join("imu_1730_sf.csv"))
        .unwrap()
        .lines()
        .filter_map(|l| l.split(',').next()?.parse().ok())
        .collect();
    // Theirs has every whole row; ours a sample per whole row after the first.
    assert_eq!(log.samples.len() + 1, theirs.len());
    let unix0 = Epoch::from_gregorian(1970, 1, 1, 0, 0, 0, 0, hifitime::TimeScale::GPST);
    let worst = log
        .samples
        .iter()
        .zip(&theirs[1..])
        .map(|(s, t)| ((s.time - unix0).to_seconds() - t).abs())
        .fold(0.0f64, f64::max);
    assert!(worst < 1e-6, "{worst}");
    assert!((log.stretch - 1.000_141).abs() < 2e-6, "{}", log.stretch);
    // Its first and last lines are cut (six fields): named, nothing else left out.
    assert_eq!(log.skipped.len(), 2, "{:?}", log.skipped);
    assert!(log.skipped[0].starts_with("line 1:") && log.skipped[1].starts_with("line 20457:"));
    assert!(log.gaps.is_empty(), "{:?}", log.gaps);
}

/// The car's receiver writes its velocities late against its positions: the lag at which
/// they match the positions' own differences is 0.14 s (the `.pos` comes from the receiver's
/// NAV-PVT; the data's own filter shifts its IMU by 0.125 s).
#[test]
fn the_car_receivers_velocities_are_late() {
    let Some(dir) = testkit::shared_data(&format!("{SET}/drive_0708")) else {
        return;
    };
    let epochs = gnss_pos::read_pos(&dir.join("gnss_1934_sf.pos")).unwrap();
    assert_eq!(epochs.len(), 2197);
    assert!(epochs.iter().all(|e| e.velocity.is_some()));
    let lag = gnss_pos::velocity_latency(&epochs).unwrap();
    eprintln!("velocity latency {lag:.3} s");
    assert!((0.11..=0.17).contains(&lag), "{lag}");
}

struct Outages {
    rms: f64,
    worst: f64,
    nees: f64,
    n: usize,
}

/// The trajectory `est` against the fixed epochs of `pos` withheld in `windows` (seconds from
/// the first epoch), through the lever arm.
fn outages(
    pos: &[PosRecord],
    est: &[(Epoch, Estimate, Mat)],
    lever: &Vector3<f64>,
    windows: &[(f64, f64)],
) -> Outages {
    let first = pos[0].time;
    let (mut ss, mut worst, mut nees, mut n) = (0.0, 0.0f64, 0.0, 0usize);
    let mut j = 0;
    for p in pos.iter().filter(|p| p.quality as u8 == 1) {
        let s = (p.time - first).to_seconds();
        if !windows.iter().any(|(a, b)| (*a..=*b).contains(&s)) {
            continue;
        }
        while j + 1 < est.len() && est[j + 1].0 <= p.time {
            j += 1;
        }
        let Some((t, e, cov)) = est.get(j) else {
            continue;
        };
        let dt = (p.time - *t).to_seconds();
        if !(0.0..0.05).contains(&dt) {
            continue;
        }
        let ant = e.nav.position.0 + dt * e.nav.velocity + e.nav.attitude * lever;
        let rot = enu_rotation(&p.pos.to_geodetic());
        let d = rot * (p.pos.0 - ant);
        let h = d.xy().norm();
        ss += h * h;
        worst = worst.max(h);
        let c = rot * cov.fixed_view::<3, 3>(idx::POS, idx::POS) * rot.transpose();
        let ch = c.fixed_view::<2, 2>(0, 0).into_owned();
        nees += (d.xy().transpose() * ch.try_inverse().unwrap() * d.xy())[(0, 0)] / 2.0;
        n += 1;
    }
    Outages {
        rms: (ss / n.max(1) as f64).sqrt(),
        worst,
        nees: nees / n.max(1) as f64,
        n,
    }
}

/// The car as the source's drive_config.py mounts it: IMU axes to body roll, pitch, yaw
/// 180°, −6.79°, 185.35° (Groves' Euler angles of the body axes in the IMU's), the IMU's
/// time tags 0.125 s late, the antenna 5 cm left of the IMU; the MEMS preset, no side slip
/// within 0.3 m/s, the outages withheld.
fn car_job(dir: &Path) -> InsJob {
    InsJob {
        imu_csv: dir.join("imu_1934.csv"),
        imu_format: ins::job::ImuFormat::RtklibCsv,
        imu_tag: dir.join("imu_1934.csv.tag"),
        gnss: dir.join("gnss_1934_sf.pos"),
        spec: ImuSpec::preset(Grade::Mems),
        mount: Euler {
            roll: 180f64.to_radians(),
            pitch: (-6.79f64).to_radians(),
            heading: 185.35f64.to_radians(),
        },
        imu_time_offset: -0.125,
        lever_arm: Vector3::new(0.0, -0.05, 0.0),
        no_side_slip: Some(0.3),
        withhold: (0..=10)
            .map(|k| (40.0 + 45.0 * k as f64, 55.0 + 45.0 * k as f64))
            .collect(),
        every: 2,
        phases: None,
    }
}

/// The car: the MEMS preset, the IMU levelled while the car stands, heading from its course
/// once it passes 1 m/s (39.5 s after the first epoch: the first outage starts half a
/// second later), RTK positions at 4 Hz (2 cm / 4 cm fixed, 0.3 m / 0.6 m float; the file's
/// σ are nominal), no side slip within 0.3 m/s, zero velocity and angular rate at its stops,
/// the IMU's noise following the innovations and, rerun, raised until the outages' ends
/// agree with their σ, then again until the smoothed σ hold in eight trial gaps of 15.5 s
/// cut between the outages (there NEES per axis 6.5 at the bridges' noise, 1.15 at ×2.55).
/// Measured over the 663 withheld RTK fixes: forward 1.88 m RMS, 8.92 m worst (the data's
/// own filter forward without velocity matching: 3.09 / 12.8 m; with it 0.30 / 0.69 m);
/// smoothed 0.261 m RMS, 0.767 m worst — the goal, 0.15 / 0.40 m, is not reached;
/// NEES 1.24 forward, 1.26 smoothed (without the trial gaps: 0.224 / 0.573 m smoothed but
/// NEES 2.49, forward 1.85 / 7.57 m, NEES 2.94; before the outages checked their σ: 1.32 /
/// 4.33 m forward, 0.253 / 0.565 m smoothed, NEES 5.1 and 12.0). Without the side-slip constraint the filter diverges after the first outage (its
/// heading, 10° uncertain at the start, is not known well enough when the outage begins).
#[test]
fn the_car_drive_bridges_fifteen_second_outages() {
    let Some(dir) = testkit::shared_data(&format!("{SET}/drive_0708")) else {
        return;
    };
    let job = car_job(&dir);
    let done = run_job(&job).unwrap();
    let r = done.run;
    let pos = read_pos(&dir.join("gnss_1934_sf.pos")).unwrap();
    let lever = job.lever_arm;
    let first = pos[0].time;
    let lv = done.levelled;
    let sm: Vec<(Epoch, Estimate, Mat)> =
        r.smoothed.iter().map(|(t, s)| (*t, s.est, s.cov)).collect();
    let f = outages(&pos, &r.forward, &lever, &job.withhold);
    let s = outages(&pos, &sm, &lever, &job.withhold);
    let nis = r.nis.iter().sum::<f64>() / r.nis.len() as f64 / 3.0;
    eprintln!(
        "car drive: levelled roll {:.2}° pitch {:.2}°, start at {:.1} s; {} fixes used ({} unused), NIS/3 {:.2}, noise scale {:.1}; outages ({} RTK epochs): forward RMS {:.3} m worst {:.3} m NEES {:.2}; smoothed RMS {:.3} m worst {:.3} m NEES {:.2}",
        lv.0.to_degrees(),
        lv.1.to_degrees(),
        (lv.2 - first).to_seconds(),
        r.nis.len(),
        r.unused_fixes,
        nis,
        r.noise_scale,
        f.n,
        f.rms,
        f.worst,
        f.nees,
        s.rms,
        s.worst,
        s.nees
    );
    assert_eq!(
        r.unused_fixes, 0,
        "every fix after the start is used, whatever the IMU's intervals"
    );
    eprintln!("trial gaps: {:?}", done.trial);
    let (scale, gaps) = done.bridge_scale;
    assert!(gaps == 11 && scale > 1.5, "{gaps} gaps, noise ×{scale}");
    let (trial, k) = done.trial.clone().expect("the gaps ask for a trial");
    assert!(
        trial.gaps == 8 && trial.length == 15.5 && trial.ratio <= 1.5 && k > 2.0,
        "{trial:?} ×{k}"
    );
    assert!(f.n > 600, "{} withheld fixes compared", f.n);
    assert!(
        f.rms < 2.2 && f.worst < 10.0,
        "forward {} {}",
        f.rms,
        f.worst
    );
    assert!(
        s.rms < 0.29 && s.worst < 0.85,
        "smoothed {} {}",
        s.rms,
        s.worst
    );
    assert!(
        (0.5..=2.0).contains(&f.nees) && (0.5..=2.0).contains(&s.nees),
        "NEES {} {}",
        f.nees,
        s.nees
    );
}

/// The walk end to end, as the source's walk_config.py mounts it (IMU axes 180°, 0°, −90°,
/// its times as tagged, the antenna 5 cm left of the IMU, no side-slip constraint: a walker
/// steps sideways), three 10 s windows of the receiver's fixed RTK withheld (20–30, 50–60,
/// 75–85 s after the first epoch). Measured: smoothed 0.094 m RMS, 0.191 m worst, NEES 2.12
/// per horizontal axis (1.90, 2.45, 1.99 in the three windows); forward 0.52 m RMS, 1.52 m
/// worst, NEES 1.07; the data sheet's random walks ×1.3 from the windows' ends and ×8.2
/// more from the trial gaps (their NEES 9.8 at ×1: a walker's steps shake a MEMS far more
/// than its data sheet says). Before the trial gaps: smoothed 0.128 / 0.242 m with NEES 8.5
/// (18.7 in the first window: 2 cm σ against 8 cm errors), forward 1.31 / 4.00 m; before
/// every fix was used and the run restarted from its smoothed start: smoothed 0.26 /
/// 0.51 m, forward 4.9 / 12.3 m, NEES 97 and 34.
#[test]
fn the_walk_bridges_ten_second_windows() {
    let Some(dir) = testkit::shared_data(&format!("{SET}/walk_0827")) else {
        return;
    };
    let job = InsJob {
        imu_csv: dir.join("imu_1730.csv"),
        imu_format: ins::job::ImuFormat::RtklibCsv,
        imu_tag: dir.join("imu_1730.csv.tag"),
        gnss: dir.join("gnss_1730_sf.pos"),
        spec: ImuSpec::preset(Grade::Mems),
        mount: Euler {
            roll: 180f64.to_radians(),
            pitch: 0.0,
            heading: (-90f64).to_radians(),
        },
        imu_time_offset: 0.0,
        lever_arm: Vector3::new(0.0, -0.05, 0.0),
        no_side_slip: None,
        withhold: vec![(20.0, 30.0), (50.0, 60.0), (75.0, 85.0)],
        every: 1,
        phases: None,
    };
    let done = run_job(&job).unwrap();
    let pos = read_pos(&dir.join("gnss_1730_sf.pos")).unwrap();
    let sm: Vec<(Epoch, Estimate, Mat)> = done
        .run
        .smoothed
        .iter()
        .map(|(t, s)| (*t, s.est, s.cov))
        .collect();
    let f = outages(&pos, &done.run.forward, &job.lever_arm, &job.withhold);
    let s = outages(&pos, &sm, &job.lever_arm, &job.withhold);
    eprintln!(
        "walk: {} fixes used ({} unused); noise ×{:.1} from {} gaps; windows ({} RTK epochs): forward RMS {:.3} m worst {:.3} m NEES {:.2}; smoothed RMS {:.3} m worst {:.3} m NEES {:.2}",
        done.run.nis.len(),
        done.run.unused_fixes,
        done.bridge_scale.0,
        done.bridge_scale.1,
        s.n,
        f.rms,
        f.worst,
        f.nees,
        s.rms,
        s.worst,
        s.nees
    );
    for w in &job.withhold {
        let f1 = outages(&pos, &done.run.forward, &job.lever_arm, &[*w]);
        let s1 = outages(&pos, &sm, &job.lever_arm, &[*w]);
        eprintln!(
            "  window {:.0}–{:.0} s: forward RMS {:.3} m NEES {:.2}; smoothed RMS {:.3} m NEES {:.2}",
            w.0, w.1, f1.rms, f1.nees, s1.rms, s1.nees
        );
    }
    assert_eq!(s.n, 123, "the windows hold 123 fixed epochs");
    assert!(
        s.rms < 0.12 && s.worst < 0.25,
        "smoothed {} {}",
        s.rms,
        s.worst
    );
    assert!(
        f.rms < 1.0 && f.worst < 2.5,
        "forward {} {}",
        f.rms,
        f.worst
    );
    assert!(
        (0.3..=3.0).contains(&f.nees) && (0.3..=3.0).contains(&s.nees),
        "NEES {} {}",
        f.nees,
        s.nees
    );
}
