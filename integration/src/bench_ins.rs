//! `ppkat bench ins`: the loosely coupled GNSS/INS filter's wall time and memory on a long
//! simulated flight — a tactical IMU at the chosen rate circling with GNSS positions at 1 Hz
//! (`sim::imu` errors on `ins::inverse`'s ideal data), forward filter and smoother, outputs
//! at 10 Hz. The simulation is not timed.

use crate::bench::peak_rss_kib;
use gnss::frame::{enu_rotation, Geodetic};
use hifitime::{Duration, Epoch};
use ins::filter::{Estimate, PositionFix};
use ins::inverse::Circling;
use ins::inverse::{ideal_imu, Motion};
use ins::loose::LooseOptions;
use ins::mech::NavState;
use ins::spec::{Grade, ImuSpec};
use nalgebra::{Matrix3, Rotation3, Vector3};
use sim::imu::corrupt;
use std::time::Instant;

/// What the bench measured.
#[derive(Clone, Debug)]
pub struct InsBench {
    /// IMU samples processed.
    pub samples: usize,
    /// IMU rate, Hz.
    pub rate_hz: f64,
    /// GNSS updates.
    pub updates: usize,
    /// Outputs (checkpoints) smoothed.
    pub outputs: usize,
    /// Wall time of the forward filter and the smoother, s.
    pub seconds: f64,
    /// Peak resident memory, KiB (Linux).
    pub peak_kib: Option<u64>,
    /// Horizontal RMS of the smoothed positions against the truth, m (a sanity check).
    pub rms_h: f64,
}

impl std::fmt::Display for InsBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "bench ins: {} IMU samples at {} Hz ({:.1} min), {} GNSS updates, {} outputs smoothed",
            self.samples,
            self.rate_hz,
            self.samples as f64 / self.rate_hz / 60.0,
            self.updates,
            self.outputs
        )?;
        writeln!(
            f,
            "  forward + smoother as ppkat ins runs them (a first pass over the first 5 min for the start, the whole, again where the outages' ends ask, once more without the fixes of trial gaps to check the smoothed σ) {:.2} s ({:.0} samples/s); peak memory {}; smoothed horizontal RMS {:.3} m",
            self.seconds,
            self.samples as f64 / self.seconds.max(1e-9),
            self.peak_kib
                .map_or("unknown".into(), |k| format!("{:.0} MB", k as f64 / 1024.0)),
            self.rms_h
        )
    }
}

/// Simulate `minutes` of flight at `rate_hz` and time the filter over it.
pub fn run_bench(minutes: f64, rate_hz: f64) -> InsBench {
    let m = Circling {
        origin: Geodetic::from_degrees(47.3, 8.5, 800.0),
        radius: 1500.0,
        speed: 60.0,
        climb: 0.0,
    };
    let start = Epoch::from_gregorian_utc_at_midnight(2026, 6, 1);
    let spec = ImuSpec::preset(Grade::Tactical);
    let n = (minutes * 60.0 * rate_hz) as usize;
    let (imu, _) = corrupt(&ideal_imu(&m, start, rate_hz, n), &spec, 1);
    // A 30 s GNSS outage every ten minutes, for the check at the outages' ends.
    let fixes: Vec<(Epoch, PositionFix)> = (1..=(minutes * 60.0) as usize)
        .filter(|s| !(300..330).contains(&(s % 600)))
        .map(|s| {
            let k = m.at(s as f64);
            let rot = enu_rotation(&k.position.to_geodetic()).transpose();
            let cov =
                rot * Matrix3::from_diagonal(&Vector3::new(4e-4, 4e-4, 1.6e-3)) * rot.transpose();
            (
                start + Duration::from_seconds(s as f64),
                PositionFix {
                    position: k.position,
                    cov,
                },
            )
        })
        .collect();
    let k = m.at(0.0);
    let est = Estimate {
        nav: NavState {
            time: start,
            position: k.position,
            velocity: k.velocity,
            attitude: Rotation3::from_matrix_unchecked(k.attitude),
        },
        gyro_bias: Vector3::zeros(),
        accel_bias: Vector3::zeros(),
    };
    let mut p0 = ins::errstate::Mat::identity() * 1e-6;
    for i in 9..15 {
        p0[(i, i)] = 1e-8;
    }
    let o = LooseOptions {
        lever_arm: Vector3::zeros(),
        every: (rate_hz / 10.0).round().max(1.0) as usize,
        no_side_slip: None,
        still: Vec::new(),
        marks: Vec::new(),
    };
    let t = Instant::now();
    let (r, _, _) = ins::job::checked_run(
        &imu,
        (&fixes, &ins::tight::Phases::default()),
        (est, p0),
        &spec,
        &o,
    );
    let seconds = t.elapsed().as_secs_f64();
    let (mut ss, mut nn) = (0.0, 0usize);
    for (time, s) in &r.smoothed {
        let k = m.at((*time - start).to_seconds());
        let d = enu_rotation(&k.position.to_geodetic()) * (s.est.nav.position.0 - k.position.0);
        ss += d.xy().norm_squared();
        nn += 1;
    }
    InsBench {
        samples: imu.len(),
        rate_hz,
        updates: r.nis.len(),
        outputs: r.smoothed.len(),
        seconds,
        peak_kib: peak_rss_kib(),
        rms_h: (ss / nn.max(1) as f64).sqrt(),
    }
}
