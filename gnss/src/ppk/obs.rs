//! Observations for carrier-phase processing: which signal of each system fills each frequency
//! slot, and per-epoch satellite measurements in cycles and metres.

use crate::orbit::Ephemerides;
use crate::rinex::{ObsCode, ObsEpoch, ObsHeader};
use crate::signal::frequency;
use crate::sv::{Constellation, Sv};

/// Number of frequency slots (L1-like, L2-like, L5-like).
pub const NF: usize = 3;

/// Band and preferred attributes per slot, best first.
fn slots(sys: Constellation) -> [(u8, &'static [u8]); NF] {
    match sys {
        Constellation::Gps => [(b'1', b"CWPXLS"), (b'2', b"WLXSCPD"), (b'5', b"QXI")],
        Constellation::Qzss => [(b'1', b"CXLS"), (b'2', b"LXS"), (b'5', b"QXI")],
        Constellation::Galileo => [(b'1', b"CXB"), (b'5', b"QXI"), (b'7', b"QXI")],
        Constellation::BeiDou => [(b'2', b"IXQ"), (b'6', b"IXQ"), (b'7', b"IXQ")],
        Constellation::Glonass => [(b'1', b"CP"), (b'2', b"CP"), (0, b"")],
        _ => [(0, b""), (0, b""), (0, b"")],
    }
}

/// Band digit of a slot of a system (0 when unused).
pub fn slot_band(sys: Constellation, slot: usize) -> u8 {
    slots(sys).get(slot).map(|s| s.0).unwrap_or(0)
}

/// Column indices of the phase, code and Doppler used for one slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotCols {
    /// Band digit.
    pub band: u8,
    /// Column of the phase.
    pub phase: usize,
    /// Column of the code (same attribute, else the best available).
    pub code: Option<usize>,
    /// Column of the Doppler, when present.
    pub doppler: Option<usize>,
    /// Column of the carrier-to-noise density (S), when present.
    pub snr: Option<usize>,
    /// The phase observation code.
    pub phase_code: ObsCode,
}

/// Which columns of a file feed each system's slots.
#[derive(Clone, Debug, Default)]
pub struct SignalPlan {
    /// Columns per system and slot.
    pub cols: std::collections::BTreeMap<Constellation, [Option<SlotCols>; NF]>,
}

impl SignalPlan {
    /// The plan of a header: per system and slot, the best signal present.
    pub fn new(h: &ObsHeader) -> Self {
        let mut plan = SignalPlan::default();
        for (&sys, types) in &h.obs_types {
            let mut row = [None; NF];
            for (k, (band, attrs)) in slots(sys).iter().enumerate() {
                if *band == 0 {
                    continue;
                }
                let find =
                    |kind: u8, attr: u8| types.iter().position(|t| t.0 == [kind, *band, attr]);
                let Some((phase, attr)) = attrs.iter().find_map(|&a| find(b'L', a).map(|i| (i, a)))
                else {
                    continue;
                };
                let code = find(b'C', attr).or_else(|| attrs.iter().find_map(|&a| find(b'C', a)));
                let doppler =
                    find(b'D', attr).or_else(|| attrs.iter().find_map(|&a| find(b'D', a)));
                let snr = find(b'S', attr).or_else(|| attrs.iter().find_map(|&a| find(b'S', a)));
                row[k] = Some(SlotCols {
                    band: *band,
                    phase,
                    code,
                    doppler,
                    snr,
                    phase_code: types[phase],
                });
            }
            plan.cols.insert(sys, row);
        }
        plan
    }
}

/// One satellite's measurements in one epoch; NaN where absent.
#[derive(Clone, Debug)]
pub struct SatMeas {
    /// The satellite.
    pub sv: Sv,
    /// Carrier frequency (Hz) per slot, NaN when the slot is unused.
    pub freq: [f64; NF],
    /// Carrier phase, cycles.
    pub l: [f64; NF],
    /// Pseudorange, metres.
    pub p: [f64; NF],
    /// Doppler, Hz.
    pub d: [f64; NF],
    /// Loss-of-lock indicator of the phase per slot (bit 0: a slip since the last epoch; bit
    /// 1: the half-cycle ambiguity not resolved, so the phase may be half a cycle off).
    pub lli: [u8; NF],
    /// Carrier-to-noise density per slot in quarters of a dB-Hz (0: the file has none; read
    /// it with [`SatMeas::cn0`]). Kept in a byte: a 10 Hz hour holds millions of these.
    pub snr: [u8; NF],
    /// How far that lies below the receiver's normal C/N0 for the satellite's elevation, in
    /// quarters of a dB ([`NO_DROP`]: unknown; read it with [`SatMeas::cn0_drop`], set by
    /// `ppk::snr`).
    pub snr_drop: [u8; NF],
    /// The code's variance measured on its receiver's own data for its C/N0 (m², NaN:
    /// not measured; read it with [`SatMeas::code_var`], set by `ppk::codenoise`). Single
    /// precision: a millimetre of σ more or less changes nothing.
    pub code_var: [f32; NF],
}

