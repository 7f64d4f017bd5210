//! `simulate --builtin ins`: a flight for the GNSS/INS with exact truth. An aircraft stands
//! still 30 s (where the IMU is levelled), speeds up east to 60 m/s in 20 s and flies four
//! strips joined by three 180° procedure turns ([`crate::ins_motion::Survey`]; the turns
//! start at 170, 350 and 530 s) for ten minutes; an IMU of the chosen grade at 200 Hz
//! ([`crate::imu`] errors) and GNSS antenna positions at 1 Hz (2 cm / 4 cm noise).
//!
//! Writes: `imu.csv` + `imu.csv.tag` (the RTKLIB-style raw log: g, °/s, ms ticks; the IMU's
//! axes are the body's), `gnss.pos`, `truth_ins.csv` (the IMU's truth at 10 Hz in the
//! columns `../shared/tools/insstat.py` reads) and `ins.toml` (the `ppkat ins --config` that
//! processes it, withholding the GNSS from 299 to 329 s, in the second strip).

use crate::imu::corrupt;
use crate::ins_motion::Survey;
use crate::rng::Rng;
use crate::SimError;
use common::frame::{enu_rotation, Ecef, Geodetic};
use gnss::solution::{write_pos, PosFormat, PosRecord, Quality};
use hifitime::{Duration, Epoch, TimeScale};
use ins::inverse::{ideal_imu, Kinematics, Motion};
use ins::mech::NavState;
use ins::output::{state_columns, STATE_HEADER};
use ins::spec::{Grade, ImuSpec, G0};
use nalgebra::{Matrix3, Rotation3, Vector3};
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

/// The default seed.
pub const SEED: u64 = 68;
/// IMU rate, Hz.
const RATE: f64 = 200.0;
/// Length of the flight, s.
const SPAN: f64 = 600.0;
/// The outage `ins.toml` withholds (seconds from the first GNSS epoch, at 1 s).
pub const OUTAGE: (f64, f64) = (299.0, 329.0);
/// IMU → antenna, body frame (forward, right, down), m.
pub const LEVER: [f64; 3] = [0.2, 0.1, -1.5];
/// When the procedure turns start, s (each lasts [`Survey::turn_length`]: 65 s).
const TURNS: [f64; 3] = [170.0, 350.0, 530.0];

/// What was written.
#[derive(Clone, Debug)]
pub struct InsFlight {
    /// Image observations of the block photographed on the way.
    pub image_obs: usize,
    /// Its photographs.
    pub images: usize,
    /// The IMU's grade, as its preset names it.
    pub grade: String,
    /// IMU samples.
    pub samples: usize,
    /// GNSS epochs.
    pub gnss: usize,
    /// The folder.
    pub out: std::path::PathBuf,
}

impl std::fmt::Display for InsFlight {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "ins flight: {} IMU samples ({}, 200 Hz), {} GNSS epochs (1 Hz) → {}",
            self.samples,
            self.grade,
            self.gnss,
            self.out.display()
        )?;
        writeln!(
            f,
            "  process: ppkat ins --config {0}/ins.toml; check: insstat.py {0}/ins.csv {0}/truth_ins.csv",
            self.out.display()
        )?;
        writeln!(
            f,
            "  block: 3 strips, {2} photographs, {1} image observations; ppkat exposures --trajectory {0}/gnss.pos --times {0}/exposure_times.csv --ins {0}/ins.csv --format antenna -o {0}/antennas.csv, then ppkat adjust --project {0}/project.toml (or project_gnss_only.toml); truth: {0}/truth_block.toml",
            self.out.display(),
            self.image_obs,
            self.images
        )
    }
}

