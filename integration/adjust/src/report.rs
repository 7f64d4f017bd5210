//! Outputs of `ppkat adjust`, each written atomically: `orientations.csv`, `points.csv`,
//! `image_residuals.csv`, `gnss_residuals.csv`, `report.json` and a self-contained
//! `report.html` with SVG plots (plotters): image residual vectors, check-point errors, GNSS
//! centre residuals per strip, drift over time.

use super::error::AdjustError;
use super::estimated::Estimated;
use super::project::{Mode, Project};
use super::results::Results;
use ::report::plot::{axes, range, svg};
use common::atomic::write_atomic;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::Path;

fn werr(path: &Path, e: impl std::fmt::Display) -> AdjustError {
    AdjustError::Write {
        path: path.display().to_string(),
        what: e.to_string(),
    }
}

fn write_text(path: &Path, text: &str) -> Result<(), AdjustError> {
    write_atomic(path, |w| w.write_all(text.as_bytes())).map_err(|e| werr(path, e))
}

/// The files of an output folder of `ppkat adjust`.
pub const OUTPUTS: [&str; 7] = [
    "orientations.csv",
    "points.csv",
    "image_residuals.csv",
    "gnss_residuals.csv",
    "report.json",
    "parameters.csv",
    "report.html",
];

/// Write every output into the folder `out` as a whole: into a staging folder beside it,
/// swapped in at the end, so that `out` holds the previous run's set or this one's, never a
/// mix. An existing `out` holding other files than [`OUTPUTS`] is refused.
pub fn write_all(p: &Project, r: &Results, out: &Path) -> Result<(), AdjustError> {
    if let Some(parent) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| werr(parent, e))?;
    }
    // Their messages name the folder already.
    let named = |e: common::atomic::Error| AdjustError::Problem(e.to_string());
    let staged = common::atomic::StagedDir::new(out, &OUTPUTS).map_err(named)?;
    write_files(p, r, staged.path())?;
    staged.commit().map_err(named)
}

/// Write the files of [`OUTPUTS`] into the folder `out`.
fn write_files(p: &Project, r: &Results, out: &Path) -> Result<(), AdjustError> {
    // Projected coordinates first when there is a projection; geodetic always.
    let geo = r.crs.starts_with("WGS84");
    let proj_head = if geo { "" } else { "easting,northing," };
    let proj = |e: f64, n: f64| {
        if geo {
            String::new()
        } else {
            format!("{e:.4},{n:.4},")
        }
    };
    let mut s = String::new();
    let _ = writeln!(s, "# ppkat adjust: projection centres; {}; h ellipsoidal; local = ENU at {:.8} {:.8} {:.3}; omega/phi/kappa (deg) of R camera->local ENU, R = Rw*Rp*Rk; sigmas m and deg", r.crs, r.origin_deg[0], r.origin_deg[1], r.origin_deg[2]);
    let _ = writeln!(s, "image,strip,{proj_head}lat,lon,h,e_local,n_local,u_local,omega,phi,kappa,sigma_e,sigma_n,sigma_u,sigma_omega,sigma_phi,sigma_kappa,points,rms_px");
    for i in &r.images {
        let _ = writeln!(
            s,
            "{},{},{}{:.9},{:.9},{:.4},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{},{:.3}",
            i.id, i.strip, proj(i.position.easting, i.position.northing), i.position.lat, i.position.lon, i.position.h, i.position.local[0], i.position.local[1], i.position.local[2],
            i.opk_deg[0], i.opk_deg[1], i.opk_deg[2], i.sigma_centre[0], i.sigma_centre[1], i.sigma_centre[2],
            i.sigma_angles_deg[0], i.sigma_angles_deg[1], i.sigma_angles_deg[2], i.points, i.rms_px
        );
    }
    write_text(&out.join("orientations.csv"), &s)?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# ppkat adjust: object points; {}; h ellipsoidal; sigmas local E,N,U (m)",
        r.crs
    );
    let _ = writeln!(
        s,
        "point,kind,{proj_head}lat,lon,h,sigma_e,sigma_n,sigma_u,rays"
    );
    for q in &r.points {
        let _ = writeln!(
            s,
            "{},{},{}{:.9},{:.9},{:.4},{:.4},{:.4},{:.4},{}",
            q.id,
            serde_json::to_value(q.kind)
                .ok()
                .and_then(|v| v.as_str().map(String::from))
                .unwrap_or_default(),
            proj(q.position.easting, q.position.northing),
            q.position.lat,
            q.position.lon,
            q.position.h,
            q.sigma[0],
            q.sigma[1],
            q.sigma[2],
            q.rays
        );
    }
    write_text(&out.join("points.csv"), &s)?;
    let mut s = String::from("# residual = predicted - measured (px); r = redundancy number; w = normalised residual\nimage,point,x_px,y_px,vx_px,vy_px,rx,ry,wx,wy\n");
    for v in &r.image_residuals {
        let _ = writeln!(
            s,
            "{},{},{:.2},{:.2},{:.3},{:.3},{:.3},{:.3},{:.2},{:.2}",
            v.image,
            v.point,
            v.px[0],
            v.px[1],
            v.v_px[0],
            v.v_px[1],
            v.r[0],
            v.r[1],
            v.w[0],
            v.w[1]
        );
    }
    write_text(&out.join("image_residuals.csv"), &s)?;
    let mut s = String::from("image,strip,tow,ve,vn,vu\n");
    for v in &r.gnss_residuals {
        let _ = writeln!(
            s,
            "{},{},{:.3},{:.4},{:.4},{:.4}",
            v.image, v.strip, v.tow, v.v[0], v.v[1], v.v[2]
        );
    }
    write_text(&out.join("gnss_residuals.csv"), &s)?;
    let json = serde_json::to_string_pretty(r).map_err(|e| werr(&out.join("report.json"), e))?;
    write_text(&out.join("report.json"), &json)?;
    write_text(&out.join("parameters.csv"), &super::parameters::csv(r))?;
    write_text(&out.join("report.html"), &html(p, r))
}

