//! What tight coupling did, for the reports: ambiguities fixed before (the PPK trajectory's
//! quality at each exposure) and after (all of an exposure's ambiguities held at integers in
//! the adjustment), and per exposure the σ of the projection centre from the float and the
//! final solution. Also [`true_integers`], which tests use to tell right fixes from wrong.

use super::dd_factor::{DdFactor, DdKind};
use super::project::Project;
use super::solve::Solved;
use super::tight::{Tight, AMBIGUITY, WIDE};
use gnss::frame::Ecef;
use hifitime::Epoch;
use photo::lsq::{ImageId, Key, Problem};
use serde::Serialize;
use std::collections::BTreeMap;

/// One exposure under tight coupling.
#[derive(Clone, Debug, Serialize)]
pub struct TightImage {
    /// The image.
    pub image: String,
    /// The PPK trajectory's quality at the exposure (1 fixed, 2 float).
    pub ppk_quality: u8,
    /// Double differences of phase used.
    pub phase_rows: usize,
    /// Every ambiguity of the exposure held at an integer.
    pub fixed: bool,
    /// 3D σ of the projection centre from the float solution, m.
    pub sigma_float: f64,
    /// 3D σ of the projection centre at the end, m.
    pub sigma_final: f64,
}

/// Tight coupling's part of the results.
#[derive(Clone, Debug, Serialize)]
pub struct TightSummary {
    /// Ambiguity blocks (first slot, or a later one without the first).
    pub ambiguities: usize,
    /// Wide-lane blocks.
    pub wide_lanes: usize,
    /// Double-difference ionosphere blocks.
    pub ionospheres: usize,
    /// Of the integer blocks, how many were held at integers.
    pub held: usize,
    /// Per fixing round: blocks held, decorrelated ambiguities fixed, ratio.
    pub rounds: Vec<(usize, usize, f64)>,
    /// Exposures carried by double differences.
    pub exposures: usize,
    /// Of them, fixed by the PPK trajectory (quality 1).
    pub exposures_ppk_fixed: usize,
    /// Of them, with every ambiguity held at an integer in the adjustment.
    pub exposures_fixed: usize,
    /// Images without double differences and why (they keep their loose antenna).
    pub missing: Vec<(String, String)>,
    /// Per exposure.
    pub images: Vec<TightImage>,
}

impl TightSummary {
    /// Lines for the terminal.
    pub fn lines(&self) -> String {
        let mut s = format!(
            "tight coupling: {} exposures by double differences; ambiguities fixed at {} of them (PPK: {}); {} of {} integer blocks held ({} wide lanes), {} ionospheres, {} rounds\n",
            self.exposures,
            self.exposures_fixed,
            self.exposures_ppk_fixed,
            self.held,
            self.ambiguities + self.wide_lanes,
            self.wide_lanes,
            self.ionospheres,
            self.rounds.len()
        );
        if !self.missing.is_empty() {
            s += &format!(
                "  {} images without double differences keep their loose antenna position (first: {} — {})\n",
                self.missing.len(),
                self.missing[0].0,
                self.missing[0].1
            );
        }
        s
    }
}

/// The summary of a tightly coupled adjustment (None when loose).
pub fn summary(p: &Project, s: &Solved) -> Option<TightSummary> {
    let t = s.built.tight.as_ref()?;
    let pr = &s.built.problem;
    let sigma = |i: usize| -> f64 {
        pr.covariance(Key::Pose(ImageId::from(i)), s.stats.sigma0)
            .ok()
            .flatten()
            .map_or(f64::NAN, |c| (c[(3, 3)] + c[(4, 4)] + c[(5, 5)]).sqrt())
    };
    let antenna_of: BTreeMap<&str, u8> = (p.antennas.iter())
        .map(|a| (a.image.as_str(), a.quality))
        .collect();
    let images: Vec<TightImage> = (t.factors.iter())
        .map(|(i, (ph, _))| TightImage {
            image: p.images[*i].id.clone(),
            ppk_quality: antenna_of
                .get(p.images[*i].id.as_str())
                .copied()
                .unwrap_or(0),
            phase_rows: ph
                .and_then(|f| pr.factor_as::<DdFactor>(f))
                .map_or(0, |f| f.rows().count()),
            fixed: t.image_fixed(pr, *i),
            sigma_float: t.sigma_float.get(i).copied().unwrap_or(f64::NAN),
            sigma_final: sigma(*i),
        })
        .collect();
    let count = |k: &str| t.blocks.iter().filter(|b| b.0 == k).count();
    Some(TightSummary {
        ambiguities: count(AMBIGUITY),
        wide_lanes: count(WIDE),
        ionospheres: count(super::tight::IONO),
        held: t.fixed.len(),
        rounds: t.rounds.clone(),
        exposures: images.len(),
        exposures_ppk_fixed: images.iter().filter(|x| x.ppk_quality == 1).count(),
        exposures_fixed: images.iter().filter(|x| x.fixed).count(),
        missing: t.missing.clone(),
        images,
    })
}

