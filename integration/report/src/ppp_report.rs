//! `OUT.pos.html` of `ppkat ppp`: what was solved, and pictures of how the solution
//! converged (static: each epoch's running solution against the final one; kinematic: the
//! positions about their mean), of the zenith total delay and of the satellites used.
//!
//! Enters: a [`PppReport`] (what a run did, defined here; `integration::ppp` makes it).
//! Leaves: a self-contained HTML text, and the report's lines ([`PppReport`]'s `Display`, and
//! [`Untimed`] for the page, without the wall time).

use crate::plot::{axes, html_escape, range, svg, TimeAxis};
use crate::survey::{enu_sigmas, refer_name};
use gnss::frame::Ecef;
use gnss::ppk::{Motion, Reference};
use gnss::ppp::PppResult;
use nalgebra::Matrix3;
use plotters::prelude::*;
use std::fmt;
use std::fmt::Write as _;
use std::path::PathBuf;

/// What a PPP run did.
#[derive(Clone, Debug)]
pub struct PppReport {
    /// The solver's result.
    pub result: PppResult,
    /// Static mode: the final position and covariance (ECEF m, m²).
    pub last: Option<(Ecef, Matrix3<f64>)>,
    /// The reference point of the positions.
    pub refer: Reference,
    /// The motion model.
    pub motion: Motion,
    /// The `.pos` written, and the JSON summary (static).
    pub out: PathBuf,
    /// The JSON summary, in static mode.
    pub summary: Option<PathBuf>,
    /// The HTML report (`OUT.pos.html`).
    pub html: Option<PathBuf>,
    /// The zenith total delay series (`OUT.pos.ztd.csv`).
    pub ztd: Option<PathBuf>,
    /// Reference frame of the orbits.
    pub frame: String,
    /// Seconds spent.
    pub seconds: f64,
    /// The header's approximate position (moved to the point asked for), to compare.
    pub header_position: Option<Ecef>,
}

/// The time axis of the run (from a round time), and each solved epoch's value on it.
fn times(r: &PppReport) -> Option<(TimeAxis, Vec<f64>)> {
    let first = r.result.epochs.first()?.time;
    let last = r.result.epochs.last()?.time;
    let axis = TimeAxis::new(first, last);
    let t = r.result.epochs.iter().map(|e| axis.x(e.time)).collect();
    Some((axis, t))
}

/// East, north, up of every epoch from `origin`, metres.
fn enu_from(r: &PppReport, origin: &Ecef) -> Vec<[f64; 3]> {
    r.result
        .epochs
        .iter()
        .map(|e| {
            let d = e.pos.enu_from(origin).0;
            [d.x, d.y, d.z]
        })
        .collect()
}

/// The report page; `summary` is what `ppkat ppp` printed of the run, without its wall time.
pub fn html(r: &PppReport, input: &str, summary: &str) -> String {
    let mut s = String::from("<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>ppkat ppp</title><style>body{font-family:sans-serif;max-width:960px;margin:auto}td,th{padding:2px 8px;text-align:right}pre{white-space:pre-wrap}</style></head><body>\n");
    let _ = writeln!(
        s,
        "<h1>Precise point positioning</h1><p>{}</p><pre>{}</pre>",
        html_escape(input),
        html_escape(summary)
    );
    let Some((axis, t)) = times(r) else {
        return s + "</body></html>\n";
    };
    let (origin, what) = match r.last {
        Some((p, _)) => (p, "running solution minus the final one"),
        None => (mean(r), "position minus the mean position"),
    };
    let enu = enu_from(r, &origin);
    s += &svg(
        &format!("Convergence: {what} (m, clipped to ±0.5 m)"),
        |root| {
            let mut ch = axes(
                root,
                range(t.iter().copied()).0..range(t.iter().copied()).1,
                -0.5..0.5,
                (&axis.desc, "m"),
                50,
            )?;
            for (k, (name, col)) in [("east", RED), ("north", BLUE), ("up", GREEN)]
                .into_iter()
                .enumerate()
            {
                ch.draw_series(LineSeries::new(
                    t.iter().zip(&enu).map(|(x, v)| (*x, v[k].clamp(-0.5, 0.5))),
                    col,
                ))?
                .label(name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], col));
            }
            ch.configure_series_labels()
                .border_style(BLACK)
                .background_style(WHITE.mix(0.8))
                .position(SeriesLabelPosition::LowerRight)
                .draw()?;
            Ok(())
        },
    );
    let ztd: Vec<f64> = r.result.epochs.iter().map(|e| e.ztd.0).collect();
    let zr = range(ztd.iter().copied());
    let x = (&axis.desc[..], &t[..]);
    s += &series("Zenith total delay (m)", x, &ztd, zr.0..zr.1, "m", BLUE);
    let ns: Vec<f64> = r.result.epochs.iter().map(|e| e.nsat as f64).collect();
    let top = ns.iter().copied().fold(4.0, f64::max) + 1.0;
    s += &series("Satellites used", x, &ns, 0.0..top, "satellites", BLACK);
    s + "</body></html>\n"
}