fn f3(v: [f64; 3], k: f64, d: usize) -> String {
    format!(
        "<td>{:.d$}</td><td>{:.d$}</td><td>{:.d$}</td>",
        v[0] * k,
        v[1] * k,
        v[2] * k
    )
}

fn est_rows(s: &mut String, e: &Estimated, unit: &str) {
    let name = if e.t0 > 0.0 {
        let week = (e.t0 / 604800.0).floor();
        format!(
            "{} (t0: GPS week {week}, {:.1} s)",
            e.name,
            e.t0 - week * 604800.0
        )
    } else {
        e.name.clone()
    };
    for (i, l) in e.labels.iter().enumerate() {
        let _ = writeln!(
            s,
            "<tr><td>{name}</td><td>{l}</td><td>{:.5}</td><td>{}</td><td>{unit}</td></tr>",
            e.values[i],
            if e.fixed {
                "fixed".into()
            } else {
                format!("{:.5}", e.sigmas[i])
            }
        );
    }
}

/// The self-contained HTML report.
/// The self-contained HTML report: summary, groups, parameters, control, removed
/// observations, check points, plots, images.
pub fn html(p: &Project, r: &Results) -> String {
    let mut s = String::new();
    html_summary(&mut s, p, r);
    html_groups(&mut s, r);
    html_parameters(&mut s, r);
    html_control(&mut s, r);
    html_distances(&mut s, r);
    html_removed(&mut s, r);
    super::tight_report::html(&mut s, r.tight.as_ref());
    html_checks(&mut s, r);
    html_plots(&mut s, p, r);
    html_images(&mut s, r);
    let _ = writeln!(
        s,
        "</table><p>Written by ppkat {}.</p></body></html>",
        env!("CARGO_PKG_VERSION")
    );
    s
}

