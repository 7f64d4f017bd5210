//! `ppk … --report OUT.html`: a self-contained page (inline SVG, no scripts, no network)
//! showing where a carrier-phase run fixed and where it did not — the ground track coloured
//! by Q with the rover's exposure events, time series of the satellites, the ratio, the σ
//! east/north/up, the forward − backward separation, the ambiguity resets of each pass and
//! the age of the base, the fix rate per Q, the ambiguity segments and the settings the run
//! used.
//!
//! Enters: a [`PpkReport`] (after the run), the `.pos` header lines (the settings) and the
//! rover's flag-5 event times. Leaves: the HTML text. Legends are HTML above each plot, so
//! they never cover data; long runs are thinned to at most [`MAX_POINTS`] drawn epochs per
//! series (the tables count every epoch).

use crate::plot::{axes, decimals, html_escape, range, svg_sized, tick, LengthAxis, TimeAxis};
use crate::ppk_summary::{PpkReport, Untimed};
use gnss::frame::{enu_rotation, Ecef};
use gnss::solution::Quality;
use gnss::time::format_ymdhms;
use gnss::trajectory::{Trajectory, TrajectoryEpoch};
use hifitime::Epoch;
use plotters::prelude::*;
use std::fmt::Write as _;

/// Most epochs drawn per series; longer runs are thinned evenly.
pub const MAX_POINTS: usize = 3000;

/// The qualities in legend order, with their names and colours.
const QUALITIES: [(Quality, &str, RGBColor); 6] = [
    (Quality::Fixed, "fixed", RGBColor(0, 150, 60)),
    (Quality::Float, "float", RGBColor(240, 140, 0)),
    (Quality::Sbas, "SBAS", RGBColor(120, 120, 120)),
    (Quality::Dgps, "DGPS", RGBColor(40, 90, 220)),
    (Quality::Single, "single", RGBColor(210, 30, 30)),
    (Quality::Ppp, "PPP", RGBColor(140, 60, 180)),
];

/// Colour of a quality.
fn colour(q: Quality) -> RGBColor {
    QUALITIES
        .iter()
        .find(|(k, ..)| *k == q)
        .map(|(.., c)| *c)
        .unwrap_or(BLACK)
}

/// An HTML legend line: a coloured mark and a label per entry.
fn legend(entries: &[(String, RGBColor, &str)]) -> String {
    let mut s = String::from("<p class=\"legend\">");
    for (label, RGBColor(r, g, b), mark) in entries {
        let _ = write!(
            s,
            "<span><b style=\"color:rgb({r},{g},{b})\">{mark}</b> {}</span>",
            html_escape(label)
        );
    }
    s + "</p>\n"
}

/// The legend of the qualities present, with their epoch counts.
fn quality_legend(tr: &Trajectory, extra: &[(String, RGBColor, &str)]) -> String {
    let mut e: Vec<(String, RGBColor, &str)> = QUALITIES
        .iter()
        .filter_map(|(q, name, c)| {
            let n = tr.epochs.iter().filter(|x| x.quality == *q).count();
            (n > 0).then(|| (format!("{name} ({n})"), *c, "●"))
        })
        .collect();
    e.extend(extra.iter().cloned());
    legend(&e)
}

/// The epochs drawn: every k-th so that at most [`MAX_POINTS`] remain.
fn thinned(tr: &Trajectory) -> Vec<&TrajectoryEpoch> {
    let k = tr.epochs.len().div_ceil(MAX_POINTS).max(1);
    tr.epochs.iter().step_by(k).collect()
}

