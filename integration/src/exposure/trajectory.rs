//! A trajectory read from an RTKLIB-style `.pos` file (llh or xyz), and its interpolation at
//! arbitrary times: cubic Hermite with velocities from central differences, covariance
//! interpolated linearly, quality = worst of the epochs used, gaps and edges refused.

use gnss::error::{Error, Result};
use gnss::frame::{enu_rotation, Ecef, Geodetic};
use gnss::solution::Quality;
use hifitime::Epoch;
use nalgebra::{Matrix3, Vector3};
use std::path::Path;

/// One trajectory epoch.
#[derive(Clone, Debug)]
pub struct TrajPoint {
    pub time: Epoch,
    pub pos: Ecef,
    /// ECEF covariance, m².
    pub cov: Matrix3<f64>,
    pub quality: Quality,
}

/// An antenna trajectory sorted by time.
#[derive(Clone, Debug, Default)]
pub struct Trajectory {
    pub points: Vec<TrajPoint>,
    /// Nominal interval (median spacing), seconds.
    pub interval: f64,
    /// Ambiguity segment of each epoch: a new id whenever the solution enters or leaves the
    /// fixed state or crosses a gap longer than 2.5 intervals (the fixed ambiguity set lost).
    pub segments: Vec<u32>,
}

/// Why a time cannot be interpolated.
#[derive(Clone, Debug, PartialEq)]
pub enum InterpError {
    Outside,
    /// The bracketing epochs are this many seconds apart.
    Gap(f64),
}

/// An interpolated antenna position.
#[derive(Clone, Debug)]
pub struct Interpolated {
    pub pos: Ecef,
    pub vel: Vector3<f64>,
    pub cov: Matrix3<f64>,
    /// Worst quality of the epochs used.
    pub quality: Quality,
    /// Ambiguity segment of the epoch before `t`.
    pub segment: u32,
}

fn sqvar_inv(v: f64) -> f64 {
    v.signum() * v * v
}

fn quality_of(q: u8) -> Quality {
    match q {
        1 => Quality::Fixed,
        2 => Quality::Float,
        3 => Quality::Sbas,
        4 => Quality::Dgps,
        6 => Quality::Ppp,
        _ => Quality::Single,
    }
}