/// Head, title, the project and the summary table, warnings.
fn html_summary(s: &mut String, p: &Project, r: &Results) {
    let title = if r.name.is_empty() {
        "ppkat adjustment"
    } else {
        &r.name
    };
    let _ = writeln!(s, "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>{title}</title><style>body{{font-family:sans-serif;max-width:1100px;margin:auto}}table{{border-collapse:collapse;margin:8px 0}}td,th{{border:1px solid #bbb;padding:2px 6px;text-align:right}}th{{background:#eee}}.warn{{color:#a40}}</style></head><body>");
    let _ = writeln!(s, "<h1>{title}</h1><p>Project <code>{}</code>; {:?} mode; output {}; local frame ENU at {:.6}°, {:.6}°, {:.2} m.</p>", p.path.display(), r.mode, r.crs, r.origin_deg[0], r.origin_deg[1], r.origin_deg[2]);
    let _ = writeln!(s, "<h2>Summary</h2><table><tr><th>σ0</th><th>observations</th><th>unknowns</th><th>redundancy</th><th>iterations</th><th>images</th><th>points</th><th>removed</th></tr><tr><td>{:.3}</td><td>{}</td><td>{}</td><td>{:.0}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr></table>", r.sigma0, r.observations, r.unknowns, r.redundancy, r.iterations, r.images.len(), r.points.len(), r.removed.len());
    for w in &r.warnings {
        let _ = writeln!(s, "<p class=\"warn\">⚠ {w}</p>");
    }
}

/// The observation groups with their reliability.
fn html_groups(s: &mut String, r: &Results) {
    let _ = writeln!(s, "<h2>Observation groups</h2><table><tr><th>group</th><th>components</th><th>σ factor (VCE)</th><th>mean redundancy</th><th>min redundancy</th><th>uncontrolled (r &lt; 0.1)</th><th>max MDB (r ≥ 0.1)</th></tr>");
    for g in &r.groups {
        let mdb = if g.uncontrolled == g.observations {
            "— (none controlled)".to_string()
        } else {
            format!("{:.3} {}", g.max_mdb, g.mdb_unit)
        };
        let _ = writeln!(s, "<tr><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td><td>{mdb}</td></tr>", g.group, g.observations, g.sigma_factor, g.mean_redundancy, g.min_redundancy, g.uncontrolled);
    }
    let _ = writeln!(s, "</table>");
}

/// Lever arms, drifts, GNSS latencies and interior parameters with σ.
fn html_parameters(s: &mut String, r: &Results) {
    let groups = [
        (&r.lever_arms, "m"),
        (&r.boresights, "deg"),
        (&r.drifts, "m, m/s"),
        (&r.latencies, "s"),
        (&r.interiors, "m (f, x0, y0), distortion units"),
    ];
    if groups.iter().any(|(g, _)| !g.is_empty()) {
        let _ = writeln!(s, "<h2>Additional parameters</h2><table><tr><th>parameter</th><th></th><th>value</th><th>σ</th><th>unit</th></tr>");
        for (g, unit) in groups {
            for e in g {
                est_rows(s, e, unit);
            }
        }
        let _ = writeln!(s, "</table>");
        if !r.drifts.is_empty() {
            let _ = writeln!(s, "<p>Drift = GNSS antenna position − adjusted antenna position (X<sub>S</sub> + R·lever arm), east/north/up of the adjustment frame: a + b·(t − t<sub>0</sub>).</p>");
        }
    }
}

/// The control points' residuals, redundancy, w and MDB.
fn html_control(s: &mut String, r: &Results) {
    if !r.control_residuals.is_empty() {
        let _ = writeln!(s, "<h2>Control points</h2><table><tr><th>point</th><th>vE m</th><th>vN m</th><th>vU m</th><th>rE</th><th>rN</th><th>rU</th><th>wE</th><th>wN</th><th>wU</th><th>MDB E/N/U m</th></tr>");
        for c in &r.control_residuals {
            let mdb: Vec<String> = c
                .mdb
                .iter()
                .map(|m| m.map(|x| format!("{x:.3}")).unwrap_or_else(|| "—".into()))
                .collect();
            let _ = writeln!(
                s,
                "<tr><td>{}</td>{}{}{}<td>{}</td></tr>",
                c.id,
                f3(c.v, 1.0, 3),
                f3(c.r, 1.0, 3),
                f3(c.w, 1.0, 2),
                mdb.join(" / ")
            );
        }
        let _ = writeln!(s, "</table>");
    }
}

