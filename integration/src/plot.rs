//! SVG plots for the HTML reports (adjustment, PPP, PPK): a titled plot in a string, axes with
//! their descriptions, and a padded data range.

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// A plot into an SVG string; drawing errors leave a note instead of the plot.
pub(crate) type Plot = Result<(), Box<dyn std::error::Error>>;

pub(crate) fn svg(
    title: &str,
    draw: impl FnOnce(&DrawingArea<SVGBackend, plotters::coord::Shift>) -> Plot,
) -> String {
    svg_sized(title, (900, 420), draw)
}

/// [`svg`] of a given size in pixels (width, height).
pub(crate) fn svg_sized(
    title: &str,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, plotters::coord::Shift>) -> Plot,
) -> String {
    let mut buf = String::new();
    let ok = {
        let root = SVGBackend::with_string(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).is_ok() && draw(&root).is_ok() && root.present().is_ok()
    };
    if ok {
        format!("<h3>{title}</h3>\n{buf}\n")
    } else {
        format!("<h3>{title}</h3><p>(plot could not be drawn)</p>\n")
    }
}

pub(crate) type Chart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The report's axes: margins, label areas, a mesh with the axis descriptions.
pub(crate) fn axes<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    desc: (&str, &str),
    y_label_px: u32,
) -> Result<Chart<'a, 'b>, Box<dyn std::error::Error>> {
    let mut ch = ChartBuilder::on(root)
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(y_label_px)
        .build_cartesian_2d(x, y)?;
    ch.configure_mesh().x_desc(desc.0).y_desc(desc.1).draw()?;
    Ok(ch)
}

pub(crate) fn range(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let lo = v.clone().fold(f64::INFINITY, f64::min);
    let hi = v.fold(f64::NEG_INFINITY, f64::max);
    if lo.is_finite() && hi.is_finite() && hi > lo {
        let m = 0.05 * (hi - lo);
        (lo - m, hi + m)
    } else {
        (-1.0, 1.0)
    }
}

/// Text safe inside HTML.
pub(crate) fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
