//! A rover trajectory in memory: epochs in GPST with ECEF position, full 3×3 ECEF covariance,
//! velocity when known, RTKLIB's Q, satellites, ratio, age and the ambiguity segment of each
//! epoch; its `.pos` serialisations ([`Trajectory::write_pos`], [`Trajectory::read_pos`]);
//! and its interpolation at arbitrary times ([`Trajectory::interpolate`]).
//!
//! # Ambiguity segments
//! A segment is a stretch of epochs over which the rover position rests on one set of
//! carrier-phase ambiguities, so that a constant GNSS offset (a wrong fix, an unmodelled
//! bias) is shared by its epochs; the joint adjustment estimates drift per segment. Ids start
//! at 0 and grow by one at each boundary, in time order.
//!
//! **Assigned by the filter** ([`SegmentSource::Filter`], what `ppk::process` returns). Each
//! pass starts a new segment at an epoch when, compared with its previous solved epoch,
//! - the solution enters the fixed state or leaves it;
//! - it is fixed in both and some ambiguity fixed in both (the same state, not reset in
//!   between) has a different integer: a re-fix. Integers are compared as differences
//!   between satellites of one system and slot, so a change of pivot is no re-fix, and an
//!   ambiguity reset by a slip has a new state whose integer is never compared with the old;
//! - more than 2.5 nominal intervals have passed (a gap);
//! - every ambiguity state was reset since (all-ambiguity reset).
//!
//! The combined (forward + backward) trajectory puts a boundary between two consecutive
//! output epochs wherever the combined Q changes; between two fixed epochs, unless a pass is
//! fixed at both within one of its segments and no pass fixed at both breaks between them
//! (a pass still float at the start of the other's fixed span adds nothing to the fix);
//! between two float epochs, wherever either pass has one (its segment id differs, or it
//! solved one epoch and not the other).
//!
//! **Derived from Q** ([`SegmentSource::DerivedFromQuality`]: a trajectory read from a `.pos`
//! file, ours or RTKLIB's, which does not carry them): a new segment whenever Q enters or
//! leaves the fixed state (1) or consecutive epochs are more than 2.5 nominal intervals
//! apart. Re-fixes cannot be seen in a file; reports say where the segments came from.
//!
//! # Interpolation
//! Cubic Hermite between the two epochs around t with velocities at the epochs (the known
//! velocity, else a second-order central difference of the positions), covariance
//! interpolated linearly, Q = the worst of the epochs used (neighbours included), segment =
//! that of the epoch before t. Times outside the trajectory or across a gap longer than a
//! given limit are refused.

use crate::error::{Error, Result};
use crate::frame::Ecef;
use crate::solution::{read_pos, write_pos, PosFormat, PosRecord, Quality};
use hifitime::Epoch;
use nalgebra::{Matrix3, Vector3};
use std::path::{Path, PathBuf};

/// One epoch of a trajectory.
#[derive(Clone, Debug)]
pub struct TrajectoryEpoch {
    /// GPST.
    pub time: Epoch,
    /// Antenna (or marker) position, ECEF.
    pub pos: Ecef,
    /// Position covariance, ECEF, m².
    pub cov: Matrix3<f64>,
    /// Velocity, ECEF, m/s, when the producer knows it.
    pub vel: Option<Vector3<f64>>,
    /// Solution quality (RTKLIB's Q).
    pub quality: Quality,
    /// Number of satellites.
    pub nsat: usize,
    /// Ambiguity ratio test value.
    pub ratio: f64,
    /// Age of differential corrections, seconds.
    pub age: f64,
    /// Ambiguity segment (see the module docs).
    pub segment: u32,
}

impl TrajectoryEpoch {
    /// An epoch with position, covariance and quality only (no velocity, no satellites,
    /// ratio or age; segment 0).
    pub fn new(time: Epoch, pos: Ecef, cov: Matrix3<f64>, quality: Quality) -> Self {
        TrajectoryEpoch {
            time,
            pos,
            cov,
            vel: None,
            quality,
            nsat: 0,
            ratio: 0.0,
            age: 0.0,
            segment: 0,
        }
    }