/// The measured distances with their residuals.
fn html_distances(s: &mut String, r: &Results) {
    if r.distance_residuals.is_empty() {
        return;
    }
    let _ = writeln!(s, "<h2>Distances</h2><table><tr><th>from</th><th>to</th><th>measured m</th><th>v m</th><th>r</th><th>w</th><th>source</th></tr>");
    for d in &r.distance_residuals {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{:.4}</td><td>{:.4}</td><td>{:.3}</td><td>{:.2}</td><td>{}</td></tr>",
            d.points[0], d.points[1], d.distance, d.v, d.r, d.w, d.source
        );
    }
    let _ = writeln!(s, "</table>");
}

/// What data snooping removed.
fn html_removed(s: &mut String, r: &Results) {
    let _ = writeln!(
        s,
        "<h2>Removed observations (data snooping, critical |w| = {:.2})</h2>",
        r.critical_w
    );
    if r.removed.is_empty() {
        let _ = writeln!(s, "<p>None.</p>");
    } else {
        // A long list folds away (the plots below are what a reader looks at first); the
        // counts by kind stay in view.
        let long = r.removed.len() > FOLD_ROWS;
        if long {
            let mut kinds: std::collections::BTreeMap<&str, usize> = Default::default();
            for x in &r.removed {
                *kinds.entry(x.kind.as_str()).or_default() += 1;
            }
            let counts: Vec<String> = kinds.iter().map(|(k, n)| format!("{n} {k}")).collect();
            let _ = writeln!(
                s,
                "<details><summary>{} removed: {} (in the order data snooping removed them; show the list)</summary>",
                r.removed.len(),
                counts.join(", ")
            );
        }
        let _ = writeln!(
            s,
            "<table><tr><th>#</th><th>kind</th><th>what</th><th>|w|</th><th>source</th></tr>"
        );
        for (i, x) in r.removed.iter().enumerate() {
            let _ = writeln!(
                s,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{}</td></tr>",
                i + 1,
                x.kind,
                x.what,
                x.w,
                x.source
            );
        }
        let _ = writeln!(s, "</table>");
        if long {
            let _ = writeln!(s, "</details>");
        }
    }
}

/// Removed observations listed in view; a longer list folds away under its counts.
const FOLD_ROWS: usize = 30;

/// The check-point table.
fn html_checks(s: &mut String, r: &Results) {
    let c = &r.checks;
    if !c.points.is_empty() {
        let close = r.mode == Mode::CloseRange;
        let _ = writeln!(s, "<h2>Check points ({})</h2><table><tr><th>point</th>{}<th>σE</th><th>σN</th><th>σU</th></tr>", c.points.len(),
            if close { "<th>ΔE m</th><th>ΔN m</th><th>ΔU m</th><th>Δlat ″</th><th>Δlon ″</th><th>Δh m</th>" } else { "<th>ΔE m</th><th>ΔN m</th><th>ΔU m</th>" });
        for q in &c.points {
            let extra = if close {
                format!(
                    "<td>{:.5}</td><td>{:.5}</td><td>{:.3}</td>",
                    q.dlat_arcsec, q.dlon_arcsec, q.dh
                )
            } else {
                String::new()
            };
            let _ = writeln!(
                s,
                "<tr><td>{}</td>{}{extra}{}</tr>",
                q.id,
                f3(q.d, 1.0, 3),
                f3(q.sigma, 1.0, 3)
            );
        }
        let blank = if close {
            "<td></td><td></td><td></td>"
        } else {
            ""
        };
        let _ = writeln!(s, "<tr><th>mean</th>{}{blank}</tr><tr><th>RMS</th>{}{blank}</tr><tr><th>max |Δ|</th>{}{blank}</tr><tr><th>theoretical RMS</th>{}{blank}</tr></table>", f3(c.mean, 1.0, 3), f3(c.rms, 1.0, 3), f3(c.max, 1.0, 3), f3(c.theoretical_rms, 1.0, 3));
    }
}