/// One value per epoch against time (the axis description and each epoch's value on it), as
/// a titled line plot.
fn series(
    title: &str,
    (desc, t): (&str, &[f64]),
    v: &[f64],
    y: std::ops::Range<f64>,
    unit: &str,
    colour: RGBColor,
) -> String {
    let (t0, t1) = range(t.iter().copied());
    svg(title, |root| {
        let mut ch = axes(root, t0..t1, y, (desc, unit), 60)?;
        ch.draw_series(LineSeries::new(
            t.iter().copied().zip(v.iter().copied()),
            colour,
        ))?;
        Ok(())
    })
}

/// The mean of the epochs' positions.
fn mean(r: &PppReport) -> Ecef {
    let n = r.result.epochs.len().max(1) as f64;
    Ecef(
        r.result
            .epochs
            .iter()
            .map(|e| e.pos.0)
            .sum::<nalgebra::Vector3<f64>>()
            / n,
    )
}

/// The middle of a span as a decimal year (the epoch at which a station coordinate in a
/// moving frame holds).
pub fn decimal_year(a: hifitime::Epoch, b: hifitime::Epoch) -> f64 {
    let mid = a + (b - a) * 0.5;
    let (y, ..) = mid.to_gregorian_utc();
    let start = hifitime::Epoch::from_gregorian_utc_at_midnight(y, 1, 1);
    let end = hifitime::Epoch::from_gregorian_utc_at_midnight(y + 1, 1, 1);
    y as f64 + (mid - start).to_seconds() / (end - start).to_seconds()
}

impl fmt::Display for PppReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_summary(self, f, true)
    }
}

/// A [`PppReport`] shown without its wall time, for files that must be the same bytes on
/// every run (the HTML report).
pub struct Untimed<'a>(pub &'a PppReport);

impl fmt::Display for Untimed<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_summary(self.0, f, false)
    }
}

/// What `ppkat ppp` prints of a run, with the wall time when `timed`.
fn write_summary(this: &PppReport, f: &mut fmt::Formatter<'_>, timed: bool) -> fmt::Result {
    for w in &this.result.warnings {
        writeln!(f, "warning: {w}")?;
    }
    let r = &this.result;
    writeln!(
        f,
        "{} epochs read, {} solved, {} without 4 usable satellites; {} ambiguity restarts at slips",
        r.input_epochs,
        r.epochs.len(),
        r.unsolved,
        r.slips
    )?;
    for (k, n) in &r.rejected {
        writeln!(f, "  {n} satellite-epochs {}", k.describe())?;
    }
    writeln!(
        f,
        "post-fit residuals RMS: phase {:.1} mm, code {:.2} m; σ scaled by √{:.1} for their size and correlation (lag-one {:.2}) plus a floor of {:.0}/{:.0} mm horizontal/up",
        r.residual_rms(0) * 1e3,
        r.residual_rms(1),
        r.inflation.0,
        r.inflation.1,
        r.floor.0 * 1e3,
        r.floor.1 * 1e3,
    )?;
    if let Some((pos, cov)) = this.last {
        let g = pos.to_geodetic();
        let sd = enu_sigmas(&pos, &cov);
        writeln!(
            f,
            "static {}: X {:.4} Y {:.4} Z {:.4} m (lat {:.9} lon {:.9} h {:.4} m), σ E/N/U {:.1}/{:.1}/{:.1} mm, frame {} at epoch {:.3}",
            refer_name(this.refer),
            pos.0.x,
            pos.0.y,
            pos.0.z,
            g.lat.to_degrees(),
            g.lon.to_degrees(),
            g.h,
            sd[0] * 1e3,
            sd[1] * 1e3,
            sd[2] * 1e3,
            this.frame,
            match (this.result.epochs.first(), this.result.epochs.last()) {
                (Some(a), Some(b)) => decimal_year(a.time, b.time),
                _ => f64::NAN,
            }
        )?;
        if let Some(h) = this.header_position {
            let d = h.enu_from(&pos).0;
            writeln!(
                f,
                "  {:.3} m from the header's approximate position (E/N/U {:+.3}/{:+.3}/{:+.3} m: header minus PPP; a header in another frame, e.g. ETRS89, differs by decimetres)",
                d.norm(),
                d.x,
                d.y,
                d.z
            )?;
        }
    }
    write!(f, "wrote {}", this.out.display())?;
    if let Some(s) = &this.summary {
        write!(f, ", {}", s.display())?;
    }
    if let Some(s) = &this.ztd {
        write!(f, ", {}", s.display())?;
    }
    if let Some(s) = &this.html {
        write!(f, ", {}", s.display())?;
    }
    if timed {
        write!(f, " in {:.1} s", this.seconds)?;
    }
    writeln!(f)
}