    /// The `.pos` line of this epoch.
    pub fn record(&self) -> PosRecord {
        PosRecord {
            time: self.time,
            pos: self.pos,
            quality: self.quality,
            nsat: self.nsat,
            cov: self.cov,
            age: self.age,
            ratio: self.ratio,
        }
    }

    fn from_record(r: PosRecord) -> Self {
        TrajectoryEpoch {
            time: r.time,
            pos: r.pos,
            cov: r.cov,
            vel: None,
            quality: r.quality,
            nsat: r.nsat,
            ratio: r.ratio,
            age: r.age,
            segment: 0,
        }
    }
}

/// How the ambiguity segments of a trajectory were obtained.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SegmentSource {
    /// Assigned by the carrier-phase filter from its ambiguity states.
    Filter,
    /// Derived from changes of Q and gaps, because the source (a file, when `file` is given)
    /// does not carry them.
    DerivedFromQuality {
        /// The file the trajectory was read from.
        file: Option<PathBuf>,
    },
}

impl SegmentSource {
    /// A sentence for reports when the segments were not assigned by the filter.
    pub fn note(&self) -> Option<String> {
        match self {
            SegmentSource::Filter => None,
            SegmentSource::DerivedFromQuality { file: Some(f) } => Some(format!(
                "ambiguity segments derived from Q changes and gaps of {}",
                f.display()
            )),
            SegmentSource::DerivedFromQuality { file: None } => {
                Some("ambiguity segments derived from Q changes and gaps".to_string())
            }
        }
    }
}

/// A trajectory sorted by time.
#[derive(Clone, Debug)]
pub struct Trajectory {
    /// The epochs, in time order.
    pub epochs: Vec<TrajectoryEpoch>,
    /// Nominal interval (median spacing of the epochs), seconds.
    pub interval: f64,
    /// Where the segment ids came from.
    pub segments_from: SegmentSource,
}

/// Why a time cannot be interpolated.
#[derive(Clone, Debug, PartialEq)]
pub enum InterpError {
    /// Before the first or after the last epoch.
    Outside,
    /// The bracketing epochs are this many seconds apart.
    Gap(f64),
}

/// A position interpolated on a trajectory.
#[derive(Clone, Debug)]
pub struct Interpolated {
    /// Position, ECEF.
    pub pos: Ecef,
    /// Velocity, ECEF, m/s (derivative of the interpolating cubic).
    pub vel: Vector3<f64>,
    /// Covariance, ECEF, m² (linear between the two epochs).
    pub cov: Matrix3<f64>,
    /// Worst quality of the epochs used.
    pub quality: Quality,
    /// Ambiguity segment of the epoch before `t`.
    pub segment: u32,
}

/// Median spacing of epochs, seconds (1 when there is none).
fn median_interval(epochs: &[TrajectoryEpoch]) -> f64 {
    crate::time::median_spacing(epochs.iter().map(|e| e.time))
}

impl Trajectory {
    /// A trajectory whose epochs (in time order) carry their segment ids, from `source`.
    pub fn new(epochs: Vec<TrajectoryEpoch>, source: SegmentSource) -> Trajectory {
        Trajectory {
            interval: median_interval(&epochs),
            epochs,
            segments_from: source,
        }
    }

    /// A trajectory of epochs (in time order) whose segment ids are derived from Q changes and
    /// gaps (see the module docs); `file` is where the epochs came from.
    pub fn with_derived_segments(
        mut epochs: Vec<TrajectoryEpoch>,
        file: Option<PathBuf>,
    ) -> Trajectory {
        let interval = median_interval(&epochs);
        let mut id = 0u32;
        for i in 0..epochs.len() {
            if i > 0 {
                let (q, p) = (&epochs[i - 1], &epochs[i]);
                let gap = (p.time - q.time).to_seconds() > 2.5 * interval;
                if gap || (p.quality == Quality::Fixed) != (q.quality == Quality::Fixed) {
                    id += 1;
                }
            }
            epochs[i].segment = id;
        }
        Trajectory {
            epochs,
            interval,
            segments_from: SegmentSource::DerivedFromQuality { file },
        }
    }

