//! Tests of slip mending on a scene of nine satellites over a walking receiver.

use super::*;
use crate::ppk::obs::NO_DROP;
use crate::sv::Constellation;
use hifitime::Duration;

const F: f64 = 1575.42e6;

/// Nine satellites over a walking receiver at 1 Hz with a wandering clock: `phase(e, k)`
/// gives the true phase (cycles) of satellite `k` at epoch `e`, and the ranges the mending
/// reads are computed from positions 3 m off, differently at every epoch.
struct Scene {
    dirs: Vec<Vector3<f64>>,
}

impl Scene {
    fn new() -> Self {
        let dirs = (0..9)
            .map(|k| {
                let (az, el) = (0.7 * k as f64, 0.2 + 0.15 * k as f64);
                Vector3::new(el.cos() * az.sin(), el.cos() * az.cos(), el.sin())
            })
            .collect();
        Scene { dirs }
    }
    fn position(e: usize) -> Vector3<f64> {
        let t = e as f64;
        Vector3::new(1.3 * t, 0.4 * (0.3 * t).sin(), 0.0)
    }
    /// Geometric range less the satellite clock, m.
    fn range(&self, e: usize, k: usize) -> f64 {
        2.1e7 + (60.0 + 40.0 * k as f64) * e as f64 - self.dirs[k].dot(&Self::position(e))
    }
    fn phase(&self, e: usize, k: usize) -> f64 {
        let clock = 300.0 * e as f64 + 0.02 * (e * e) as f64;
        (self.range(e, k) + clock) / (crate::orbit::C / F)
    }
    fn meas(&self, e: usize, k: usize, extra: f64, lli: u8) -> SatMeas {
        SatMeas {
            sv: Sv::new(Constellation::Gps, k as u8 + 1),
            freq: [F, f64::NAN, f64::NAN],
            l: [self.phase(e, k) + extra, f64::NAN, f64::NAN],
            p: [f64::NAN; NF],
            d: [f64::NAN; NF],
            lli: [lli, 0, 0],
            snr: [180, 0, 0],
            snr_drop: [0, NO_DROP, NO_DROP],
            code_var: [f32::NAN; NF],
        }
    }
    /// The range of satellite `k` at epoch `e` from a position 3 m off.
    fn approx(&self, e: usize, k: usize) -> Range {
        let off = Vector3::new(3.0 * (e as f64).cos(), 2.0, -1.0);
        Some((self.range(e, k) - self.dirs[k].dot(&off), self.dirs[k]))
    }
}

/// A jump of one cycle, one of half a cycle and one of 17 without a flag are mended; a
/// loss of lock of three seconds with a new integer is joined to its arc; an arc that
/// began with its half cycle unresolved, half a cycle off, is left as the receiver gave
/// it when the receiver resolves it (its raw phase steps by the half cycle and its flag
/// clears: the filter's own business); a jump of 0.7 cycles cuts the arc.
#[test]
fn slips_are_mended_and_arcs_joined() {
    let s = Scene::new();
    let t0 = crate::time::gpst(2024, 1, 1, 0, 0, 0, 0);
    let n = 30;
    let times: Vec<Epoch> = (0..n)
        .map(|e| t0 + Duration::from_seconds(e as f64))
        .collect();
    // What each satellite's raw phase carries besides the truth, and its flags.
    let extra = |e: usize, k: usize| -> Option<(f64, u8)> {
        match k {
            0 => Some((if e >= 5 { 1.0 } else { 0.0 }, 0)),
            1 => Some((if e >= 7 { -0.5 } else { 0.0 }, 0)),
            2 => Some((if e >= 9 { 17.0 } else { 0.0 }, 0)),
            // lost at 10–12, back at 13 with another integer and the loss flagged
            3 => match e {
                10..=12 => None,
                13 => Some((-4321.0, 1)),
                _ => Some((if e > 13 { -4321.0 } else { 0.0 }, 0)),
            },
            // half a cycle off and unresolved until epoch 15, then right and resolved
            4 => Some(if e < 15 {
                (0.5, LLI_HALF_CYCLE)
            } else {
                (0.0, 0)
            }),
            5 => Some((if e >= 20 { 0.7 } else { 0.0 }, 0)),
            _ => Some((0.0, 0)),
        }
    };
    let mut meas: Vec<Vec<SatMeas>> = (0..n)
        .map(|e| {
            (0..9)
                .filter_map(|k| extra(e, k).map(|(x, lli)| s.meas(e, k, x, lli)))
                .collect()
        })
        .collect();
    let ranges: Vec<Vec<Range>> = meas
        .iter()
        .enumerate()
        .map(|(e, m)| {
            m.iter()
                .map(|x| s.approx(e, usize::from(x.sv.prn) - 1))
                .collect()
        })
        .collect();
    let done = mend(&times, &mut meas, &ranges, 10.0);
    assert_eq!(
        done,
        Mended {
            jumps: 3,
            bridged: 1,
            cut: 1,
            left: 0
        }
    );
    // Every corrected phase lies a constant from the truth over its arc: satellites 0–3
    // over the whole run, satellite 5 up to its cut; satellite 4 is the raw phase.
    for k in 0..9 {
        let offsets: Vec<(usize, f64)> = meas
            .iter()
            .enumerate()
            .filter_map(|(e, m)| {
                let x = m.iter().find(|x| usize::from(x.sv.prn) == k + 1)?;
                Some((e, x.l[0] - s.phase(e, k)))
            })
            .collect();
        let first = offsets[0].1;
        for &(e, o) in &offsets {
            let want = match k {
                5 if e >= 20 => 0.7,
                4 if e >= 15 => -0.5,
                _ => 0.0,
            };
            assert!(
                (o - first - want).abs() < 1e-6,
                "satellite {k} epoch {e}: {o}"
            );
        }
    }
    let sat = |e: usize, k: usize| meas[e].iter().find(|x| usize::from(x.sv.prn) == k + 1);
    assert_eq!(
        sat(14, 4).unwrap().lli[0],
        LLI_HALF_CYCLE,
        "flags as they were"
    );
    assert_eq!(
        sat(13, 3).unwrap().lli[0] & 1,
        0,
        "the joined arc is not cut"
    );
    assert_eq!(sat(20, 5).unwrap().lli[0] & 1, 1, "the 0.7 cycle jump cuts");
}