/// The report page. `settings` are the `.pos` header lines, `events` the rover's exposure
/// event times (GPST receiver time tags).
pub fn html(r: &PpkReport, settings: &[String], events: &[Epoch]) -> String {
    let mut s = String::from("<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>ppkat ppk</title><style>body{font-family:sans-serif;max-width:960px;margin:auto}td,th{padding:2px 8px;text-align:right}th{background:#eee}td.l,th.l{text-align:left}pre{white-space:pre-wrap}.legend span{margin-right:1.5em}.legend b{font-size:1.2em}</style></head><body>\n");
    let _ = writeln!(
        s,
        "<h1>Carrier-phase positioning (PPK)</h1><pre>{}</pre>",
        html_escape(&Untimed(r).to_string())
    );
    let tr = &r.result.trajectory;
    s += &fix_table(r);
    let Some(axis) = tr.span().map(|(t0, t1)| TimeAxis::new(t0, t1)) else {
        s += "<p>No epoch was solved: nothing to draw.</p>";
        return s + &settings_table(settings) + "</body></html>\n";
    };
    s += &ground_track(tr, events);
    s += &satellites_and_ratio(tr, &axis);
    s += &sigmas(tr, &axis);
    s += &separation(&r.result.diagnostics, &axis, &r.result.base_marker);
    s += &resets(&r.result.diagnostics, &axis);
    s += &age(tr, &axis);
    s += &segment_table(tr);
    s += &settings_table(settings);
    s + "</body></html>\n"
}

/// Epochs per Q, with the unsolved rover epochs.
fn fix_table(r: &PpkReport) -> String {
    let tr = &r.result.trajectory;
    let n = tr.epochs.len();
    let mut s = String::from("<h2>Fix rate</h2><table><tr><th class=\"l\">solution</th><th>epochs</th><th>% of rover epochs</th></tr>\n");
    let pct = |k: usize| 100.0 * k as f64 / r.result.rover_epochs.max(1) as f64;
    for (q, name, _) in QUALITIES {
        let k = tr.epochs.iter().filter(|e| e.quality == q).count();
        if k > 0 {
            let _ = writeln!(
                s,
                "<tr><td class=\"l\">{name} (Q={})</td><td>{k}</td><td>{:.1}</td></tr>",
                q as u8,
                pct(k)
            );
        }
    }
    let un = r.result.rover_epochs.saturating_sub(n);
    let _ = writeln!(
        s,
        "<tr><td class=\"l\">not solved</td><td>{un}</td><td>{:.1}</td></tr><tr><th class=\"l\">rover epochs</th><th>{}</th><th>100.0</th></tr></table>",
        pct(un),
        r.result.rover_epochs
    );
    s
}

/// East and north (m) of `p` from `origin`.
fn east_north(origin: &Ecef, p: &Ecef) -> (f64, f64) {
    let d = p.enu_from(origin).0;
    (d.x, d.y)
}

