//! The page of a `ppkat ins` run (`OUT.html` beside its trajectory): the alignment, the GNSS
//! outages the IMU bridged (how long, how far the horizontal σ grew), and pictures of the
//! attitude and its σ over time, the position σ with the outages shaded, and the sensor
//! biases the filter estimated.
//!
//! What enters: the rows written (time, estimate, covariance), the GNSS epochs used, the
//! alignment and the run's summary line. What leaves: a self-contained HTML text.

use crate::errstate::Mat;
use crate::filter::Estimate;
use crate::gnss_pos::GnssEpoch;
use crate::loose::BRIDGE;
use crate::output::sigmas;
use hifitime::Epoch;
use plotters::prelude::*;
use report::plot::{axes, html_escape, range, svg, TimeAxis};
use std::fmt::Write as _;

/// What the page shows besides the rows.
pub struct PageInputs<'a> {
    /// The command's summary line(s).
    pub summary: &'a str,
    /// The GNSS epochs the filter used, in time order.
    pub used: &'a [&'a GnssEpoch],
    /// Alignment: time, roll, pitch (levelled), heading (from the course), radians.
    pub alignment: (Epoch, f64, f64, f64),
}

/// One row's values for the plots: attitude and σ (degrees), horizontal σ (m), gyro bias
/// (°/h) and accelerometer bias (mg).
struct Values {
    t: f64,
    att: [f64; 3],
    sd_att: [f64; 3],
    sd_h: f64,
    gyro: [f64; 3],
    accel: [f64; 3],
}

fn values(axis: &TimeAxis, rows: &[(Epoch, Estimate, Mat)]) -> Vec<Values> {
    rows.iter()
        .map(|(t, e, c)| {
            let sd = sigmas(e, c);
            let att = e.nav.euler();
            Values {
                t: axis.x(*t),
                att: [att.roll, att.pitch, att.heading].map(f64::to_degrees),
                sd_att: [sd[6], sd[7], sd[8]],
                sd_h: sd[0].hypot(sd[1]),
                gyro: (e.gyro_bias * (180.0 / std::f64::consts::PI * 3600.0)).into(),
                accel: (e.accel_bias / crate::spec::G0 * 1e3).into(),
            }
        })
        .collect()
}

/// The GNSS gaps longer than [`BRIDGE`] (the filter's bridges) within the rows' span: start, end.
fn outages(used: &[&GnssEpoch], first: Epoch, last: Epoch) -> Vec<(Epoch, Epoch)> {
    let mut out = Vec::new();
    let mut prev = first;
    for g in used.iter().map(|g| g.time).chain([last]) {
        if g < first {
            continue;
        }
        if (g - prev).to_seconds() > BRIDGE {
            out.push((prev, g.min(last)));
        }
        prev = g;
        if g >= last {
            break;
        }
    }
    out
}

/// Named series against time, titled, with the outages shaded.
fn series(
    title: &str,
    axis: &TimeAxis,
    t: &[f64],
    lines: &[(&str, Vec<f64>)],
    unit: &str,
    shade: &[(f64, f64)],
) -> String {
    let (t0, t1) = range(t.iter().copied());
    let (lo, hi) = range(lines.iter().flat_map(|l| l.1.iter().copied()));
    svg(title, |root| {
        let mut ch = axes(root, t0..t1, lo..hi, (&axis.desc, unit), 60)?;
        let fill = RGBColor(255, 220, 150).filled();
        ch.draw_series(
            shade
                .iter()
                .map(|(a, b)| Rectangle::new([(*a, lo), (*b, hi)], fill)),
        )?;
        for ((name, v), col) in lines.iter().zip([RED, BLUE, GREEN]) {
            ch.draw_series(LineSeries::new(
                t.iter().copied().zip(v.iter().copied()),
                col,
            ))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], col));
        }
        ch.configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .position(SeriesLabelPosition::UpperRight)
            .draw()?;
        Ok(())
    })
}