/// A satellite tracked on two frequencies is left to the geometry-free and
/// Melbourne–Wübbena tests: its jump is neither mended nor cut, while the same jump on a
/// single-frequency satellite is mended.
#[test]
fn dual_frequency_phases_are_left_to_their_own_tests() {
    let s = Scene::new();
    let t0 = crate::time::gpst(2024, 1, 1, 0, 0, 0, 0);
    let times: Vec<Epoch> = (0..10)
        .map(|e| t0 + Duration::from_seconds(e as f64))
        .collect();
    const F2: f64 = 1227.60e6;
    let mut meas: Vec<Vec<SatMeas>> = (0..10)
        .map(|e| {
            (0..9)
                .map(|k| {
                    let jump = if k < 2 && e >= 5 + k { 1.0 } else { 0.0 };
                    let mut m = s.meas(e, k, jump, 0);
                    if k == 0 {
                        m.freq[1] = F2;
                        m.l[1] = s.phase(e, k) * F2 / F;
                        m.snr[1] = 180;
                        m.snr_drop[1] = 0;
                    }
                    m
                })
                .collect()
        })
        .collect();
    let ranges: Vec<Vec<Range>> = (0..10)
        .map(|e| (0..9).map(|k| s.approx(e, k)).collect())
        .collect();
    let done = mend(&times, &mut meas, &ranges, 10.0);
    assert_eq!(
        done,
        Mended {
            jumps: 1,
            ..Mended::default()
        }
    );
    let l1 = |e: usize, k: usize| meas[e][k].l[0] - s.phase(e, k);
    assert!((l1(9, 0) - 1.0).abs() < 1e-6, "dual: raw jump kept");
    assert_eq!(meas[5][0].lli[0] & 1, 0, "dual: not cut");
    assert!(l1(9, 1).abs() < 1e-6, "single: mended");
}

/// Where the satellites' phases disagree by centimetres (30 s epochs, the ionosphere
/// moving), nothing is mended.
#[test]
fn nothing_is_mended_from_a_loose_fit() {
    let s = Scene::new();
    let t0 = crate::time::gpst(2024, 1, 1, 0, 0, 0, 0);
    let times: Vec<Epoch> = (0..10)
        .map(|e| t0 + Duration::from_seconds(e as f64))
        .collect();
    let mut meas: Vec<Vec<SatMeas>> = (0..10)
        .map(|e| {
            (0..9)
                .map(|k| {
                    let wander = 0.2 * ((e * (k + 1)) as f64).sin();
                    let jump = if k == 0 && e >= 5 { 1.0 } else { 0.0 };
                    s.meas(e, k, wander + jump, 0)
                })
                .collect()
        })
        .collect();
    let before = meas.clone();
    let ranges: Vec<Vec<Range>> = (0..10)
        .map(|e| (0..9).map(|k| s.approx(e, k)).collect())
        .collect();
    let done = mend(&times, &mut meas, &ranges, 10.0);
    assert_eq!(done, Mended::default());
    for (a, b) in meas.iter().flatten().zip(before.iter().flatten()) {
        assert_eq!(a.l[0].to_bits(), b.l[0].to_bits());
    }
}