/// The ground track at one scale for east and north, coloured by Q, exposures circled.
fn ground_track(tr: &Trajectory, events: &[Epoch]) -> String {
    let n = tr.epochs.len() as f64;
    let origin = Ecef(
        tr.epochs
            .iter()
            .map(|e| e.pos.0)
            .sum::<nalgebra::Vector3<f64>>()
            / n,
    );
    let pts: Vec<(f64, f64, Quality)> = thinned(tr)
        .into_iter()
        .map(|e| {
            let (x, y) = east_north(&origin, &e.pos);
            (x, y, e.quality)
        })
        .collect();
    let max_gap = 2.5 * median_step(tr);
    let marks: Vec<(f64, f64)> = events
        .iter()
        .filter_map(|t| tr.interpolate(*t, max_gap).ok())
        .map(|i| east_north(&origin, &i.pos))
        .collect();
    let (w, h) = (900u32, 700u32);
    // Plot area in pixels (margins 10 and 30 on the right, label areas 30 below and 70 left).
    let (pw, ph) = (f64::from(w - 40 - 70), f64::from(h - 20 - 30));
    let (x0, x1) = range(pts.iter().map(|p| p.0));
    let (y0, y1) = range(pts.iter().map(|p| p.1));
    let m = ((x1 - x0) / pw).max((y1 - y0) / ph);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let (hx, hy) = (m * pw / 2.0, m * ph / 2.0);
    let mut extra = Vec::new();
    if !events.is_empty() {
        extra.push((
            format!(
                "exposure events ({} of {} on the trajectory)",
                marks.len(),
                events.len()
            ),
            BLACK,
            "○",
        ));
    }
    let lab = LengthAxis::for_span(2.0 * hx.max(hy));
    let mut s = String::from("<h2>Ground track</h2>\n");
    s += &quality_legend(tr, &extra);
    s += &svg_sized(
        &format!(
            "East and north from the mean position ({}, same scale)",
            lab.unit
        ),
        (w, h),
        |root| {
            // Labels in the unit the span suits, and room on the right for the last east
            // label.
            let mut ch = ChartBuilder::on(root)
                .margin(10)
                .margin_right(30)
                .x_label_area_size(30)
                .y_label_area_size(70)
                .build_cartesian_2d(cx - hx..cx + hx, cy - hy..cy + hy)?;
            ch.configure_mesh()
                .x_desc(format!("east ({})", lab.unit))
                .y_desc(format!("north ({})", lab.unit))
                .x_label_formatter(&|v| lab.label(*v))
                .y_label_formatter(&|v| lab.label(*v))
                .draw()?;
            for (q, ..) in QUALITIES {
                ch.draw_series(
                    pts.iter()
                        .filter(|p| p.2 == q)
                        .map(|p| Circle::new((p.0, p.1), 2, colour(q).filled())),
                )?;
            }
            ch.draw_series(
                marks
                    .iter()
                    .map(|p| Circle::new(*p, 5, BLACK.stroke_width(1))),
            )?;
            Ok(())
        },
    );
    s
}

/// Median spacing of the trajectory's epochs, seconds (1 without two epochs).
fn median_step(tr: &Trajectory) -> f64 {
    let mut d: Vec<f64> = tr
        .epochs
        .windows(2)
        .map(|w| (w[1].time - w[0].time).to_seconds())
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(1.0)
}

/// Satellites and the ratio per epoch, coloured by Q.
fn satellites_and_ratio(tr: &Trajectory, axis: &TimeAxis) -> String {
    let pts = thinned(tr);
    let xr = range(pts.iter().map(|e| axis.x(e.time)));
    let mut s = String::from("<h2>Time series</h2>\n");
    s += &quality_legend(tr, &[]);
    let ns_max = pts.iter().map(|e| e.nsat as f64).fold(4.0, f64::max) + 1.0;
    s += &svg_sized("Satellites used", (900, 300), |root| {
        let mut ch = axes(
            root,
            xr.0..xr.1,
            0.0..ns_max,
            (&axis.desc, "satellites"),
            50,
        )?;
        ch.draw_series(pts.iter().map(|e| {
            Circle::new(
                (axis.x(e.time), e.nsat as f64),
                2,
                colour(e.quality).filled(),
            )
        }))?;
        Ok(())
    });
    const CLIP: f64 = 50.0;
    s += &svg_sized(
        &format!("Ambiguity ratio test (clipped at {CLIP}; 0 where no fix was tried)"),
        (900, 300),
        |root| {
            let mut ch = axes(
                root,
                xr.0..xr.1,
                0.0..CLIP * 1.05,
                (&axis.desc, "ratio"),
                50,
            )?;
            ch.draw_series(pts.iter().map(|e| {
                Circle::new(
                    (axis.x(e.time), e.ratio.min(CLIP)),
                    2,
                    colour(e.quality).filled(),
                )
            }))?;
            Ok(())
        },
    );
    s
}

