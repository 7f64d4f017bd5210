//! SP3 (c and d) precise orbits and clocks, interpolated by Lagrange polynomials.

use super::kepler::{SatPosClock, C};
use crate::error::{Error, Result};
use crate::frame::Ecef;
use crate::rinex::body::DateCols;
use crate::rinex::lines::{cols, parse_real, Lines};
use crate::sv::Sv;
use hifitime::{Epoch, TimeScale};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::path::Path;

/// Points used by the interpolator (degree 10 over 15-minute samples: millimetres).
const NPTS: usize = 11;

/// Epoch line `*  yyyy mm dd hh mm ss.ssssssss`.
const EPOCH: DateCols = DateCols {
    ymdhm: [(3, 7), (8, 10), (11, 13), (14, 16), (17, 19)],
    sec: (20, 31),
    two_digit_years: false,
};

/// Precise orbits: per satellite, samples on the file's epoch grid.
#[derive(Clone, Debug, Default)]
pub struct Sp3 {
    /// The file's epochs (GPST).
    pub epochs: Vec<Epoch>,
    /// Per satellite: position (m) and clock (s, NaN when absent) at each epoch; NaN position = absent.
    pub sats: BTreeMap<Sv, Vec<(Vector3<f64>, f64)>>,
}

impl Sp3 {
    /// Read an SP3-c or SP3-d file (plain or gzip).
    pub fn read(path: &Path) -> Result<Sp3> {
        let mut src = Lines::open(path)?;
        let first = src
            .next_line()?
            .ok_or_else(|| Error::input(path, "the file is empty"))?
            .to_vec();
        if first.first() != Some(&b'#') || !matches!(first.get(1), Some(b'c' | b'd' | b'a' | b'b'))
        {
            return Err(Error::input(
                path,
                "not an SP3 file (first line does not start with #c or #d)",
            ));
        }
        let mut sp3 = Sp3::default();
        let mut scale = TimeScale::GPST;
        loop {
            let ln = src.line_no + 1;
            let Some(line) = src.next_line()? else { break };
            match line.first() {
                Some(b'%') if line.starts_with(b"%c") && ln < 16 && sp3.epochs.is_empty() => {
                    match cols(line, 9, 12) {
                        b"UTC" => scale = TimeScale::UTC,
                        b"GAL" => scale = TimeScale::GST,
                        b"BDT" => scale = TimeScale::BDT,
                        b"TAI" => scale = TimeScale::TAI,
                        _ => {}
                    }
                }
                Some(b'*') => {
                    let e = EPOCH
                        .epoch(line, scale)
                        .ok_or_else(|| Error::parse(path, ln, "unreadable SP3 epoch line"))?;
                    sp3.epochs.push(e);
                    let n = sp3.epochs.len();
                    for v in sp3.sats.values_mut() {
                        v.resize(n, (Vector3::repeat(f64::NAN), f64::NAN));
                    }
                }
                Some(b'P') if !sp3.epochs.is_empty() => {
                    let Some(sv) = Sv::parse(cols(line, 1, 4)) else {
                        continue;
                    };
                    let f = |a| parse_real(cols(line, a, a + 14)).ok().flatten();
                    let (Some(x), Some(y), Some(z)) = (f(4), f(18), f(32)) else {
                        return Err(Error::parse(path, ln, "unreadable SP3 position"));
                    };
                    let clk = f(46)
                        .filter(|c| c.abs() < 999_999.0)
                        .map(|c| c * 1e-6)
                        .unwrap_or(f64::NAN);
                    let pos = if x == 0.0 && y == 0.0 && z == 0.0 {
                        Vector3::repeat(f64::NAN)
                    } else {
                        Vector3::new(x, y, z) * 1e3
                    };
                    let n = sp3.epochs.len();
                    let v = sp3
                        .sats
                        .entry(sv)
                        .or_insert_with(|| vec![(Vector3::repeat(f64::NAN), f64::NAN); n]);
                    v.resize(n, (Vector3::repeat(f64::NAN), f64::NAN));
                    v[n - 1] = (pos, clk);
                }
                Some(b'E') if line.starts_with(b"EOF") => break,
                _ => {}
            }
        }
        if sp3.epochs.len() < NPTS {
            return Err(Error::input(
                path,
                format!("only {} epochs: too few to interpolate", sp3.epochs.len()),
            ));
        }
        Ok(sp3)
    }

    /// Time span covered.
    pub fn span(&self) -> Option<(Epoch, Epoch)> {
        Some((*self.epochs.first()?, *self.epochs.last()?))
    }

    /// Interpolated position (centre of mass) and clock (relativistic correction added) at `t`.
    pub fn compute(&self, sv: Sv, t: Epoch) -> Option<SatPosClock> {
        let samples = self.sats.get(&sv)?;
        let n = self.epochs.len();
        let (t0, t1) = self.span()?;
        if t < t0 || t > t1 {
            return None;
        }
        let step = (self.epochs[1] - self.epochs[0]).to_seconds();
        let x = (t - t0).to_seconds() / step;
        let i = (x.floor() as usize).min(n - 1);
        let start = (i + 1).saturating_sub(NPTS / 2).min(n - NPTS);
        let idx = start..start + NPTS;
        let ts: Vec<f64> = idx
            .clone()
            .map(|k| (self.epochs[k] - t).to_seconds())
            .collect();
        let ps: Vec<Vector3<f64>> = idx.clone().map(|k| samples[k].0).collect();
        if ps.iter().any(|p| p.x.is_nan()) {
            return None;
        }
        let lag = |tt: f64| -> Vector3<f64> {
            let mut acc = Vector3::zeros();
            for j in 0..NPTS {
                let mut w = 1.0;
                for m in 0..NPTS {
                    if m != j {
                        w *= (tt - ts[m]) / (ts[j] - ts[m]);
                    }
                }
                acc += ps[j] * w;
            }
            acc
        };
        let pos = lag(0.0);
        let vel = (lag(0.05) - lag(-0.05)) / 0.1;
        // Clock: linear between the neighbouring samples.
        let j = i.min(n - 2);
        let (c0, c1) = (samples[j].1, samples[j + 1].1);
        let f = (t - self.epochs[j]).to_seconds() / step;
        let clock = c0 + (c1 - c0) * f;
        let rel = -2.0 * pos.dot(&vel) / (C * C);
        Some(SatPosClock {
            pos: Ecef(pos),
            vel,
            clock: clock + rel,
            clock_rate: (c1 - c0) / step,
        })
    }
}