/// [`SatMeas::snr_drop`] unknown.
pub const NO_DROP: u8 = u8::MAX;

/// Loss-of-lock bit of an unresolved half-cycle ambiguity (RINEX LLI bit 1).
pub const LLI_HALF_CYCLE: u8 = 2;

impl SatMeas {
    /// C/N0 of slot `f`, dB-Hz (NaN when the file has none).
    pub fn cn0(&self, f: usize) -> f64 {
        match self.snr[f] {
            0 => f64::NAN,
            q => f64::from(q) * 0.25,
        }
    }

    /// Store a C/N0 (dB-Hz; not positive or not finite: none) for slot `f`, to a quarter dB.
    pub fn set_cn0(&mut self, f: usize, v: f64) {
        self.snr[f] = if v > 0.0 {
            (v * 4.0).round().clamp(1.0, 254.0) as u8
        } else {
            0
        };
    }

    /// How far (dB) the C/N0 of slot `f` lies below its receiver's normal (NaN unknown).
    pub fn cn0_drop(&self, f: usize) -> f64 {
        match self.snr_drop[f] {
            NO_DROP => f64::NAN,
            q => f64::from(q) * 0.25,
        }
    }

    /// Store a drop (dB; NaN: unknown) for slot `f`, to a quarter dB (at most 63.5 dB).
    pub fn set_cn0_drop(&mut self, f: usize, v: f64) {
        self.snr_drop[f] = if v.is_nan() {
            NO_DROP
        } else {
            (v.max(0.0) * 4.0).round().min(254.0) as u8
        };
    }

    /// The code variance of slot `f` measured on the receiver's own data, m² (NaN: not
    /// measured).
    pub fn code_var(&self, f: usize) -> f64 {
        f64::from(self.code_var[f])
    }

    /// Store a measured code variance (m²) for slot `f`.
    pub fn set_code_var(&mut self, f: usize, v: f64) {
        self.code_var[f] = v as f32;
    }

    /// Whether the phase of slot `f` may be half a cycle off (its half-cycle ambiguity not
    /// yet resolved by the receiver).
    pub fn half_cycle(&self, f: usize) -> bool {
        self.lli[f] & LLI_HALF_CYCLE != 0
    }

    /// Wavelength of slot `f`, metres.
    pub fn wavelength(&self, f: usize) -> f64 {
        crate::orbit::C / self.freq[f]
    }
}

/// Extract the measurements of the selected systems and slots.
pub fn extract(
    e: &ObsEpoch,
    h: &ObsHeader,
    plan: &SignalPlan,
    systems: &[Constellation],
    nf: usize,
    eph: &Ephemerides,
) -> Vec<SatMeas> {
    let mut out = Vec::with_capacity(e.sats.len());
    for s in &e.sats {
        if !systems.contains(&s.sv.sys) {
            continue;
        }
        let Some(row) = plan.cols.get(&s.sv.sys) else {
            continue;
        };
        let chan = h
            .glonass_channel(s.sv)
            .or_else(|| eph.glonass_channel(s.sv.prn));
        let mut m = SatMeas {
            sv: s.sv,
            freq: [f64::NAN; NF],
            l: [f64::NAN; NF],
            p: [f64::NAN; NF],
            d: [f64::NAN; NF],
            lli: [0; NF],
            snr: [0; NF],
            snr_drop: [NO_DROP; NF],
            code_var: [f32::NAN; NF],
        };
        let mut any = false;
        for (k, c) in row.iter().enumerate().take(nf) {
            let Some(c) = c else { continue };
            let Some(f) = frequency(s.sv.sys, c.band, chan) else {
                continue;
            };
            m.freq[k] = f;
            let l = s.get(c.phase);
            if l.is_present() && l.value != 0.0 {
                m.l[k] = l.value;
                m.lli[k] = l.lli;
                any = true;
            }
            if let Some(ci) = c.code {
                let p = s.get(ci).value;
                if p.is_finite() && p > 1.0e7 {
                    m.p[k] = p;
                }
            }
            if let Some(di) = c.doppler {
                m.d[k] = s.get(di).value;
            }
            if let Some(si) = c.snr {
                let v = s.get(si).value;
                m.set_cn0(k, v);
            }
        }
        if any {
            out.push(m);
        }
    }
    out
}