/// σ east, north, up per epoch on a logarithmic axis.
fn sigmas(tr: &Trajectory, axis: &TimeAxis) -> String {
    let pts = thinned(tr);
    let sig: Vec<(f64, [f64; 3])> = pts
        .iter()
        .map(|e| {
            let r = enu_rotation(&e.pos.to_geodetic());
            let c = r * e.cov * r.transpose();
            let sd = |k: usize| c[(k, k)].max(1e-8).sqrt();
            (axis.x(e.time), [sd(0), sd(1), sd(2)])
        })
        .collect();
    let xr = range(sig.iter().map(|p| p.0));
    let all = sig.iter().flat_map(|p| p.1);
    let lo = all.clone().fold(f64::INFINITY, f64::min).max(1e-4) / 1.5;
    let hi = all.fold(0.0, f64::max).max(lo * 10.0) * 1.5;
    let names = [
        ("σ east", RGBColor(210, 30, 30)),
        ("σ north", RGBColor(40, 90, 220)),
        ("σ up", RGBColor(0, 150, 60)),
    ];
    let mut s = legend(&names.map(|(n, c)| (n.to_string(), c, "━")));
    // A logarithmic axis: ticks at 1, 2, 5 of each decade, labelled in the unit of the
    // largest σ.
    let unit = LengthAxis::for_span(hi);
    s += &svg_sized(
        &format!("Standard deviations ({}, logarithmic)", unit.unit),
        (900, 320),
        |root| {
            let mut ch = ChartBuilder::on(root)
                .margin(10)
                .x_label_area_size(30)
                .y_label_area_size(60)
                .build_cartesian_2d(xr.0..xr.1, (lo..hi).log_scale())?;
            let dx = decimals(xr.1 - xr.0);
            ch.configure_mesh()
                .x_desc(axis.desc.as_str())
                .x_label_formatter(&|v| tick(*v, dx))
                .y_desc(unit.unit)
                .y_label_formatter(&|v| log_label(*v, &unit))
                .draw()?;
            for (k, (_, c)) in names.iter().enumerate() {
                ch.draw_series(LineSeries::new(sig.iter().map(|p| (p.0, p.1[k])), c))?;
            }
            Ok(())
        },
    );
    s
}

/// A tick of a logarithmic length axis: as many decimals as its own first digit needs.
fn log_label(v: f64, unit: &LengthAxis) -> String {
    let x = v * unit.factor();
    let decimals = (-x.log10().floor()).clamp(0.0, 6.0) as usize;
    format!("{x:.decimals$}")
}

/// Forward minus backward solution, east/north/up in centimetres: where the two passes
/// disagree, at least one of them is wrong (GrafNav's "combined separation"). `origin`
/// orients east/north/up.
fn separation(d: &gnss::ppk::PassDiagnostics, axis: &TimeAxis, origin: &Ecef) -> String {
    let title = "Forward − backward separation (cm)";
    if d.separation.is_empty() {
        return format!("<h3>{title}</h3><p>One pass only: nothing to compare.</p>\n");
    }
    let r = enu_rotation(&origin.to_geodetic());
    let k = d.separation.len().div_ceil(MAX_POINTS).max(1);
    let pts: Vec<(f64, [f64; 3])> = d
        .separation
        .iter()
        .step_by(k)
        .map(|x| {
            let e = r * x.d * 100.0;
            (axis.x(x.time), [e.x, e.y, e.z])
        })
        .collect();
    let xr = range(pts.iter().map(|p| p.0));
    let largest = |fixed: bool| {
        d.separation
            .iter()
            .filter(|x| x.both_fixed || !fixed)
            .map(|x| x.d.norm() * 100.0)
            .fold(0.0, f64::max)
    };
    let (big, big_fixed) = (largest(false), largest(true));
    let lim = pts
        .iter()
        .flat_map(|p| p.1)
        .fold(1.0f64, |m, v| m.max(v.abs()))
        * 1.1;
    let names = [
        ("east", RGBColor(210, 30, 30)),
        ("north", RGBColor(40, 90, 220)),
        ("up", RGBColor(0, 150, 60)),
    ];
    let mut s = legend(&names.map(|(n, c)| (n.to_string(), c, "━")));
    s += &svg_sized(
        &format!(
            "{title}: largest {big:.1} cm (3D); {big_fixed:.1} cm where both passes are fixed"
        ),
        (900, 300),
        |root| {
            let mut ch = axes(root, xr.0..xr.1, -lim..lim, (&axis.desc, "cm"), 50)?;
            for (k, (_, c)) in names.iter().enumerate() {
                ch.draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1[k])), c))?;
            }
            Ok(())
        },
    );
    s
}