    /// Read an RTKLIB-compatible `.pos` (llh or xyz; GPST; `%` comments), ours or RTKLIB's;
    /// epochs sorted by time, segments derived from Q changes and gaps.
    pub fn read_pos(path: &Path) -> Result<Trajectory> {
        let mut epochs: Vec<TrajectoryEpoch> = read_pos(path)?
            .into_iter()
            .map(TrajectoryEpoch::from_record)
            .collect();
        if epochs.len() < 2 {
            return Err(Error::input(
                path,
                "the trajectory has fewer than two epochs",
            ));
        }
        epochs.sort_by(|a, b| {
            a.time
                .partial_cmp(&b.time)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        Ok(Trajectory::with_derived_segments(
            epochs,
            Some(path.to_path_buf()),
        ))
    }

    /// The `.pos` lines of the epochs.
    pub fn records(&self) -> Vec<PosRecord> {
        self.epochs.iter().map(TrajectoryEpoch::record).collect()
    }

    /// Write the trajectory as a `.pos` file (atomically): `%` header lines, column names,
    /// one line per epoch.
    pub fn write_pos(&self, path: &Path, header: &[String], format: PosFormat) -> Result<()> {
        write_pos(path, header, &self.records(), format)
    }

    /// Number of fixed epochs.
    pub fn fixed(&self) -> usize {
        self.epochs
            .iter()
            .filter(|e| e.quality == Quality::Fixed)
            .count()
    }

    /// First and last time.
    pub fn span(&self) -> Option<(Epoch, Epoch)> {
        Some((self.epochs.first()?.time, self.epochs.last()?.time))
    }

    /// Velocity at epoch `i`: the known one, else from its neighbours (non-uniform central
    /// difference; one-sided at the ends).
    fn velocity(&self, i: usize) -> Vector3<f64> {
        let p = &self.epochs;
        if let Some(v) = p[i].vel {
            return v;
        }
        let n = p.len();
        let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
        if a == i || b == i {
            let (a, b) = if a == i { (i, b) } else { (a, i) };
            return (p[b].pos.0 - p[a].pos.0) / (p[b].time - p[a].time).to_seconds();
        }
        let h1 = (p[i].time - p[a].time).to_seconds();
        let h2 = (p[b].time - p[i].time).to_seconds();
        // Second-order accurate derivative for unequal spacing.
        p[b].pos.0 * (h1 / (h2 * (h1 + h2))) - p[a].pos.0 * (h2 / (h1 * (h1 + h2)))
            + p[i].pos.0 * ((h2 - h1) / (h1 * h2))
    }

    /// Position at `t`; refused outside the trajectory or across a gap longer than `max_gap`
    /// seconds.
    pub fn interpolate(
        &self,
        t: Epoch,
        max_gap: f64,
    ) -> std::result::Result<Interpolated, InterpError> {
        let p = &self.epochs;
        let (t0, t1) = self.span().ok_or(InterpError::Outside)?;
        if t < t0 || t > t1 {
            return Err(InterpError::Outside);
        }
        let j = p.partition_point(|x| x.time <= t).clamp(1, p.len() - 1);
        let (a, b) = (j - 1, j);
        let h = (p[b].time - p[a].time).to_seconds();
        if h > max_gap {
            return Err(InterpError::Gap(h));
        }
        let s = if h > 0.0 {
            (t - p[a].time).to_seconds() / h
        } else {
            0.0
        };
        let (va, vb) = (self.velocity(a), self.velocity(b));
        let (s2, s3) = (s * s, s * s * s);
        let pos = p[a].pos.0 * (2.0 * s3 - 3.0 * s2 + 1.0)
            + va * (h * (s3 - 2.0 * s2 + s))
            + p[b].pos.0 * (-2.0 * s3 + 3.0 * s2)
            + vb * (h * (s3 - s2));
        let vel = (p[a].pos.0 * (6.0 * s2 - 6.0 * s)
            + va * (h * (3.0 * s2 - 4.0 * s + 1.0))
            + p[b].pos.0 * (-6.0 * s2 + 6.0 * s)
            + vb * (h * (3.0 * s2 - 2.0 * s)))
            / h.max(1e-9);
        // Quality: the worst of the epochs feeding the interpolation (neighbours included).
        let lo = a.saturating_sub(1);
        let hi = (b + 1).min(p.len() - 1);
        let quality = p[lo..=hi]
            .iter()
            .map(|x| x.quality)
            .max()
            .unwrap_or(Quality::Single);
        Ok(Interpolated {
            pos: Ecef(pos),
            vel,
            cov: p[a].cov * (1.0 - s) + p[b].cov * s,
            quality,
            segment: p[a].segment,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hifitime::Duration;

    fn epochs(q: &[Quality], dt: &[f64]) -> Vec<TrajectoryEpoch> {
        let t0 = crate::time::from_week_tow(2300, 1000.0);
        q.iter()
            .zip(dt)
            .map(|(&q, &d)| {
                TrajectoryEpoch::new(
                    t0 + Duration::from_seconds(d),
                    Ecef::new(4.2e6, 6.4e5, 4.7e6),
                    Matrix3::identity(),
                    q,
                )
            })
            .collect()
    }

    /// Derived segments: a new one whenever the fixed state is entered or left, or across a
    /// gap.
    #[test]
    fn segments_follow_fix_state_and_gaps() {
        use Quality::{Fixed as X, Float as F};
        let t = Trajectory::with_derived_segments(
            epochs(
                &[X, X, F, F, X, X, X, X],
                &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 10.0, 11.0],
            ),
            None,
        );
        let seg: Vec<u32> = t.epochs.iter().map(|e| e.segment).collect();
        assert_eq!(seg, vec![0, 0, 1, 1, 2, 2, 3, 3]);
        let t0 = t.epochs[0].time;
        let ip = t
            .interpolate(t0 + Duration::from_seconds(4.5), 3.0)
            .unwrap();
        assert_eq!(ip.segment, 2);
        assert!(t.segments_from.note().unwrap().contains("derived from Q"));
        assert_eq!(
            t.interpolate(t0 + Duration::from_seconds(7.0), 3.0)
                .unwrap_err(),
            InterpError::Gap(5.0)
        );
    }

    /// The `.pos` writer and reader are inverse to the precision of the format, in llh and
    /// xyz, covariance included; the reader derives segments and names the file.
    #[test]
    fn pos_round_trip() {
        use Quality::{Fixed as X, Float as F};
        let mut e = epochs(&[X, F, X], &[0.0, 0.2, 0.4]);
        for (k, x) in e.iter_mut().enumerate() {
            x.pos = Ecef(x.pos.0 + Vector3::new(1.0, -2.0, 0.5) * k as f64);
            x.cov = Matrix3::new(4e-4, 1e-4, -2e-5, 1e-4, 9e-4, 3e-5, -2e-5, 3e-5, 2.5e-3);
            x.nsat = 9;
            x.ratio = 12.5;
            x.age = 0.4;
        }
        let t = Trajectory::new(e, SegmentSource::Filter);
        let dir = testkit::scratch_dir("trajectory");
        for format in [PosFormat::Llh, PosFormat::Xyz] {
            let path = dir.join("t.pos");
            t.write_pos(&path, &["test".to_string()], format).unwrap();
            let r = Trajectory::read_pos(&path).unwrap();
            assert_eq!(r.epochs.len(), 3);
            for (a, b) in t.epochs.iter().zip(&r.epochs) {
                assert!((a.time - b.time).to_seconds().abs() < 1e-6);
                assert!((a.pos.0 - b.pos.0).norm() < 1e-3);
                assert!((a.cov - b.cov).abs().max() < 2e-5, "{format:?}");
                assert_eq!((a.quality, a.nsat), (b.quality, b.nsat));
                assert!((a.ratio - b.ratio).abs() < 0.1 && (a.age - b.age).abs() < 0.01);
            }
            let seg: Vec<u32> = r.epochs.iter().map(|e| e.segment).collect();
            assert_eq!(seg, vec![0, 1, 2]);
            assert_eq!(
                r.segments_from,
                SegmentSource::DerivedFromQuality { file: Some(path) }
            );
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