/// The true integer of every integer block (by the `n` of its key) that the phase factors
/// can tell, given the true antenna position (ECEF) of an image at a GPST time: the observed
/// double difference minus the true range, in cycles, rounded (a wide lane: the first
/// slot's minus the later slot's). For checking fixes against a simulation's truth.
pub fn true_integers(
    pr: &Problem,
    t: &Tight,
    antenna_at: &dyn Fn(usize, Epoch) -> Option<Ecef>,
) -> BTreeMap<usize, f64> {
    let mut out = BTreeMap::new();
    for (i, (ph, _)) in &t.factors {
        let Some(f) = ph.and_then(|f| pr.factor_as::<DdFactor>(f)) else {
            continue;
        };
        if f.kind() != DdKind::Phase {
            continue;
        }
        let Some(x) = antenna_at(*i, f.rover_time) else {
            continue;
        };
        let cycles = |a: &gnss::ppk::tight::DdAmbiguity| {
            let r = f.rows().find(|r| r.ambiguity == Some(*a))?;
            Some(((r.phase - r.range(&x.0).0) / r.wavelength).round())
        };
        for (n, (kind, a, b)) in t.blocks.iter().enumerate() {
            if out.contains_key(&n) {
                continue;
            }
            let v = match (*kind, b) {
                (AMBIGUITY, None) => cycles(a),
                (WIDE, Some(b)) => cycles(a).zip(cycles(b)).map(|(x, y)| x - y),
                _ => None,
            };
            if let Some(v) = v {
                out.insert(n, v);
            }
        }
    }
    out
}

/// The report's section on tight coupling: the counts before (PPK) and after, and the
/// exposures the PPK left float with the σ of their centres from the float and the final
/// solution (at most 300 rows; the JSON has them all).
pub fn html(s: &mut String, tight: Option<&TightSummary>) {
    use std::fmt::Write as _;
    let Some(t) = tight else { return };
    let _ = writeln!(
        s,
        "<h2>Tight coupling</h2><table><tr><th>exposures</th><th>fixed by PPK</th><th>fixed now</th><th>integer blocks held</th><th>wide lanes</th><th>ionospheres</th><th>rounds</th><th>without double differences</th></tr><tr><td>{}</td><td>{}</td><td>{}</td><td>{} of {}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr></table>",
        t.exposures,
        t.exposures_ppk_fixed,
        t.exposures_fixed,
        t.held,
        t.ambiguities + t.wide_lanes,
        t.wide_lanes,
        t.ionospheres,
        t.rounds.len(),
        t.missing.len()
    );
    let float: Vec<&TightImage> = t.images.iter().filter(|x| x.ppk_quality != 1).collect();
    if float.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "<p>Exposures the PPK left float ({}), σ of the projection centre (3D, m) from the float and the final adjustment:</p><table><tr><th>image</th><th>PPK Q</th><th>fixed now</th><th>phase DDs</th><th>σ float</th><th>σ final</th></tr>",
        float.len()
    );
    for x in float.iter().take(300) {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.4}</td><td>{:.4}</td></tr>",
            x.image,
            x.ppk_quality,
            if x.fixed { "yes" } else { "no" },
            x.phase_rows,
            x.sigma_float,
            x.sigma_final
        );
    }
    let _ = writeln!(s, "</table>");
}
