//! The adjustment report's image-residual plots, readable at any block size:
//! - a **systematic pattern**: the image format cut into cells, each coloured by the RMS (per
//!   coordinate, as the images table gives it) of the residuals falling in it (all images together, in each image's own format) with their
//!   mean vector — what uncorrected distortion or a wrong principal point looks like;
//! - **small multiples**: one panel per image, the images with the largest RMS first, all
//!   panels at one scale, so a bad image stands out instead of vanishing in a hairball.
//!
//! Scales and colour keys are drawn beside the data, never over it.

use super::project::Project;
use super::results::Results;
use ::report::plot::{svg_sized, Plot};
use plotters::prelude::*;
use std::collections::BTreeMap;

/// Cells of the pattern plot across and down the format.
const CELLS: (usize, usize) = (8, 6);
/// Most images drawn as small multiples.
const PANELS: usize = 24;
/// Panels per row.
const COLUMNS: usize = 6;

/// A residual in its image's format: position and vector, both divided by the format's
/// width (so images of different cameras share one picture).
#[derive(Clone, Copy)]
struct Norm {
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
}

/// The residuals per image, in its camera's format (width-normalised), and the format's
/// height/width.
fn per_image(p: &Project, r: &Results) -> BTreeMap<String, (Vec<Norm>, f64, f64)> {
    let format: BTreeMap<&str, (f64, f64)> = p
        .images
        .iter()
        .filter_map(|i| {
            let c = &p.cameras.get(i.camera)?.camera;
            Some((i.id.as_str(), (c.width_px as f64, c.height_px as f64)))
        })
        .collect();
    let mut out: BTreeMap<String, (Vec<Norm>, f64, f64)> = BTreeMap::new();
    for v in &r.image_residuals {
        let Some(&(w, h)) = format.get(v.image.as_str()) else {
            continue;
        };
        let e = out
            .entry(v.image.clone())
            .or_insert_with(|| (Vec::new(), w, h / w));
        e.0.push(Norm {
            x: v.px[0] / w,
            y: v.px[1] / w,
            vx: v.v_px[0],
            vy: v.v_px[1],
        });
    }
    out
}

/// Both plots as HTML.
pub(crate) fn image_residual_plots(p: &Project, r: &Results) -> String {
    let images = per_image(p, r);
    if images.is_empty() {
        return String::new();
    }
    let aspect = images.values().map(|i| i.2).fold(0.0, f64::max);
    let mut s = pattern(&images, aspect);
    s.push_str(&small_multiples(&images, aspect));
    s
}

/// A colour from light yellow (0) to dark red (1).
fn heat(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0);
    let lerp = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    RGBColor(lerp(255.0, 165.0), lerp(245.0, 15.0), lerp(200.0, 21.0))
}

/// The systematic-pattern plot: RMS per cell as colour, the mean vector as an arrow.
fn pattern(images: &BTreeMap<String, (Vec<Norm>, f64, f64)>, aspect: f64) -> String {
    let (nx, ny) = CELLS;
    let mut sum = vec![(0usize, 0.0f64, 0.0f64, 0.0f64); nx * ny];
    for (res, _, _) in images.values() {
        for v in res {
            let i = ((v.x * nx as f64) as usize).min(nx - 1);
            let j = ((v.y / aspect * ny as f64).max(0.0) as usize).min(ny - 1);
            let c = &mut sum[j * nx + i];
            c.0 += 1;
            c.1 += v.vx;
            c.2 += v.vy;
            c.3 += v.vx * v.vx + v.vy * v.vy;
        }
    }
    // RMS per coordinate, as the images table states it.
    let rms = |c: &(usize, f64, f64, f64)| (c.3 / (2 * c.0.max(1)) as f64).sqrt();
    let rmax = sum.iter().map(rms).fold(1e-9, f64::max);
    let mean = |c: &(usize, f64, f64, f64)| (c.1 / c.0.max(1) as f64, c.2 / c.0.max(1) as f64);
    let mmax = sum
        .iter()
        .map(|c| mean(c).0.hypot(mean(c).1))
        .fold(1e-9, f64::max);
    let (cw, ch) = (1.0 / nx as f64, aspect / ny as f64);
    let k = 0.45 * cw.min(ch) / mmax;
    let title = format!(
        "Image residuals: systematic pattern over the format (all images; colour: RMS per \
         cell, 0–{rmax:.2} px; arrows: mean residual, the longest {mmax:.2} px)"
    );
    // The format keeps its shape: plot area 420 px high (less when wide), key beside it.
    let plot_w = (420.0 / aspect).min(700.0);
    let plot_h = plot_w * aspect;
    let main_w = plot_w as u32 + 70;
    svg_sized(&title, (main_w + 130, plot_h as u32 + 50), |root| -> Plot {
        let (main, key) = root.split_horizontally(main_w);
        let mut c = ChartBuilder::on(&main)
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..1.0, aspect..0.0)?;
        c.configure_mesh()
            .disable_mesh()
            .x_desc("x / image width")
            .y_desc("y / image width")
            .draw()?;
        for (n, cell) in sum.iter().enumerate() {
            let (i, j) = ((n % nx) as f64, (n / nx) as f64);
            let (x0, y0) = (i * cw, j * ch);
            let fill = if cell.0 == 0 {
                RGBColor(235, 235, 235)
            } else {
                heat(rms(cell) / rmax)
            };
            c.draw_series(std::iter::once(Rectangle::new(
                [(x0, y0), (x0 + cw, y0 + ch)],
                fill.filled(),
            )))?;
            if cell.0 > 0 {
                let (mx, my) = mean(cell);
                let (cx, cy) = (x0 + cw / 2.0, y0 + ch / 2.0);
                c.draw_series(std::iter::once(PathElement::new(
                    vec![(cx, cy), (cx + k * mx, cy + k * my)],
                    BLACK.stroke_width(2),
                )))?;
                c.draw_series(std::iter::once(Circle::new((cx, cy), 2, BLACK.filled())))?;
            }
        }
        colour_key(&key, rmax)
    })
}

