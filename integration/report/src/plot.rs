//! SVG plots for the HTML reports (adjustment, PPP, PPK): a titled plot in a string, axes with
//! their descriptions, a padded data range, length axes labelled in a unit that suits their
//! span ([`LengthAxis`]) and time axes counted from a round time ([`TimeAxis`]).

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// What a drawing closure given to [`svg`] or [`svg_sized`] returns; on `Err` the page shows
/// a note instead of the plot.
pub type Plot = Result<(), Box<dyn std::error::Error>>;

/// `draw` run on a 900 × 420 SVG canvas, returned under an `<h3>` title as HTML.
pub fn svg(
    title: &str,
    draw: impl FnOnce(&DrawingArea<SVGBackend, plotters::coord::Shift>) -> Plot,
) -> String {
    svg_sized(title, (900, 420), draw)
}

/// [`svg`] of a given size in pixels (width, height).
pub fn svg_sized(
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

/// A chart of two linear axes on an SVG canvas, as [`axes`] returns it.
pub type Chart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The report's axes: margins, label areas, a mesh with the axis descriptions.
pub fn axes<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    desc: (&str, &str),
    y_label_px: u32,
) -> Result<Chart<'a, 'b>, Box<dyn std::error::Error>> {
    let (dx, dy) = (decimals(x.end - x.start), decimals(y.end - y.start));
    let mut ch = ChartBuilder::on(root)
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(y_label_px)
        .build_cartesian_2d(x, y)?;
    ch.configure_mesh()
        .x_desc(desc.0)
        .y_desc(desc.1)
        .x_label_formatter(&|v| tick(*v, dx))
        .y_label_formatter(&|v| tick(*v, dy))
        .draw()?;
    Ok(ch)
}

/// Decimals a tick label needs on an axis spanning `span` (plotters puts about ten ticks a
/// 1-2-5 step apart): none for a span of ten or more ("5", not "5.0").
pub fn decimals(span: f64) -> usize {
    if span.is_finite() && span > 0.0 {
        (-(span / 10.0).log10()).ceil().clamp(0.0, 6.0) as usize
    } else {
        0
    }
}

/// A tick label with `decimals` decimals (no "-0").
pub fn tick(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// The span of the values widened by 5 % on each side ((−1, 1) when there is no span),
/// so that no point sits on the frame.
pub fn range(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let lo = v.clone().fold(f64::INFINITY, f64::min);
    let hi = v.fold(f64::NEG_INFINITY, f64::max);
    if lo.is_finite() && hi.is_finite() && hi > lo {
        let m = 0.05 * (hi - lo);
        (lo - m, hi + m)
    } else {
        (-1.0, 1.0)
    }
}

/// Text safe inside an HTML element (`&`, `<`, `>` escaped; not for attribute values).
pub fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// How an axis of lengths (metres) is labelled: in km, m, cm or mm as its span suits, with as
/// many decimals as the tick step needs, so that neighbouring ticks never read alike (a
/// sub-metre track labelled in whole metres read "-0 -0 0 0").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LengthAxis {
    factor: f64,
    /// The unit the labels are in (`km`, `m`, `cm`, `mm`).
    pub unit: &'static str,
    decimals: usize,
}

impl LengthAxis {
    /// The labelling of an axis spanning `span` metres (about ten ticks, as plotters draws).
    pub fn for_span(span: f64) -> LengthAxis {
        let span = if span.is_finite() && span > 0.0 {
            span
        } else {
            1.0
        };
        let (factor, unit) = match span {
            s if s >= 10_000.0 => (1e-3, "km"),
            s if s >= 1.0 => (1.0, "m"),
            s if s >= 0.01 => (100.0, "cm"),
            _ => (1000.0, "mm"),
        };
        LengthAxis {
            factor,
            unit,
            decimals: decimals(span * factor),
        }
    }

    /// Metres to the labels' unit.
    pub fn factor(&self) -> f64 {
        self.factor
    }

    /// The label of `v` metres (no "-0").
    pub fn label(&self, v: f64) -> String {
        tick(v * self.factor, self.decimals)
    }
}

/// A time axis counted from a round time: minutes since the whole minute (runs under two
/// hours) or hours since the whole hour at or before the first epoch (taken to the second, so
/// a receiver's 23:59:59.999 counts from 00:00), GPST.
pub struct TimeAxis {
    t0: hifitime::Epoch,
    unit: f64,
    /// The axis description, e.g. `hours since 2002-01-30 00:00 GPST`.
    pub desc: String,
}

impl TimeAxis {
    /// The axis of a run from `first` to `last`.
    pub fn new(first: hifitime::Epoch, last: hifitime::Epoch) -> TimeAxis {
        let (unit, name) = if (last - first).to_seconds() < 7200.0 {
            (60.0, "minutes")
        } else {
            (3600.0, "hours")
        };
        let s = gnss::time::to_gpst(first).to_gpst_seconds().round();
        let t0 = hifitime::Epoch::from_gpst_seconds((s / unit).floor() * unit);
        let (y, mo, d, h, mi, ..) = t0.to_gregorian(hifitime::TimeScale::GPST);
        TimeAxis {
            t0,
            unit,
            desc: format!("{name} since {y:04}-{mo:02}-{d:02} {h:02}:{mi:02} GPST"),
        }
    }

    /// The axis value of `t`.
    pub fn x(&self, t: hifitime::Epoch) -> f64 {
        (t - self.t0).to_seconds() / self.unit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ticks a tenth of the span apart read differently, in a unit that suits the span.
    #[test]
    fn length_labels_are_distinct_at_every_span() {
        for span in [0.004, 0.03, 0.3, 0.9, 4.0, 250.0, 4000.0, 60_000.0] {
            let a = LengthAxis::for_span(span);
            let ticks: Vec<String> = (-5..=5).map(|k| a.label(k as f64 * span / 10.0)).collect();
            let mut d = ticks.clone();
            d.dedup();
            assert_eq!(d.len(), ticks.len(), "{span} m in {}: {ticks:?}", a.unit);
            assert!(!ticks
                .iter()
                .any(|t| t.starts_with("-0") && t.parse::<f64>() == Ok(0.0)));
        }
        assert_eq!(LengthAxis::for_span(0.3).unit, "cm");
        assert_eq!(LengthAxis::for_span(0.3).label(-0.001), "0");
        assert_eq!(LengthAxis::for_span(60_000.0).label(12_345.0), "12");
    }

    #[test]
    fn time_axes_start_at_a_round_time() {
        // A receiver's first epoch a millisecond before midnight.
        let first = hifitime::Epoch::from_gregorian(
            2002,
            1,
            29,
            23,
            59,
            59,
            999_000_000,
            hifitime::TimeScale::GPST,
        );
        let day = TimeAxis::new(first, first + hifitime::Duration::from_seconds(86_000.0));
        assert_eq!(day.desc, "hours since 2002-01-30 00:00 GPST");
        assert!(day.x(first).abs() < 1e-6);
        let short = TimeAxis::new(
            first + hifitime::Duration::from_seconds(95.0),
            first + hifitime::Duration::from_seconds(600.0),
        );
        assert_eq!(short.desc, "minutes since 2002-01-30 00:01 GPST");
    }
}