/// Simulate into `out` with `seed`.
pub fn run(out: &Path, seed: u64, grade: Grade) -> Result<InsFlight, SimError> {
    std::fs::create_dir_all(out).map_err(|e| SimError::File {
        path: out.display().to_string(),
        what: format!("cannot create the folder: {e}"),
    })?;
    let origin = Geodetic::from_degrees(47.3, 8.5, 800.0);
    let m = Survey::new(origin, SPAN, &TURNS);
    let start = Epoch::from_gregorian(2026, 6, 1, 10, 0, 0, 0, TimeScale::GPST);
    let spec = ImuSpec::preset(grade);
    let n = (SPAN * RATE) as usize;
    let (imu, _) = corrupt(&ideal_imu(&m, start, RATE, n), &spec, seed);
    write_imu(out, start, &imu)?;
    let gnss = write_gnss(out, &m, start, seed)?;
    write_truth(out, &m, start)?;
    let base = write_gnss_obs(out, &m, &origin, start, seed)?;
    let (images, image_obs) = crate::ins_block::write_block(out, &m, &origin, start, &LEVER, seed)?;
    let lever = LEVER.map(|x| x.to_string()).join(",");
    let config = format!(
        "# ppkat ins --config ins.toml: the simulated survey flight (see simulate --builtin ins)\nimu = \"imu.csv\"\ngnss = \"gnss.pos\"\ngrade = \"{}\"\nlever-arm = \"{lever}\"\nwithhold = [\"{},{}\"]\nevery = 20\nout = \"ins.csv\"\n# Tight coupling: the double-differenced phases of these files where the positions are withheld\n# rover = \"rover.obs\"\n# base = \"base.obs\"\n# nav = \"nav.rnx\"\n# base-pos = \"{:.4},{:.4},{:.4}\"\n# withheld-satellites = 3\n",
        grade_name(grade),
        OUTAGE.0,
        OUTAGE.1,
        base.x,
        base.y,
        base.z
    );
    common::atomic::write_atomic(&out.join("ins.toml"), |w: &mut dyn Write| {
        w.write_all(config.as_bytes())
    })?;
    Ok(InsFlight {
        image_obs,
        images,
        grade: spec.name,
        samples: imu.len(),
        gnss,
        out: out.to_path_buf(),
    })
}

/// The name `ppkat ins` reads for `grade`.
fn grade_name(grade: Grade) -> &'static str {
    match grade {
        Grade::Navigation => "navigation",
        Grade::Tactical => "tactical",
        Grade::Mems => "mems",
    }
}

/// The IMU log: a first row at the start, then one per sample (mean rates over it), and its
/// time tags (the first row at the tags' start, the last at their last tick).
fn write_imu(out: &Path, start: Epoch, imu: &[ins::imu::ImuSample]) -> Result<(), SimError> {
    let dt_ms = (1000.0 / RATE).round() as u64;
    let mut text = String::new();
    let mut row = |s: &ins::imu::ImuSample, tick: u64| {
        let f = s.dv / s.dt / G0;
        let w = s.dtheta / s.dt * (180.0 / std::f64::consts::PI);
        let _ = writeln!(
            text,
            "{:.7},{:.7},{:.7},{:.7},{:.7},{:.7},{tick}",
            f.x, f.y, f.z, w.x, w.y, w.z
        );
    };
    row(&imu[0], 1000);
    for (k, s) in imu.iter().enumerate() {
        row(s, 1000 + dt_ms * (k as u64 + 1));
    }
    common::atomic::write_atomic(&out.join("imu.csv"), |w: &mut dyn Write| {
        w.write_all(text.as_bytes())
    })?;
    let since =
        (start - Epoch::from_gregorian(1970, 1, 1, 0, 0, 0, 0, TimeScale::GPST)).to_seconds();
    let mut tag = b"TIMETAG RTKLIB demo5 (ppkat simulate)".to_vec();
    tag.resize(60, 0);
    tag.extend(1000u32.to_le_bytes());
    tag.extend((since.floor() as u32).to_le_bytes());
    tag.extend((since - since.floor()).to_le_bytes());
    let last = (dt_ms * imu.len() as u64) as u32;
    for (tick, off) in [(0u32, 0u32), (last, text.len() as u32)] {
        tag.extend(tick.to_le_bytes());
        tag.extend(off.to_le_bytes());
    }
    common::atomic::write_atomic(&out.join("imu.csv.tag"), |w: &mut dyn Write| {
        w.write_all(&tag)
    })?;
    Ok(())
}

/// A fixed GNSS antenna position of a body at `k` with the antenna `lever` from it (body,
/// m): the truth plus noise of 2 cm horizontally and 4 cm vertically drawn from `rng`, and
/// that covariance (ECEF).
pub fn noisy_antenna(k: &Kinematics, lever: &Vector3<f64>, rng: &mut Rng) -> (Ecef, Matrix3<f64>) {
    let rot = enu_rotation(&k.position.to_geodetic()).transpose();
    let sd = Vector3::new(0.02, 0.02, 0.04);
    let noise = rot
        * Vector3::new(
            sd.x * rng.normal(),
            sd.y * rng.normal(),
            sd.z * rng.normal(),
        );
    let cov = rot * Matrix3::from_diagonal(&sd.component_mul(&sd)) * rot.transpose();
    (Ecef(k.position.0 + k.attitude * lever + noise), cov)
}

