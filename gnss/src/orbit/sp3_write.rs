//! SP3-c text of an [`Sp3`]: the header (satellite list, accuracy, time system GPS) and, per
//! epoch, each satellite's position (km, 1 mm) and clock (µs, 1 ps; 999999.999999 where
//! absent). What [`Sp3::read`] reads back to the same millimetre; used by the simulator to
//! give its synthetic constellation as precise orbits.

use super::sp3::Sp3;
use crate::time::week_tow;
use hifitime::Epoch;
use std::fmt::Write;

/// Satellites per `+` (and `++`) header line.
const PER_LINE: usize = 17;

/// The SP3-c text of `sp3` (epochs GPST; a satellite without a position at an epoch is left
/// out of that epoch).
pub fn sp3_text(sp3: &Sp3) -> String {
    let mut t = String::new();
    header(&mut t, sp3);
    for (k, e) in sp3.epochs.iter().enumerate() {
        let _ = writeln!(t, "*  {}", calendar(*e));
        for (sv, v) in &sp3.sats {
            let (p, c) = v[k];
            if !p.iter().all(|x| x.is_finite()) {
                continue;
            }
            let clock = if c.is_finite() {
                c * 1e6
            } else {
                999_999.999_999
            };
            let _ = writeln!(
                t,
                "P{}{:14.6}{:14.6}{:14.6}{:14.6}",
                sv,
                p.x * 1e-3,
                p.y * 1e-3,
                p.z * 1e-3,
                clock
            );
        }
    }
    t.push_str("EOF\n");
    t
}

/// `yyyy mm dd hh mm ss.ssssssss` of a GPST epoch, as SP3 epoch lines and the first header
/// line write it.
fn calendar(e: Epoch) -> String {
    let (y, mo, d, h, mi, s, ns) = e.to_gregorian(hifitime::TimeScale::GPST);
    let sec = s as f64 + ns as f64 * 1e-9;
    format!("{y:4} {mo:2} {d:2} {h:2} {mi:2} {sec:11.8}")
}

/// The header lines: first line, GPS week line, satellite list, accuracies, `%c`, `%f`, `%i`
/// and comment lines.
fn header(t: &mut String, sp3: &Sp3) {
    let first = sp3.epochs.first().copied().unwrap_or_default();
    let frame: String = sp3.frame.chars().take(5).collect();
    let _ = writeln!(
        t,
        "#cP{} {:7} ORBIT {frame:>5} HLM  PPKT",
        calendar(first),
        sp3.epochs.len()
    );
    let (week, sow) = week_tow(first);
    let mjd = first.to_mjd_tai_days() - 19.0 / 86_400.0;
    let _ = writeln!(
        t,
        "## {week:4} {sow:15.8} {:14.8} {:5} {:15.13}",
        sp3.interval,
        mjd.floor() as i64,
        mjd - mjd.floor()
    );
    let ids: Vec<String> = sp3.sats.keys().map(|s| s.to_string()).collect();
    let lines = ids.len().div_ceil(PER_LINE).max(5);
    for l in 0..lines {
        let mut row = if l == 0 {
            format!("+  {:3}   ", ids.len())
        } else {
            "+        ".to_string()
        };
        for i in 0..PER_LINE {
            row += ids.get(l * PER_LINE + i).map_or("  0", |s| s.as_str());
        }
        let _ = writeln!(t, "{row}");
    }
    for l in 0..lines {
        let mut row = "++       ".to_string();
        for i in 0..PER_LINE {
            row += if l * PER_LINE + i < ids.len() {
                "  2"
            } else {
                "  0"
            };
        }
        let _ = writeln!(t, "{row}");
    }
    t.push_str("%c M  cc GPS ccc cccc cccc cccc cccc ccccc ccccc ccccc ccccc\n");
    t.push_str("%c cc cc ccc ccc cccc cccc cccc cccc ccccc ccccc ccccc ccccc\n");
    t.push_str("%f  1.2500000  1.025000000  0.00000000000  0.000000000000000\n");
    t.push_str("%f  0.0000000  0.000000000  0.00000000000  0.000000000000000\n");
    t.push_str("%i    0    0    0    0      0      0      0      0         0\n");
    t.push_str("%i    0    0    0    0      0      0      0      0         0\n");
    t.push_str("/* written by ppkat                                          \n");
    t.push_str("/* clocks without the relativistic correction -2 r.v/c^2     \n");
    t.push_str("/*                                                           \n");
    t.push_str("/*                                                           \n");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sv::{Constellation, Sv};
    use nalgebra::Vector3;
    use std::collections::BTreeMap;

    #[test]
    fn written_text_reads_back_to_the_millimetre() {
        let t0 = crate::time::gpst(2026, 11, 29, 23, 45, 0, 0);
        let epochs: Vec<Epoch> = (0..3)
            .map(|k| t0 + hifitime::Duration::from_seconds(300.0 * k as f64))
            .collect();
        let mut sats = BTreeMap::new();
        for prn in 1..=20u8 {
            let sv = Sv::new(
                if prn <= 18 {
                    Constellation::Gps
                } else {
                    Constellation::Galileo
                },
                prn,
            );
            let v: Vec<(Vector3<f64>, f64)> = (0..3)
                .map(|k| {
                    let f = prn as f64 * 1000.0 + k as f64;
                    let p = Vector3::new(1.5e7 + f, -2.1e7 - 3.3 * f, 8.0e6 + 0.1234567 * f);
                    let c = if prn == 5 && k == 1 {
                        f64::NAN
                    } else {
                        1e-4 - f * 1e-12
                    };
                    (p, c)
                })
                .collect();
            sats.insert(sv, v);
        }
        let sp3 = Sp3 {
            frame: "IGS20".into(),
            epochs: epochs.clone(),
            interval: 300.0,
            sats,
            ..Sp3::default()
        };
        let back = Sp3::read(&testkit::scratch_file("w.sp3", sp3_text(&sp3))).unwrap();
        assert_eq!(back.epochs, epochs);
        assert_eq!((back.version, back.frame.as_str()), ('c', "IGS20"));
        assert_eq!(back.interval, 300.0);
        assert_eq!(back.sats.len(), 20);
        for (sv, v) in &sp3.sats {
            for (k, (p, c)) in v.iter().enumerate() {
                let (q, d) = back.sats[sv][k];
                assert!((p - q).norm() < 1e-3, "{sv} {k}: {p} {q}");
                if c.is_nan() {
                    assert!(d.is_nan(), "{sv} {k}: an absent clock stays absent");
                } else {
                    assert!((c - d).abs() < 1e-12, "{sv} {k}: {c} {d}");
                }
            }
        }
    }
}