/// The colour key beside the pattern plot.
fn colour_key(area: &DrawingArea<SVGBackend, plotters::coord::Shift>, rmax: f64) -> Plot {
    let mut c = ChartBuilder::on(area)
        .margin_top(10)
        .margin_bottom(40)
        .margin_right(40)
        .y_label_area_size(45)
        .caption("RMS (px)", ("sans-serif", 13))
        .build_cartesian_2d(0.0..1.0, 0.0..rmax)?;
    c.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_label_style(("sans-serif", 12))
        .draw()?;
    let steps = 40;
    c.draw_series((0..steps).map(|i| {
        let (a, b) = (i as f64 / steps as f64, (i + 1) as f64 / steps as f64);
        Rectangle::new([(0.0, a * rmax), (1.0, b * rmax)], heat(a).filled())
    }))?;
    Ok(())
}

/// One panel per image (largest RMS first), every panel at the same scale.
fn small_multiples(images: &BTreeMap<String, (Vec<Norm>, f64, f64)>, aspect: f64) -> String {
    let rms = |v: &[Norm]| {
        (v.iter().map(|n| n.vx * n.vx + n.vy * n.vy).sum::<f64>() / (2 * v.len().max(1)) as f64)
            .sqrt()
    };
    let mut order: Vec<(&String, f64)> = images.iter().map(|(k, v)| (k, rms(&v.0))).collect();
    order.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(b.0)));
    order.truncate(PANELS);
    let vmax = order
        .iter()
        .flat_map(|(k, _)| images[*k].0.iter().map(|n| n.vx.hypot(n.vy)))
        .fold(1e-9, f64::max);
    let k = 0.12 / vmax;
    let rows = order.len().div_ceil(COLUMNS);
    // Panels 148 px wide: the format's shape below a caption line.
    let panel_h = (140.0 * aspect + 30.0) as u32;
    let shown = if order.len() < images.len() {
        format!(
            "the {} of {} images with the largest RMS",
            order.len(),
            images.len()
        )
    } else {
        format!("all {} images, largest RMS first", images.len())
    };
    let title = format!(
        "Image residuals per image ({shown}; one scale: a vector 12 % of the width is \
         {vmax:.2} px)"
    );
    svg_sized(&title, (900, rows as u32 * panel_h + 10), |root| -> Plot {
        let areas = root.margin(5, 5, 5, 5).split_evenly((rows, COLUMNS));
        for ((id, r), area) in order.iter().zip(areas) {
            let (res, _, asp) = &images[*id];
            let mut c = ChartBuilder::on(&area)
                .margin(4)
                .caption(
                    format!("{id}: {r:.2} px, {} pts", res.len()),
                    ("sans-serif", 11),
                )
                .build_cartesian_2d(0.0..1.0, *asp..0.0)?;
            c.draw_series(std::iter::once(Rectangle::new(
                [(0.0, 0.0), (1.0, *asp)],
                RGBColor(120, 120, 120).stroke_width(1),
            )))?;
            c.draw_series(res.iter().map(|n| {
                PathElement::new(
                    vec![(n.x, n.y), (n.x + k * n.vx, n.y + k * n.vy)],
                    BLUE.stroke_width(1),
                )
            }))?;
        }
        Ok(())
    })
}