/// The SVG plots.
fn html_plots(s: &mut String, p: &Project, r: &Results) {
    let _ = writeln!(s, "<h2>Plots</h2>");
    s.push_str(&super::residual_plots::image_residual_plots(p, r));
    if !r.checks.points.is_empty() {
        s.push_str(&plot_checks(r));
    }
    if !r.gnss_residuals.is_empty() {
        s.push_str(&plot_gnss(r));
    }
    if !r.drifts.is_empty() {
        s.push_str(&plot_drift(r));
    }
}

/// The images' orientations with σ (the table is closed by the caller).
fn html_images(s: &mut String, r: &Results) {
    let geo = r.crs.starts_with("WGS84");
    let _ = writeln!(s, "<h2>Images</h2><table><tr><th>image</th><th>strip</th>{}<th>h</th><th>ω°</th><th>φ°</th><th>κ°</th><th>σE</th><th>σN</th><th>σU</th><th>σω°</th><th>σφ°</th><th>σκ°</th><th>points</th><th>RMS px</th></tr>", if geo { "<th>lat°</th><th>lon°</th>" } else { "<th>easting</th><th>northing</th>" });
    for i in &r.images {
        let xy = if geo {
            format!(
                "<td>{:.9}</td><td>{:.9}</td>",
                i.position.lat, i.position.lon
            )
        } else {
            format!(
                "<td>{:.3}</td><td>{:.3}</td>",
                i.position.easting, i.position.northing
            )
        };
        let _ = writeln!(s, "<tr><td>{}</td><td>{}</td>{xy}<td>{:.3}</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td>{}{}<td>{}</td><td>{:.2}</td></tr>", i.id, i.strip, i.position.h, i.opk_deg[0], i.opk_deg[1], i.opk_deg[2], f3(i.sigma_centre, 1.0, 3), f3(i.sigma_angles_deg, 1.0, 4), i.points, i.rms_px);
    }
}

/// Check-point errors: horizontal vectors at the points, height error as a coloured dot.
fn plot_checks(r: &Results) -> String {
    let pts: Vec<(f64, f64, [f64; 3])> = r
        .checks
        .points
        .iter()
        .filter_map(|c| {
            r.points
                .iter()
                .find(|p| p.id == c.id)
                .map(|p| (p.position.local[0], p.position.local[1], c.d))
        })
        .collect();
    let (x0, x1) = range(pts.iter().map(|p| p.0));
    let (y0, y1) = range(pts.iter().map(|p| p.1));
    let vmax = pts
        .iter()
        .map(|p| p.2[0].hypot(p.2[1]).max(p.2[2].abs()))
        .fold(1e-9, f64::max);
    let k = 0.08 * (x1 - x0) / vmax;
    svg(&format!("Check-point errors (horizontal vectors × {k:.0}; red: up, blue: down; largest {vmax:.3} m)"), |root| {
        let mut ch = axes(root, x0..x1, y0..y1, ("east (m, local)", "north (m, local)"), 60)?;
        ch.draw_series(pts.iter().map(|p| {
            PathElement::new(vec![(p.0, p.1), (p.0 + k * p.2[0], p.1 + k * p.2[1])], BLACK.stroke_width(2))
        }))?;
        ch.draw_series(pts.iter().map(|p| {
            let size = (3.0 + 12.0 * p.2[2].abs() / vmax) as i32;
            let col = if p.2[2] >= 0.0 { RED } else { BLUE };
            Circle::new((p.0, p.1), size, col.mix(0.5).filled())
        }))?;
        Ok(())
    })
}

/// The time axis of the exposures: minutes or hours from a round time, or the exposures'
/// sequence numbers when the source knew no times (GPS week 0, the number as time of week);
/// its description and the value on it of a time.
fn exposure_axis(
    v: &[super::residuals::GnssResidual],
) -> (String, Box<dyn Fn(hifitime::Epoch) -> f64>) {
    let tow = |t: hifitime::Epoch| gnss::time::week_tow(t).1;
    let numbered = v.iter().all(|x| gnss::time::week_tow(x.time).0 == 0);
    let first = v.iter().map(|x| x.time).min();
    let last = v.iter().map(|x| x.time).max();
    match first.zip(last) {
        Some((a, b)) if !numbered => {
            let axis = ::report::plot::TimeAxis::new(a, b);
            (axis.desc.clone(), Box::new(move |t| axis.x(t)))
        }
        _ => (
            "exposure number (the source gave no times)".into(),
            Box::new(tow),
        ),
    }
}

