//! The match report: `match.json` (counts per image and pair, tracks, the photos left out;
//! no timings, which standard output prints, so that the file is the same on every run) and `match_report.html`, self-contained: a table per image and the pair graph drawn
//! at the photos' positions (or on a circle without them), each verified pair a line whose
//! width grows with its matches, photos outside the main block in red.

use super::matched::Matched;
use super::project::Written;
use serde_json::json;
use std::fmt::Write as _;

/// Per image: verified pairs it is in, measurements written.
fn per_image(m: &Matched, w: &Written) -> Vec<(usize, usize)> {
    let mut out = vec![(0usize, 0usize); m.images.len()];
    for p in m.pairs.iter().filter(|p| !p.verified.is_empty()) {
        out[p.a].0 += 1;
        out[p.b].0 += 1;
    }
    let index: std::collections::BTreeMap<&str, usize> = m
        .images
        .iter()
        .enumerate()
        .map(|(i, im)| (im.meta.id.as_str(), i))
        .collect();
    for (img, _, _, _) in &w.project.measurements {
        if let Some(&i) = index.get(img.as_str()) {
            out[i].1 += 1;
        }
    }
    out
}

/// The JSON summary.
pub fn json(m: &Matched, w: &Written) -> serde_json::Value {
    let per = per_image(m, w);
    json!({
        "images": m.images.iter().zip(&per).enumerate().map(|(i, (im, p))| json!({
            "id": im.meta.id, "features": im.features.keypoints.len() - im.measured,
            "matched_pairs": p.0, "observations": p.1, "component": m.component[i],
        })).collect::<Vec<_>>(),
        "pairs_tried": m.pairs.len(),
        "pairs_verified": m.pairs.iter().filter(|p| !p.verified.is_empty()).count(),
        "pair_selection": m.pair_note,
        "tracks": w.tracks, "tracks_3plus": w.tracks_3plus, "observations": w.observations,
        "track_conflicts_cut": m.tracks.conflicts,
        "measurements_off_epipolar_cut": m.inconsistent,
        "measurements_by_completion": m.completed,
        "measurements_by_patches": m.patch_measured,
        "measurements_refined": m.refinement.refined,
        "measurements_not_refined": m.refinement.kept,
        "not_connected": w.not_connected,
        "skipped": m.skipped.iter().chain(&w.no_camera).map(|(n, r)| json!({"file": n, "reason": r})).collect::<Vec<_>>(),
        "cameras": w.cameras.iter().map(|(c, s, n)| json!({"id": c, "focal_from": s, "photos": n})).collect::<Vec<_>>(),
    })
}

/// Node positions in a 600 × 460 box: ENU when every image has one, else a circle.
fn layout(pos: &[Option<nalgebra::Vector3<f64>>]) -> Vec<(f64, f64)> {
    let n = pos.len().max(1) as f64;
    if pos.iter().any(Option::is_none) || pos.len() < 2 {
        return (0..pos.len())
            .map(|i| {
                let a = i as f64 / n * std::f64::consts::TAU;
                (300.0 + 200.0 * a.cos(), 230.0 + 200.0 * a.sin())
            })
            .collect();
    }
    let p: Vec<_> = pos.iter().flatten().collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for q in &p {
        x0 = x0.min(q.x);
        x1 = x1.max(q.x);
        y0 = y0.min(q.y);
        y1 = y1.max(q.y);
    }
    let s = (540.0 / (x1 - x0).max(1e-9)).min(400.0 / (y1 - y0).max(1e-9));
    p.iter()
        .map(|q| (30.0 + (q.x - x0) * s, 430.0 - (q.y - y0) * s))
        .collect()
}

/// The HTML report.
pub fn html(m: &Matched, w: &Written) -> String {
    let per = per_image(m, w);
    let xy = layout(&m.enu);
    let mut svg = String::from(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="600" height="460" style="border:1px solid #ccc">"#,
    );
    for p in m.pairs.iter().filter(|p| !p.verified.is_empty()) {
        let (a, b) = (xy[p.a], xy[p.b]);
        let width = (p.verified.len() as f64).log10().max(0.3);
        let _ = write!(
            svg,
            r##"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="#4477aa" stroke-opacity="0.5" stroke-width="{width:.2}"><title>{} – {}: {} matches</title></line>"##,
            a.0,
            a.1,
            b.0,
            b.1,
            m.images[p.a].meta.id,
            m.images[p.b].meta.id,
            p.verified.len()
        );
    }
    for (i, im) in m.images.iter().enumerate() {
        let (x, y) = xy[i];
        let c = if m.component[i] == 0 {
            "#222"
        } else {
            "#cc3311"
        };
        let _ = write!(
            svg,
            r#"<circle cx="{x:.1}" cy="{y:.1}" r="5" fill="{c}"><title>{}</title></circle><text x="{:.1}" y="{:.1}" font-size="10" fill="{c}">{}</text>"#,
            im.meta.id,
            x + 6.0,
            y - 6.0,
            im.meta.id
        );
    }
    svg.push_str("</svg>");
    let mut rows = String::new();
    for (i, im) in m.images.iter().enumerate() {
        let _ = write!(
            rows,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            im.meta.id,
            im.features.keypoints.len(),
            per[i].0,
            per[i].1,
            if m.component[i] == 0 {
                "block".into()
            } else {
                format!("not connected ({})", m.component[i])
            }
        );
    }
    let skipped: String = m
        .skipped
        .iter()
        .chain(&w.no_camera)
        .map(|(n, r)| format!("<li>{n}: {r}</li>"))
        .collect();
    format!(
        r#"<!doctype html><html><head><meta charset="utf-8"><title>ppkat match</title><style>body{{font-family:sans-serif;margin:2em;max-width:1000px}}table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:2px 8px;text-align:right}}</style></head><body>
<h1>ppkat match</h1>
<p>{} photos in the block, {} not connected, {} left out. {} tracks ({} seen in ≥ 3 photos), {} measurements. Pairs: {} tried, {} verified — {}.</p>
<h2>Pair graph</h2><p>Photos at their positions (east right, north up); a line per verified pair, wider with more matches; red: not connected to the block.</p>{svg}
<h2>Photos</h2><table><tr><th>photo</th><th>features</th><th>verified pairs</th><th>measurements</th><th></th></tr>{rows}</table>
<h2>Left out</h2><ul>{}</ul></body></html>"#,
        m.component.iter().filter(|&&c| c == 0).count() - w.no_camera.len(),
        w.not_connected.len(),
        m.skipped.len() + w.no_camera.len(),
        w.tracks,
        w.tracks_3plus,
        w.observations,
        m.pairs.len(),
        m.pairs.iter().filter(|p| !p.verified.is_empty()).count(),
        m.pair_note,
        if skipped.is_empty() {
            "<li>none</li>".to_string()
        } else {
            skipped
        },
    )
}

/// [`json()`] as pretty-printed text.
pub fn json_text(m: &Matched, w: &Written) -> String {
    serde_json::to_string_pretty(&json(m, w)).unwrap_or_default()
}