impl Trajectory {
    /// Read an RTKLIB-compatible `.pos` (llh or xyz; GPST; `%` comments).
    pub fn read_pos(path: &Path) -> Result<Trajectory> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let mut points = Vec::new();
        let mut xyz: Option<bool> = None;
        for (i, line) in text.lines().enumerate() {
            let l = line.trim();
            if l.starts_with('%') {
                if l.contains("x-ecef") {
                    xyz = Some(true);
                } else if l.contains("latitude") {
                    xyz = Some(false);
                }
                continue;
            }
            if l.is_empty() {
                continue;
            }
            let bad = |what: &str| Error::Parse {
                path: path.to_path_buf(),
                line: i + 1,
                what: what.to_string(),
            };
            let f: Vec<&str> = l.split_whitespace().collect();
            if f.len() < 6 {
                return Err(bad("too few columns for a .pos line (date time a b c Q …)"));
            }
            let time = parse_time(f[0], f[1]).ok_or_else(|| {
                bad("unreadable date/time (yyyy/mm/dd hh:mm:ss.sss GPST expected)")
            })?;
            let num = |k: usize| f.get(k).and_then(|x| x.parse::<f64>().ok());
            let (a, b, c) = (
                num(2).ok_or_else(|| bad("bad number"))?,
                num(3).ok_or_else(|| bad("bad number"))?,
                num(4).ok_or_else(|| bad("bad number"))?,
            );
            let is_xyz = xyz.unwrap_or(a.abs() > 1000.0);
            let pos = if is_xyz {
                Ecef::new(a, b, c)
            } else {
                Geodetic::from_degrees(a, b, c).to_ecef()
            };
            let q = f[5].parse::<u8>().map_err(|_| bad("bad quality flag"))?;
            let sd: Vec<f64> = (7..13).map(|k| num(k).unwrap_or(0.0)).collect();
            let cov = if is_xyz {
                Matrix3::new(
                    sd[0] * sd[0],
                    sqvar_inv(sd[3]),
                    sqvar_inv(sd[5]),
                    sqvar_inv(sd[3]),
                    sd[1] * sd[1],
                    sqvar_inv(sd[4]),
                    sqvar_inv(sd[5]),
                    sqvar_inv(sd[4]),
                    sd[2] * sd[2],
                )
            } else {
                // sdn sde sdu sdne sdeu sdun → ENU covariance → ECEF.
                let (n, e, u) = (sd[0], sd[1], sd[2]);
                let (ne, eu, un) = (sqvar_inv(sd[3]), sqvar_inv(sd[4]), sqvar_inv(sd[5]));
                let c_enu = Matrix3::new(e * e, ne, eu, ne, n * n, un, eu, un, u * u);
                let r = enu_rotation(&pos.to_geodetic());
                r.transpose() * c_enu * r
            };
            points.push(TrajPoint {
                time,
                pos,
                cov,
                quality: quality_of(q),
            });
        }
        if points.len() < 2 {
            return Err(Error::input(
                path,
                "the trajectory has fewer than two epochs",
            ));
        }
        points.sort_by(|a, b| {
            a.time
                .partial_cmp(&b.time)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        Ok(Trajectory::from_points(points))
    }

    pub fn from_points(points: Vec<TrajPoint>) -> Trajectory {
        let mut d: Vec<f64> = points
            .windows(2)
            .map(|w| (w[1].time - w[0].time).to_seconds())
            .filter(|x| *x > 0.0)
            .collect();
        d.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
        let interval = d.get(d.len() / 2).copied().unwrap_or(1.0);
        let mut segments = Vec::with_capacity(points.len());
        let mut id = 0u32;
        for (i, p) in points.iter().enumerate() {
            if i > 0 {
                let q = &points[i - 1];
                let gap = (p.time - q.time).to_seconds() > 2.5 * interval;
                if gap || (p.quality == Quality::Fixed) != (q.quality == Quality::Fixed) {
                    id += 1;
                }
            }
            segments.push(id);
        }
        Trajectory {
            points,
            interval,
            segments,
        }
    }

    pub fn span(&self) -> Option<(Epoch, Epoch)> {
        Some((self.points.first()?.time, self.points.last()?.time))
    }

    /// Velocity at point `i` from its neighbours (non-uniform central difference).
    fn velocity(&self, i: usize) -> Vector3<f64> {
        let p = &self.points;
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

    /// Position at `t`; refused outside the trajectory or across a gap longer than `max_gap`.
    pub fn interpolate(
        &self,
        t: Epoch,
        max_gap: f64,
    ) -> std::result::Result<Interpolated, InterpError> {
        let p = &self.points;
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
            segment: self.segments.get(a).copied().unwrap_or(0),
        })
    }
}

/// `yyyy/mm/dd` + `hh:mm:ss.sss` in GPST.
pub fn parse_time(date: &str, time: &str) -> Option<Epoch> {
    let d: Vec<i64> = date
        .split('/')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let mut tp = time.split(':');
    let (h, m, s) = (
        tp.next()?.parse::<i64>().ok()?,
        tp.next()?.parse::<i64>().ok()?,
        tp.next()?.parse::<f64>().ok()?,
    );
    if d.len() != 3 {
        return None;
    }
    let base = Epoch::maybe_from_gregorian(
        d[0] as i32,
        d[1] as u8,
        d[2] as u8,
        h as u8,
        m as u8,
        0,
        0,
        hifitime::TimeScale::GPST,
    )
    .ok()?;
    Some(base + hifitime::Duration::from_seconds(s))
}

#[cfg(test)]
mod segment_tests {
    use super::*;

    /// A new ambiguity segment whenever the fixed state is entered or left, or across a gap.
    #[test]
    fn segments_follow_fix_state_and_gaps() {
        let t0 = gnss::time::from_week_tow(2300, 1000.0);
        let q = [1u8, 1, 2, 2, 1, 1, 1, 1];
        let dt = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 10.0, 11.0];
        let pts = q
            .iter()
            .zip(dt)
            .map(|(&q, d)| TrajPoint {
                time: t0 + hifitime::Duration::from_seconds(d),
                pos: Ecef::new(4.2e6, 6.4e5, 4.7e6),
                cov: Matrix3::identity(),
                quality: quality_of(q),
            })
            .collect();
        let t = Trajectory::from_points(pts);
        assert_eq!(t.segments, vec![0, 0, 1, 1, 2, 2, 3, 3]);
        let ip = t
            .interpolate(t0 + hifitime::Duration::from_seconds(4.5), 3.0)
            .unwrap();
        assert_eq!(ip.segment, 2);
    }
}
