//! The GNSS camera positions of a MicMac import: what they are assumed to be (survey- or
//! navigation-grade, σ, drift model; said in a note), and for navigation-grade positions the
//! strips from their track.
//!
//! What enters: the OriConvert-style file, the job, the ground frame. What leaves: the
//! positions in the project, the strips, the notes.

use super::common::{ferr, lines, GroundFrame, ImportError, Summary};
use super::micmac_job::{GnssKind, MicMacJob};
use super::write::ProjectOut;
use nalgebra::Vector3;
use std::collections::HashSet;
use std::path::Path;

/// The σ and kind of the positions, and the note that says what was assumed.
pub(super) fn gnss_assumptions(job: &MicMacJob) -> ([f64; 2], GnssKind, String) {
    let kind = job.gnss_kind.unwrap_or(GnssKind::Survey);
    let sigma = job.gnss_sigma.unwrap_or(kind.sigma());
    let given = match (job.gnss_kind, job.gnss_sigma) {
        (None, None) => "assumed survey-grade (RTK/PPK) as no --gnss-kind or --gnss-sigma was given; for navigation-grade positions give --gnss-kind nav",
        (Some(_), None) => "by --gnss-kind",
        (_, Some(_)) => "from --gnss-sigma",
    };
    let drift = match kind {
        GnssKind::Survey => "no drift estimated",
        GnssKind::Navigation => "one offset per strip estimated (drift = \"strip\": it takes up a constant offset and the along-track shift of a latency, as the file has no times for a latency)",
    };
    let note = format!(
        "GNSS positions: σ {} m horizontal, {} m vertical ({given}); {drift}",
        sigma[0], sigma[1]
    );
    (sigma, kind, note)
}

/// Strips for navigation-grade positions: from the positions' track, images in name order
/// ([`super::strips`]), said in a note.
fn nav_strips(
    out: &mut ProjectOut,
    at: &std::collections::HashMap<String, nalgebra::Vector2<f64>>,
    sum: &mut Summary,
) {
    let track: Vec<(String, Option<nalgebra::Vector2<f64>>)> = out
        .images
        .iter()
        .map(|(i, _)| (i.clone(), at.get(i).copied()))
        .collect();
    let strips = super::strips::strips_from_track(&track);
    let n = strips.iter().max().copied().unwrap_or(0);
    out.image_strips = strips.iter().map(|s| s.to_string()).collect();
    sum.notes.push(format!(
        "{n} strips from the GNSS track (images in name order; a new strip where the track turns by more than {}° or jumps): one GNSS offset per strip",
        super::strips::TURN_DEG
    ));
}

/// GNSS camera positions as antenna positions (lever arm zero, fixed).
pub(super) fn add_gnss(
    path: &Path,
    format: &str,
    job: &MicMacJob,
    frame: &GroundFrame,
    out: &mut ProjectOut,
    sum: &mut Summary,
) -> Result<(), ImportError> {
    let (sigma, kind, note) = gnss_assumptions(job);
    sum.notes.push(note);
    out.gnss_navigation = kind == GnssKind::Navigation;
    let rows = read_gnss(path, format)?;
    sum.read.push(("GNSS positions".into(), rows.len()));
    let images: HashSet<String> = out.images.iter().map(|(i, _)| i.clone()).collect();
    let mut ground_xy = std::collections::HashMap::new();
    for (name, p, line) in rows {
        if !images.contains(&name) {
            sum.skipped.push((
                format!("GNSS position of {name} ({}:{line})", path.display()),
                "image not measured".into(),
            ));
            continue;
        }
        ground_xy.insert(name.clone(), nalgebra::Vector2::new(p.x, p.y));
        out.gnss
            .push((name, frame.to_ecef(&p), [sigma[0], sigma[0], sigma[1]]));
    }
    if kind == GnssKind::Navigation {
        nav_strips(out, &ground_xy, sum);
    }
    let located: HashSet<&str> = out.gnss.iter().map(|g| g.0.as_str()).collect();
    let without: Vec<&str> = out
        .images
        .iter()
        .map(|(i, _)| i.as_str())
        .filter(|i| !located.contains(i))
        .collect();
    if !without.is_empty() {
        sum.notes.push(format!(
            "{} measured image(s) have no position in {}: {}",
            without.len(),
            path.display(),
            without.join(", ")
        ));
    }
    Ok(())
}

/// GNSS camera positions in `OriConvert` text: `#F=N X Y Z` (other letters ignored).
fn read_gnss(path: &Path, format: &str) -> Result<Vec<(String, Vector3<f64>, usize)>, ImportError> {
    let fields: Vec<&str> = format
        .trim()
        .trim_start_matches("#F=")
        .split_whitespace()
        .collect();
    let col = |c: &str| fields.iter().position(|f| *f == c);
    let (Some(n), Some(xc), Some(yc), Some(zc)) = (col("N"), col("X"), col("Y"), col("Z")) else {
        return Err(ImportError::Usage(format!(
            "--gnss-format '{format}': name the columns with N X Y Z, e.g. '#F=N X Y Z'"
        )));
    };
    let mut out: Vec<(String, Vector3<f64>, usize)> = Vec::new();
    let mut names = HashSet::new();
    for (line, l) in lines(path)? {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.is_empty() {
            continue;
        }
        let num = |c: usize| {
            f.get(c)
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|v| v.is_finite())
        };
        let (Some(name), Some(a), Some(b), Some(c)) = (f.get(n), num(xc), num(yc), num(zc)) else {
            return Err(ferr(
                path,
                Some(line),
                format!("expected the columns '{format}'"),
            ));
        };
        if !names.insert(name.to_string()) {
            return Err(ferr(
                path,
                Some(line),
                format!("image {name} has two positions: keep one"),
            ));
        }
        out.push((name.to_string(), Vector3::new(a, b, c), line));
    }
    Ok(out)
}
