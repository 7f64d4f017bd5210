//! `parameters.csv`: the additional parameters of an adjustment — lever arms, drifts, GNSS
//! latencies, interior orientations — one row per value with its σ and unit, in the order of
//! `report.json`. What enters: the [`Results`]; what leaves: the CSV text.

use super::estimated::Estimated;
use super::results::Results;
use std::fmt::Write as _;

/// The unit of value `label` of a parameter of `group`.
fn unit(group: &str, label: &str) -> &'static str {
    match (group, label.as_bytes().first()) {
        ("lever_arm", _) => "m",
        ("boresight", _) => "deg",
        ("drift", Some(b'a')) => "m",
        ("drift", _) => "m/s",
        ("latency", _) => "s",
        ("interior", _) if matches!(label, "f" | "x0" | "y0") => "m",
        _ => "",
    }
}

/// The CSV text: `group,name,label,value,sigma,unit,fixed,t0` (σ 0 when fixed; t0 in GPST
/// seconds for a drift, 0 otherwise).
pub fn csv(r: &Results) -> String {
    let mut s = String::from("# ppkat adjust: additional parameters; drift = GNSS antenna minus adjusted antenna (local ENU); latency: exposure = GNSS time + dt\ngroup,name,label,value,sigma,unit,fixed,t0\n");
    let groups: [(&str, &Vec<Estimated>); 5] = [
        ("lever_arm", &r.lever_arms),
        ("boresight", &r.boresights),
        ("drift", &r.drifts),
        ("latency", &r.latencies),
        ("interior", &r.interiors),
    ];
    for (group, list) in groups {
        for e in list {
            for (i, l) in e.labels.iter().enumerate() {
                let _ = writeln!(
                    s,
                    "{group},\"{}\",{l},{:.6e},{:.6e},{},{},{:.3}",
                    e.name,
                    e.values.get(i).copied().unwrap_or(f64::NAN),
                    e.sigmas.get(i).copied().unwrap_or(f64::NAN),
                    unit(group, l),
                    e.fixed,
                    e.t0
                );
            }
        }
    }
    s
}
