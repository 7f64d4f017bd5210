//! Cycle-slip detection for one receiver: loss-of-lock indicators, geometry-free phase jumps,
//! Melbourne–Wübbena wide-lane jumps and data gaps. A slip resets only what it touches.

use super::obs::{SatMeas, NF};
use crate::orbit::C;
use crate::sv::Sv;
use hifitime::Epoch;
use std::collections::HashMap;

/// Why an ambiguity was reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SlipCause {
    LossOfLock,
    GeometryFree,
    MelbourneWubbena,
    Gap,
}

#[derive(Clone, Debug)]
struct Hist {
    t: Epoch,
    gf: f64,
    mw_mean: f64,
    mw_n: usize,
    lli: [u8; NF],
}

/// Per-receiver detector; `backward` passes read the loss-of-lock flag of the later epoch.
#[derive(Clone, Debug)]
pub struct SlipDetector {
    hist: HashMap<Sv, Hist>,
    /// Geometry-free jump threshold, metres.
    pub gf_threshold: f64,
    /// Melbourne–Wübbena jump threshold, wide-lane cycles.
    pub mw_threshold: f64,
    /// Longest tolerated gap, seconds.
    pub max_gap: f64,
    pub backward: bool,
}

impl SlipDetector {
    pub fn new(max_gap: f64, backward: bool) -> Self {
        SlipDetector {
            hist: HashMap::new(),
            gf_threshold: 0.05,
            mw_threshold: 4.0,
            max_gap,
            backward,
        }
    }

    /// Slips per frequency slot of `m` at `t` (None = no slip), and update the history.
    pub fn check(&mut self, t: Epoch, m: &SatMeas) -> [Option<SlipCause>; NF] {
        let mut out = [None; NF];
        let gf = if m.l[0].is_finite() && m.l[1].is_finite() {
            m.wavelength(0) * m.l[0] - m.wavelength(1) * m.l[1]
        } else {
            f64::NAN
        };
        let mw =
            if m.l[0].is_finite() && m.l[1].is_finite() && m.p[0].is_finite() && m.p[1].is_finite()
            {
                let (f1, f2) = (m.freq[0], m.freq[1]);
                let lw = C / (f1 - f2);
                (m.l[0] - m.l[1]) - (f1 * m.p[0] + f2 * m.p[1]) / ((f1 + f2) * lw)
            } else {
                f64::NAN
            };
        match self.hist.get(&m.sv) {
            None => {}
            Some(h) => {
                let gap = (t - h.t).to_seconds().abs();
                if gap > self.max_gap {
                    out = [Some(SlipCause::Gap); NF];
                } else {
                    for (f, o) in out.iter_mut().enumerate() {
                        let flag = if self.backward { h.lli[f] } else { m.lli[f] };
                        if flag & 1 != 0 {
                            *o = Some(SlipCause::LossOfLock);
                        }
                    }
                    if gf.is_finite() && h.gf.is_finite() && (gf - h.gf).abs() > self.gf_threshold {
                        out[0] = out[0].or(Some(SlipCause::GeometryFree));
                        out[1] = out[1].or(Some(SlipCause::GeometryFree));
                    }
                    if mw.is_finite() && h.mw_n >= 5 && (mw - h.mw_mean).abs() > self.mw_threshold {
                        out[0] = out[0].or(Some(SlipCause::MelbourneWubbena));
                        out[1] = out[1].or(Some(SlipCause::MelbourneWubbena));
                    }
                }
            }
        }
        let reset_mw = out[0].is_some() || out[1].is_some();
        let h = self.hist.entry(m.sv).or_insert(Hist {
            t,
            gf,
            mw_mean: 0.0,
            mw_n: 0,
            lli: m.lli,
        });
        h.t = t;
        h.gf = gf;
        h.lli = m.lli;
        if reset_mw || !mw.is_finite() {
            h.mw_n = 0;
            h.mw_mean = 0.0;
        }
        if mw.is_finite() {
            h.mw_n += 1;
            h.mw_mean += (mw - h.mw_mean) / h.mw_n as f64;
        }
        out
    }
}