/// Ambiguity resets (slips, gaps, outliers) per epoch of each pass.
fn resets(d: &gnss::ppk::PassDiagnostics, axis: &TimeAxis) -> String {
    let passes = [
        ("forward", RGBColor(40, 90, 220), &d.forward_resets),
        ("backward", RGBColor(240, 140, 0), &d.backward_resets),
    ];
    let total = |v: &[(Epoch, u32)]| v.iter().map(|x| x.1 as u64).sum::<u64>();
    let entries: Vec<(String, RGBColor, &str)> = passes
        .iter()
        .filter(|p| !p.2.is_empty())
        .map(|(n, c, v)| {
            (
                format!("{n} ({} resets at {} epochs)", total(v), v.len()),
                *c,
                "●",
            )
        })
        .collect();
    let title = "Ambiguity resets per epoch (cycle slips, gaps, outliers)";
    if entries.is_empty() {
        return format!("<h3>{title}</h3><p>No ambiguity was reset.</p>\n");
    }
    let xs = passes.iter().flat_map(|p| p.2.iter().map(|x| axis.x(x.0)));
    let xr = range(xs);
    let top = passes
        .iter()
        .flat_map(|p| p.2.iter().map(|x| x.1))
        .max()
        .unwrap_or(1) as f64
        * 1.15;
    let mut s = legend(&entries);
    s += &svg_sized(title, (900, 240), |root| {
        let mut ch = axes(root, xr.0..xr.1, 0.0..top, (&axis.desc, "resets"), 50)?;
        for (k, (_, c, v)) in passes.iter().enumerate() {
            // Backward marks a little to the right of forward ones at the same epoch.
            let dx = (xr.1 - xr.0) * 0.002 * k as f64;
            ch.draw_series(v.iter().map(|(t, n)| {
                PathElement::new(
                    vec![(axis.x(*t) + dx, 0.0), (axis.x(*t) + dx, *n as f64)],
                    c.stroke_width(2),
                )
            }))?;
        }
        Ok(())
    });
    s
}

/// Age of the base observations per epoch.
fn age(tr: &Trajectory, axis: &TimeAxis) -> String {
    let pts = thinned(tr);
    let xr = range(pts.iter().map(|e| axis.x(e.time)));
    let (a0, a1) = range(pts.iter().map(|e| e.age).chain([0.0]));
    svg_sized("Age of the base observations (s)", (900, 260), |root| {
        let mut ch = axes(root, xr.0..xr.1, a0..a1, (&axis.desc, "s"), 50)?;
        ch.draw_series(
            pts.iter()
                .map(|e| Circle::new((axis.x(e.time), e.age), 1, BLACK.filled())),
        )?;
        Ok(())
    })
}

