//! The faults of the long-baseline pair's `faults/` copy (issue 67): what a 256 km real pair
//! showed as four epochs metres off with centimetre σ. Two kinds, each of which the filter's
//! own σ do not know of:
//! - slips nobody flags: at [`SLIP_EPOCHS`] the rover's strongest GPS satellite slips by one
//!   cycle on L1 and one on L2 with no loss-of-lock indicator (a jump the geometry-free
//!   combination sees as 5 cm over 30 s, where the ionosphere of 250 km moves as much, and
//!   the Melbourne–Wübbena combination not at all);
//! - a bad orbit: satellite G[`BAD_PRN`]'s set of [`BAD_TOE`] (used from 09:00 to 11:00) puts
//!   it [`BAD_ALONG_TRACK_M`] m along its track from the truth, the other sets are right.
//!
//! What enters: the observation and navigation texts as the pair's simulation wrote them.
//! What leaves: the texts with the faults, and what was done (for the README and the tests).

use super::constellation::{off_gps_records, split_records, GpsLayout};
use hifitime::Epoch;

/// The epochs (index at 30 s from 00:00) at which the strongest GPS satellite slips.
pub const SLIP_EPOCHS: [usize; 3] = [960, 1680, 2400];
/// The slip on L1 and L2, cycles.
pub const SLIP_CYCLES: (f64, f64) = (1.0, 1.0);
/// The satellite with a bad set.
pub const BAD_PRN: u8 = 12;
/// The time of ephemeris of the bad set, as a RINEX navigation record writes it.
pub const BAD_TOE: &str = "2024 03 20 10 00 00";
/// How far the bad set puts the satellite along its track, metres.
pub const BAD_ALONG_TRACK_M: f64 = 30.0;

/// One slip put in: the satellite and the epoch (index) from which its phases are off.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Slip {
    /// The satellite, e.g. `G17`.
    pub sv: String,
    /// The epoch index.
    pub epoch: usize,
}

/// The rover's observation text with the unflagged slips, and the slips.
pub fn slips(text: &str) -> (String, Vec<Slip>) {
    let types = gps_types(text);
    let col = |name: &str| types.iter().position(|t| t == name);
    let (Some(l1), Some(l2), Some(s1)) = (
        types.iter().position(|t| t.starts_with("L1")),
        types.iter().position(|t| t.starts_with("L2")),
        col("S1C"),
    ) else {
        return (text.to_string(), Vec::new());
    };
    let lines: Vec<&str> = text.lines().collect();
    let mut chosen: Vec<Slip> = Vec::new();
    let mut epoch: Option<usize> = None;
    // First pass: the strongest satellite of each slip epoch.
    for (i, l) in lines.iter().enumerate() {
        if l.starts_with("> ") {
            epoch = Some(epoch.map_or(0, |e| e + 1));
            if let Some(e) = epoch.filter(|e| SLIP_EPOCHS.contains(e)) {
                let n: usize = l
                    .get(32..35)
                    .and_then(|f| f.trim().parse().ok())
                    .unwrap_or(0);
                let end = (i + 1 + n).min(lines.len());
                let best = lines[i + 1..end]
                    .iter()
                    .filter(|s| s.starts_with('G'))
                    .max_by(|a, b| value(a, s1).total_cmp(&value(b, s1)));
                if let Some(b) = best {
                    chosen.push(Slip {
                        sv: b[..3].to_string(),
                        epoch: e,
                    });
                }
            }
        }
    }
    // Second pass: every phase of a chosen satellite from its epoch on moved.
    let mut out = String::with_capacity(text.len());
    let mut epoch: Option<usize> = None;
    for l in &lines {
        if l.starts_with("> ") {
            epoch = Some(epoch.map_or(0, |e| e + 1));
        }
        let e = epoch.unwrap_or(0);
        let hit = chosen.iter().any(|s| l.starts_with(&s.sv) && e >= s.epoch);
        if hit {
            out.push_str(&moved(l, &[(l1, SLIP_CYCLES.0), (l2, SLIP_CYCLES.1)]));
        } else {
            out.push_str(l);
        }
        out.push('\n');
    }
    (out, chosen)
}

/// The GPS observation types of the header.
fn gps_types(text: &str) -> Vec<String> {
    text.lines()
        .take_while(|l| !l.contains("END OF HEADER"))
        .filter(|l| l.starts_with('G') && l.contains("SYS / # / OBS TYPES"))
        .flat_map(|l| {
            l[7..58]
                .split_whitespace()
                .map(String::from)
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The value of field `k` of a satellite line (NaN when blank).
fn value(line: &str, k: usize) -> f64 {
    let a = 3 + 16 * k;
    line.get(a..a + 14)
        .and_then(|f| f.trim().parse().ok())
        .unwrap_or(f64::NAN)
}

/// A satellite line with fields `(k, cycles)` moved by that many cycles (blank ones left).
fn moved(line: &str, by: &[(usize, f64)]) -> String {
    let mut s = line.to_string();
    for &(k, d) in by {
        let v = value(line, k);
        if v.is_finite() {
            let a = 3 + 16 * k;
            s.replace_range(a..a + 14, &format!("{:14.3}", v + d));
        }
    }
    s
}

/// The navigation text with G[`BAD_PRN`]'s set of [`BAD_TOE`] replaced by one
/// [`BAD_ALONG_TRACK_M`] along its track.
pub fn bad_orbit(nav: &str, span: (Epoch, Epoch), seed: u64, gps: GpsLayout) -> String {
    let head = format!("G{BAD_PRN:02} {BAD_TOE}");
    let (_, bad) = split_records(
        &off_gps_records(span, seed, gps, BAD_PRN, BAD_ALONG_TRACK_M),
        &head,
    );
    let (rest, good) = split_records(nav, &head);
    if bad.is_empty() || good.is_empty() {
        return nav.to_string();
    }
    rest + &bad
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slip_moves_the_phases_of_its_satellite_from_its_epoch_on() {
        let head = "G    4 C1W L1C S1C L2W                                  SYS / # / OBS TYPES\n                                                            END OF HEADER\n";
        let mut text = head.to_string();
        for _ in 0..=961 {
            text += "> 2024 03 20 00 00  0.0000000  0  2\n";
            text += "G04  20679336.017 8 108200575.334 8        50.000    20679337.834 8\n";
            text += "G08  24381390.132 6 128923679.481 6        41.000    24381394.608 6\n";
        }
        // G04's S1C (50) beats G08's (41): G04's L1C and L2W move by a cycle from epoch 960.
        let (out, slips) = slips(&text);
        assert_eq!(
            slips,
            vec![Slip {
                sv: "G04".into(),
                epoch: 960
            }]
        );
        let g04: Vec<f64> = out
            .lines()
            .filter(|l| l.starts_with("G04"))
            .map(|l| value(l, 1))
            .collect();
        assert_eq!(g04[959], 108200575.334);
        assert_eq!(g04[960], 108200576.334);
        let l2: Vec<f64> = out
            .lines()
            .filter(|l| l.starts_with("G04"))
            .map(|l| value(l, 3))
            .collect();
        assert_eq!((l2[959], l2[961]), (20679337.834, 20679338.834));
        assert!(out
            .lines()
            .filter(|l| l.starts_with("G08"))
            .all(|l| value(l, 1) == 128923679.481));
    }
}