/// The three components of `get` as named series.
fn split<'a>(
    v: &[Values],
    names: [&'a str; 3],
    get: impl Fn(&Values) -> [f64; 3],
) -> Vec<(&'a str, Vec<f64>)> {
    (0..3)
        .map(|k| (names[k], v.iter().map(|x| get(x)[k]).collect()))
        .collect()
}

/// The page.
pub fn html(rows: &[(Epoch, Estimate, Mat)], p: &PageInputs) -> String {
    let mut s = String::from("<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>ppkat ins</title><style>body{font-family:sans-serif;max-width:960px;margin:auto}td,th{padding:2px 8px;text-align:right}pre{white-space:pre-wrap}</style></head><body>\n<h1>GNSS/INS</h1>\n");
    let _ = writeln!(s, "<pre>{}</pre>", html_escape(p.summary));
    let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
        return s + "<p>No rows.</p></body></html>\n";
    };
    let (t, roll, pitch, heading) = p.alignment;
    let _ = writeln!(
        s,
        "<h2>Alignment</h2><p>At {t}: levelled while still (roll {:.2}°, pitch {:.2}°), heading {:.1}° from the course once moving; σ 3° in roll and pitch, 10° in heading for a land vehicle (30° otherwise: a hand or a crab angle turns the body from its course) at the start, converging as the motion shows them.</p>",
        roll.to_degrees(),
        pitch.to_degrees(),
        heading.to_degrees()
    );
    let axis = TimeAxis::new(first.0, last.0);
    let v = values(&axis, rows);
    let gaps = outages(p.used, first.0, last.0);
    s += "<h2>GNSS outages bridged by the IMU</h2>";
    if gaps.is_empty() {
        s += &format!("<p>None longer than {BRIDGE} s.</p>\n");
    } else {
        s += "<table><tr><th>from</th><th>to</th><th>s</th><th>largest horizontal σ, m</th></tr>\n";
        for (a, b) in &gaps {
            let (xa, xb) = (axis.x(*a), axis.x(*b));
            let worst = v
                .iter()
                .filter(|x| (xa..=xb).contains(&x.t))
                .map(|x| x.sd_h)
                .fold(0.0, f64::max);
            let _ = writeln!(
                s,
                "<tr><td>{a}</td><td>{b}</td><td>{:.1}</td><td>{worst:.3}</td></tr>",
                (*b - *a).to_seconds()
            );
        }
        s += "</table>\n";
    }
    let shade: Vec<(f64, f64)> = gaps.iter().map(|(a, b)| (axis.x(*a), axis.x(*b))).collect();
    let t: Vec<f64> = v.iter().map(|x| x.t).collect();
    let rp = ["roll", "pitch", "heading"];
    let att = split(&v, rp, |x| x.att);
    s += &series("Roll and pitch (°)", &axis, &t, &att[..2], "°", &shade);
    s += &series("Heading (°)", &axis, &t, &att[2..], "°", &shade);
    let sd = split(&v, rp, |x| x.sd_att);
    s += &series(
        "Attitude σ (°), outages shaded",
        &axis,
        &t,
        &sd,
        "°",
        &shade,
    );
    let h = [("horizontal", v.iter().map(|x| x.sd_h).collect())];
    s += &series(
        "Horizontal position σ (m), outages shaded",
        &axis,
        &t,
        &h,
        "m",
        &shade,
    );
    let xyz = ["x (forward)", "y (right)", "z (down)"];
    let g = split(&v, xyz, |x| x.gyro);
    s += &series("Gyro biases (°/h)", &axis, &t, &g, "°/h", &shade);
    let a = split(&v, xyz, |x| x.accel);
    s += &series("Accelerometer biases (mg)", &axis, &t, &a, "mg", &shade);
    s + "</body></html>\n"
}

/// Write the page to `path` atomically.
pub fn write_page(
    path: &std::path::Path,
    rows: &[(Epoch, Estimate, Mat)],
    p: &PageInputs,
) -> crate::Result<()> {
    let text = html(rows, p);
    common::atomic::write_atomic(path, |w: &mut dyn std::io::Write| {
        w.write_all(text.as_bytes())
    })?;
    Ok(())
}