/// GNSS antenna positions at 1 Hz with 2 cm / 4 cm noise, fixed.
fn write_gnss(out: &Path, m: &Survey, start: Epoch, seed: u64) -> Result<usize, SimError> {
    let mut rng = Rng::new(seed).fork(91);
    let lever = Vector3::from(LEVER);
    let recs: Vec<PosRecord> = (0..=SPAN as usize)
        .map(|s| {
            let (pos, cov) = noisy_antenna(&m.at(s as f64), &lever, &mut rng);
            PosRecord {
                time: start + Duration::from_seconds(s as f64),
                pos,
                quality: Quality::Fixed,
                nsat: 12,
                cov,
                age: 0.0,
                ratio: 0.0,
            }
        })
        .collect();
    write_pos(
        &out.join("gnss.pos"),
        &["ppkat simulate --builtin ins: the antenna, 2 cm / 4 cm noise".to_string()],
        &recs,
        PosFormat::Llh,
    )?;
    Ok(recs.len())
}

/// The IMU's truth at 10 Hz in insstat.py's columns.
fn write_truth(out: &Path, m: &Survey, start: Epoch) -> Result<(), SimError> {
    let mut text = format!("{STATE_HEADER}\n");
    for k in 0..=(SPAN * 10.0) as usize {
        let t = start + Duration::from_seconds(k as f64 * 0.1);
        let km = m.at(k as f64 * 0.1);
        let nav = NavState {
            time: t,
            position: km.position,
            velocity: km.velocity,
            attitude: Rotation3::from_matrix_unchecked(km.attitude),
        };
        let _ = writeln!(text, "{}", state_columns(t, &nav));
    }
    common::atomic::write_atomic(&out.join("truth_ins.csv"), |w: &mut dyn Write| {
        w.write_all(text.as_bytes())
    })?;
    Ok(())
}

/// Where the base stands: on the ground below the flight's start, 300 m west and 200 m south.
const BASE_ENU: [f64; 3] = [-300.0, -200.0, -500.0];

/// `rover.obs` (the antenna along the flight, 1 Hz), `base.obs` (1 Hz) and `nav.rnx`, as the
/// demo's receivers and errors (no cycle slips, no losses of lock): the phases a tightly
/// coupled run reads. Returns the base's position.
fn write_gnss_obs(
    out: &Path,
    m: &Survey,
    origin: &Geodetic,
    start: Epoch,
    seed: u64,
) -> Result<Vector3<f64>, SimError> {
    let mut s = crate::builtin("demo").expect("the demo scenario");
    s.seed = seed;
    let end = start + Duration::from_seconds(SPAN);
    let (_, eph, klob) = crate::broadcast_orbits(out, start, end, &s)?;
    let rover_pos = |t: Epoch| crate::ins_block::antenna_at(m, (t - start).to_seconds(), &LEVER);
    let base = common::frame::Enu(Vector3::from(BASE_ENU)).to_ecef(&origin.to_ecef());
    let base_pos = move |_t: Epoch| base;
    let root = Rng::new(seed);
    for (name, pos, clock, fork) in [
        (
            "ROVER",
            &rover_pos as &dyn Fn(Epoch) -> Ecef,
            (2.0e-4, 3.0e-9),
            5,
        ),
        (
            "BASE",
            &base_pos as &dyn Fn(Epoch) -> Ecef,
            (-1.0e-4, -2.0e-9),
            6,
        ),
    ] {
        let r = crate::gnss_obs::Receiver {
            name,
            pos,
            clock,
            start,
            end,
            interval: 1.0,
            events: &[],
            faults: false,
            lose_lock: &[],
            glonass_phase_icb: 0.0,
            glonass_code_icb: 0.0,
        };
        let (text, _) = crate::gnss_obs::simulate(&r, &eph, &klob, &s.errors, &root.fork(fork));
        let file = if name == "ROVER" {
            "rover.obs"
        } else {
            "base.obs"
        };
        crate::io::write(out, file, &text)?;
    }
    Ok(base.0)
}