/// GNSS centre residuals against time, one colour per axis, strips marked by their images.
fn plot_gnss(r: &Results) -> String {
    let v = &r.gnss_residuals;
    let (desc, x_of) = exposure_axis(v);
    let xs: Vec<f64> = v.iter().map(|r| x_of(r.time)).collect();
    let (t0, t1) = range(xs.iter().copied());
    let (y0, y1) = range(v.iter().flat_map(|x| x.v));
    // In the unit the residuals' span suits (millimetres for a good flight).
    let unit = ::report::plot::LengthAxis::for_span(y1 - y0);
    let k = unit.factor();
    svg(
        &format!(
            "GNSS centre residuals (predicted − observed, {}) over time; strips in sequence",
            unit.unit
        ),
        |root| {
            let mut ch = axes(
                root,
                t0..t1,
                k * y0..k * y1,
                (desc.as_str(), &format!("residual ({})", unit.unit)),
                60,
            )?;
            let mut strips: Vec<&str> = v.iter().map(|x| x.strip.as_str()).collect();
            strips.dedup();
            for (a, col, name) in [(0, RED, "E"), (1, GREEN, "N"), (2, BLUE, "U")] {
                for st in &strips {
                    ch.draw_series(LineSeries::new(
                        v.iter()
                            .zip(&xs)
                            .filter(|(x, _)| x.strip == *st)
                            .map(|(x, t)| (*t, k * x.v[a])),
                        col,
                    ))?;
                }
                ch.draw_series(
                    v.iter()
                        .zip(&xs)
                        .map(|(x, t)| Circle::new((*t, k * x.v[a]), 2, col.filled())),
                )?
                .label(name)
                .legend(move |(x, y)| Circle::new((x, y), 3, col.filled()));
            }
            ch.configure_series_labels().border_style(BLACK).draw()?;
            Ok(())
        },
    )
}

/// The estimated drift per group over its exposures' time span.
fn plot_drift(r: &Results) -> String {
    let v = &r.gnss_residuals;
    let (t0, t1) = range(v.iter().map(|x| x.tow));
    // The axis as for the residuals, a time of week placed in the exposures' week.
    let (desc, x_of) = exposure_axis(v);
    let week = v.first().map_or(0, |r| gnss::time::week_tow(r.time).0);
    let at = |tow: f64| x_of(gnss::time::from_week_tow(week, tow));
    let week_start = |t: f64| t - (t / 604800.0).floor() * 604800.0;
    let mut curves: Vec<(usize, Vec<(f64, f64)>)> = Vec::new();
    for d in &r.drifts {
        for a in 0..3 {
            let pts: Vec<(f64, f64)> = (0..=50)
                .map(|i| {
                    let tow = t0 + (t1 - t0) * i as f64 / 50.0;
                    let dt = tow - week_start(d.t0);
                    let val = match d.labels.len() {
                        6 => d.values[a] + d.values[a + 3] * dt,
                        _ if d.labels[0].starts_with('b') => d.values[a] * dt,
                        _ => d.values[a],
                    };
                    (at(tow), val)
                })
                .collect();
            curves.push((a, pts));
        }
    }
    let (y0, y1) = range(curves.iter().flat_map(|c| c.1.iter().map(|p| p.1)));
    svg(
        "Estimated GNSS drift (m) per group: E red, N green, U blue",
        |root| {
            let mut ch = axes(
                root,
                at(t0)..at(t1),
                y0..y1,
                (desc.as_str(), "drift (m)"),
                60,
            )?;
            for (a, pts) in curves {
                let col = [RED, GREEN, BLUE][a];
                ch.draw_series(LineSeries::new(pts, col))?;
            }
            Ok(())
        },
    )
}
