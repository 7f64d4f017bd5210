//! `simulate --builtin ins`: a flight for the GNSS/INS with exact truth. An aircraft stands
//! still 30 s (where the IMU is levelled), accelerates east at 3 m/s² for 20 s and flies a
//! straight strip at 60 m/s for the rest of ten minutes; a tactical IMU at 200 Hz
//! ([`crate::imu`] errors) and GNSS antenna positions at 1 Hz (2 cm / 4 cm noise).
//!
//! Writes: `imu.csv` + `imu.csv.tag` (the RTKLIB-style raw log: g, °/s, ms ticks; the IMU's
//! axes are the body's), `gnss.pos`, `truth_ins.csv` (the IMU's truth at 10 Hz in the
//! columns `../shared/tools/insstat.py` reads) and `ins.toml` (the `ppkat ins --config` that
//! processes it, withholding the GNSS from 300 to 330 s).

use crate::imu::corrupt;
use crate::rng::Rng;
use crate::SimError;
use common::frame::{enu_rotation, Ecef, Geodetic};
use gnss::solution::{write_pos, PosFormat, PosRecord, Quality};
use hifitime::{Duration, Epoch, TimeScale};
use ins::attitude::{ned_to_ecef, Euler};
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

/// Still, then a straight acceleration east, then a straight strip (see the module's text).
struct Strip {
    origin: Geodetic,
}

impl Motion for Strip {
    fn at(&self, t: f64) -> Kinematics {
        let (t0, t1, a) = (30.0, 50.0, 3.0);
        let (s, v, acc) = if t < t0 {
            (0.0, 0.0, 0.0)
        } else if t < t1 {
            let u = t - t0;
            (0.5 * a * u * u, a * u, a)
        } else {
            let vmax = a * (t1 - t0);
            (0.5 * a * (t1 - t0).powi(2) + vmax * (t - t1), vmax, 0.0)
        };
        let to_ecef = enu_rotation(&self.origin).transpose();
        let position = Ecef(self.origin.to_ecef().0 + to_ecef * Vector3::new(s, 0.0, 0.0));
        let e = Euler {
            roll: 0.0,
            pitch: 0.0,
            heading: std::f64::consts::FRAC_PI_2,
        };
        Kinematics {
            position,
            velocity: to_ecef * Vector3::new(v, 0.0, 0.0),
            acceleration: to_ecef * Vector3::new(acc, 0.0, 0.0),
            attitude: ned_to_ecef(&position.to_geodetic()) * e.to_matrix(),
        }
    }
}

/// What was written.
#[derive(Clone, Debug)]
pub struct InsFlight {
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
            "ins flight: {} IMU samples (tactical, 200 Hz), {} GNSS epochs (1 Hz) → {}",
            self.samples,
            self.gnss,
            self.out.display()
        )?;
        writeln!(
            f,
            "  process: ppkat ins --config {0}/ins.toml; check: insstat.py {0}/ins.csv {0}/truth_ins.csv",
            self.out.display()
        )
    }
}

/// Simulate into `out` with `seed`.
pub fn run(out: &Path, seed: u64) -> Result<InsFlight, SimError> {
    std::fs::create_dir_all(out).map_err(|e| SimError::File {
        path: out.display().to_string(),
        what: format!("cannot create the folder: {e}"),
    })?;
    let m = Strip {
        origin: Geodetic::from_degrees(47.3, 8.5, 800.0),
    };
    let start = Epoch::from_gregorian(2026, 6, 1, 10, 0, 0, 0, TimeScale::GPST);
    let spec = ImuSpec::preset(Grade::Tactical);
    let n = (SPAN * RATE) as usize;
    let (imu, _) = corrupt(&ideal_imu(&m, start, RATE, n), &spec, seed);
    write_imu(out, start, &imu)?;
    let gnss = write_gnss(out, &m, start, seed)?;
    write_truth(out, &m, start)?;
    let lever = LEVER.map(|x| x.to_string()).join(",");
    let config = format!(
        "# ppkat ins --config ins.toml: the simulated strip (see simulate --builtin ins)\nimu = \"imu.csv\"\ngnss = \"gnss.pos\"\ngrade = \"tactical\"\nlever-arm = \"{lever}\"\nwithhold = [\"{},{}\"]\nevery = 20\nout = \"ins.csv\"\n",
        OUTAGE.0, OUTAGE.1
    );
    common::atomic::write_atomic(&out.join("ins.toml"), |w: &mut dyn Write| {
        w.write_all(config.as_bytes())
    })?;
    Ok(InsFlight {
        samples: imu.len(),
        gnss,
        out: out.to_path_buf(),
    })
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

/// GNSS antenna positions at 1 Hz with 2 cm / 4 cm noise, fixed.
fn write_gnss(out: &Path, m: &Strip, start: Epoch, seed: u64) -> Result<usize, SimError> {
    let mut rng = Rng::new(seed).fork(91);
    let lever = Vector3::from(LEVER);
    let recs: Vec<PosRecord> = (0..=SPAN as usize)
        .map(|s| {
            let k = m.at(s as f64);
            let rot = enu_rotation(&k.position.to_geodetic()).transpose();
            let sd = Vector3::new(0.02, 0.02, 0.04);
            let noise = rot
                * Vector3::new(
                    sd.x * rng.normal(),
                    sd.y * rng.normal(),
                    sd.z * rng.normal(),
                );
            PosRecord {
                time: start + Duration::from_seconds(s as f64),
                pos: Ecef(k.position.0 + k.attitude * lever + noise),
                quality: Quality::Fixed,
                nsat: 12,
                cov: rot * Matrix3::from_diagonal(&sd.component_mul(&sd)) * rot.transpose(),
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
fn write_truth(out: &Path, m: &Strip, start: Epoch) -> Result<(), SimError> {
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