/// One row per ambiguity segment (a run of epochs with one segment id).
fn segment_table(tr: &Trajectory) -> String {
    const ROWS: usize = 200;
    let mut runs: Vec<&[TrajectoryEpoch]> =
        tr.epochs.chunk_by(|a, b| a.segment == b.segment).collect();
    let total = runs.len();
    runs.truncate(ROWS);
    let mut s = format!("<h2>Ambiguity segments ({total})</h2><p>A new segment starts where the fixed ambiguity set is entered, left or re-fixed, after a gap or a reset of all ambiguities.</p><table><tr><th>segment</th><th class=\"l\">start (GPST)</th><th class=\"l\">end (GPST)</th><th>seconds</th><th>epochs</th><th>fixed %</th><th>median σ up (m)</th></tr>\n");
    for run in runs {
        let (a, b) = (&run[0], &run[run.len() - 1]);
        let fixed = run.iter().filter(|e| e.quality == Quality::Fixed).count();
        let mut su: Vec<f64> = run
            .iter()
            .map(|e| {
                let r = enu_rotation(&e.pos.to_geodetic());
                (r * e.cov * r.transpose())[(2, 2)].max(0.0).sqrt()
            })
            .collect();
        su.sort_by(f64::total_cmp);
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{:.1}</td><td>{}</td><td>{:.1}</td><td>{:.3}</td></tr>",
            a.segment,
            format_ymdhms(a.time),
            format_ymdhms(b.time),
            (b.time - a.time).to_seconds(),
            run.len(),
            100.0 * fixed as f64 / run.len() as f64,
            su[su.len() / 2]
        );
    }
    s += "</table>\n";
    if total > ROWS {
        let _ = writeln!(s, "<p>… and {} more segments.</p>", total - ROWS);
    }
    s
}

/// The settings of the run: the `.pos` header lines as a table.
fn settings_table(settings: &[String]) -> String {
    let mut s = String::from("<h2>Settings</h2><table>\n");
    for l in settings {
        let (k, v) = l.split_once(':').unwrap_or(("", l));
        let _ = writeln!(
            s,
            "<tr><th class=\"l\">{}</th><td class=\"l\">{}</td></tr>",
            html_escape(k.trim()),
            html_escape(v.trim())
        );
    }
    s + "</table>\n"
}

#[cfg(test)]
mod tests {
    use super::*;
    use gnss::trajectory::SegmentSource;

    /// The tick labels of the ground track's axes (the `<text>` of the SVG that are numbers).
    fn numbers(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                let body = t.split('>').nth(1)?.split('<').next()?.trim().to_string();
                body.parse::<f64>().is_ok().then_some(body)
            })
            .collect()
    }

    /// A static receiver's 30 cm scatter: every tick of both axes reads differently, in
    /// centimetres (the whole-metre labels read "-0 -0 0 0").
    #[test]
    fn ground_track_ticks_of_a_sub_metre_track_are_distinct() {
        let t0 = Epoch::from_gpst_seconds(1_000_000_000.0);
        let base = Ecef::new(4_775_849.4, 116_814.3, 4_213_018.9);
        let epochs = (0..200)
            .map(|k| {
                let a = k as f64 * 0.7;
                let d = nalgebra::Vector3::new(0.15 * a.cos(), 0.12 * a.sin(), 0.05 * a.cos());
                TrajectoryEpoch::new(
                    t0 + hifitime::Duration::from_seconds(30.0 * k as f64),
                    Ecef(base.0 + d),
                    nalgebra::Matrix3::identity() * 1e-4,
                    Quality::Fixed,
                )
            })
            .collect();
        let tr = Trajectory::new(epochs, SegmentSource::Filter);
        let svg = ground_track(&tr, &[]);
        assert!(
            svg.contains("east (cm)") && svg.contains("north (cm)"),
            "{svg:.400}"
        );
        let labels = numbers(&svg);
        assert!(labels.len() >= 8, "{labels:?}");
        // Ticks come axis by axis in order: neighbours never read alike, and the values are
        // many (east and north may share some).
        assert!(labels.windows(2).all(|w| w[0] != w[1]), "{labels:?}");
        let mut unique = labels.clone();
        unique.sort();
        unique.dedup();
        assert!(
            unique.len() >= 6 && 2 * unique.len() >= labels.len(),
            "{labels:?}"
        );
        assert!(!labels
            .iter()
            .any(|l| l.starts_with("-0") && l.parse::<f64>() == Ok(0.0)));
    }
}
