//! `ppkat bench match --photos N`: tie points on a rendered block of N photos with exact truth,
//! timed and measured stage by stage.
//!
//! The block is the textured block's scene (`simulate --builtin textured-block`) flown as
//! about √N / 2 strips of 1600 × 1200 px photos; it is rendered once into a folder and reused
//! by later runs asking for the same number. The match runs as `ppkat match` does (with the
//! antenna positions, or without any with `--no-positions`), without a feature cache, and each
//! stage's wall time and peak resident memory are taken (Linux: `VmHWM`, reset between
//! stages through `/proc/self/clear_refs`). Every track is then checked against the truth:
//! the ground point of its measurements (rays ∩ terrain, averaged) projected into its photos
//! must fall within 2 px of each measurement.

use crate::bench::peak_rss_kib;
use crate::simulate::textured::{textured_block, TexturedSpec, Truth};
use crate::tiepoints::{self, project, MatchJob, PairMode};
use gnss::frame::Enu;
use nalgebra::{Vector2, Vector3};
use std::path::Path;
use std::sync::Mutex;

/// What the benchmark measured.
#[derive(Clone, Debug)]
pub struct MatchBench {
    /// Photos, strips × per strip.
    pub photos: usize,
    /// Strips and photos per strip.
    pub layout: (usize, usize),
    /// Seconds spent rendering (None: the block was reused).
    pub render_s: Option<f64>,
    /// Wall time of each stage (s) and its peak resident memory (KiB).
    pub stages: Vec<(String, f64, Option<u64>)>,
    /// How the pairs were chosen.
    pub pair_note: String,
    /// Pairs tried and verified.
    pub pairs: (usize, usize),
    /// Photos in the main block.
    pub in_block: usize,
    /// The block's truth check.
    pub check: TrackCheck,
}

/// Tracks against the truth.
#[derive(Clone, Copy, Debug, Default)]
pub struct TrackCheck {
    /// Tracks checked (every measurement's ray meets the terrain).
    pub tracks: usize,
    /// Tracks in three photos or more.
    pub tracks_3plus: usize,
    /// Tracks whose every measurement lies within 2 px of the projection of their ground point.
    pub correct: usize,
    /// RMS of the measurements' distances from those projections (those within 2 px), px.
    pub rms_px: f64,
}

/// Check the measurements (image, point, x, y) of a matched block against the truth.
pub fn check_tracks(truth: &Truth, measurements: &[(String, String, f64, f64)]) -> TrackCheck {
    let mut by_point: std::collections::BTreeMap<&str, Vec<(&str, Vector2<f64>)>> =
        Default::default();
    for (img, pt, x, y) in measurements {
        by_point
            .entry(pt.as_str())
            .or_default()
            .push((img.as_str(), Vector2::new(*x, *y)));
    }
    let mut c = TrackCheck::default();
    let (mut sum, mut n) = (0.0, 0usize);
    for obs in by_point.values() {
        let gs: Vec<Enu> = obs
            .iter()
            .filter_map(|(i, xy)| truth.ground_of(i, *xy))
            .collect();
        if gs.len() != obs.len() || gs.is_empty() {
            continue;
        }
        c.tracks += 1;
        c.tracks_3plus += usize::from(obs.len() >= 3);
        let g = Enu(gs.iter().map(|g| g.0).sum::<Vector3<f64>>() / gs.len() as f64);
        let mut ok = true;
        for (img, xy) in obs {
            match truth.project(img, &g).map(|p| (p - xy).norm()) {
                Some(e) if e <= 2.0 => {
                    sum += e * e;
                    n += 1;
                }
                _ => ok = false,
            }
        }
        c.correct += usize::from(ok);
    }
    c.rms_px = (sum / n.max(1) as f64).sqrt();
    c
}

/// Strips and photos per strip for about `n` photos: about √n / 2 strips.
pub fn layout(n: usize) -> (usize, usize) {
    let strips = ((n as f64).sqrt() / 2.0).round().max(1.0) as usize;
    (strips, n.div_ceil(strips).max(1))
}

/// The stage running (None before the first and after the last) and the peak resident
/// memory (KiB) of each stage done.
type StagePeaks = (Option<String>, Vec<(String, Option<u64>)>);

/// Reset the peak resident memory (Linux); false where that cannot be done.
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Render (or reuse) the block of about `n` photos in `dir` and match it, with the antenna
/// positions or without (`positions`), on the current thread pool.
pub fn run(n: usize, dir: &Path, positions: bool) -> Result<MatchBench, String> {
    let (strips, per_strip) = layout(n);
    let spec = TexturedSpec {
        strips,
        per_strip,
        ties: 12 * strips * per_strip,
        ..TexturedSpec::builtin()
    };
    let photos = strips * per_strip;
    let rendered = std::fs::read_dir(dir.join("photos")).map_or(0, |d| d.count());
    let render_s = if rendered == photos && dir.join("truth.toml").is_file() {
        None
    } else {
        let t = std::time::Instant::now();
        let _ = std::fs::remove_dir_all(dir);
        textured_block(&spec, dir).map_err(|e| e.to_string())?;
        Some(t.elapsed().as_secs_f64())
    };
    let mut job = MatchJob::new(dir.join("photos"));
    job.camera = Some(dir.join("camera.toml"));
    if positions {
        job.exposures = Some(dir.join("antennas.csv"));
    } else {
        job.ignore_gps = true;
    }
    job.pairs = PairMode::Auto;
    let stage: Mutex<StagePeaks> = Default::default();
    let turn = |next: Option<&str>| {
        let mut s = stage.lock().unwrap_or_else(|e| e.into_inner());
        if s.0.as_deref() == next {
            return;
        }
        if let Some(done) = s.0.take() {
            s.1.push((done, peak_rss_kib()));
        }
        reset_peak();
        s.0 = next.map(str::to_string);
    };
    reset_peak();
    let t = std::time::Instant::now();
    let m = tiepoints::run(&job, &|name, _, _| turn(Some(name))).map_err(|e| e.to_string())?;
    turn(Some("project"));
    let t_build = std::time::Instant::now();
    let w = project::build(&job, &m).map_err(|e| e.to_string())?;
    let build_s = t_build.elapsed().as_secs_f64();
    let total_s = t.elapsed().as_secs_f64();
    turn(None);
    let peaks = stage.into_inner().unwrap_or_else(|e| e.into_inner()).1;
    let peak_of = |name: &str| peaks.iter().find(|p| p.0 == name).and_then(|p| p.1);
    let mut stages: Vec<(String, f64, Option<u64>)> = m
        .timing
        .iter()
        .map(|(s, secs)| {
            let key = if s == "matching" { "pairs" } else { s.as_str() };
            (s.clone(), *secs, peak_of(key))
        })
        .collect();
    stages.push(("project".into(), build_s, peak_of("project")));
    stages.push((
        "match in all".into(),
        total_s,
        peaks.iter().filter_map(|p| p.1).max(),
    ));
    let truth = Truth::load(dir).map_err(|e| e.to_string())?;
    Ok(MatchBench {
        photos,
        layout: (strips, per_strip),
        render_s,
        stages,
        pair_note: m.pair_note.clone(),
        pairs: (
            m.pairs.len(),
            m.pairs.iter().filter(|p| !p.verified.is_empty()).count(),
        ),
        in_block: w.project.images.len(),
        check: check_tracks(&truth, &w.project.measurements),
    })
}

impl std::fmt::Display for MatchBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mib = |k: Option<u64>| k.map_or("n/a".to_string(), |k| format!("{} MiB", k / 1024));
        writeln!(
            f,
            "block: {} photos ({} strips × {}), 1600 × 1200 px, {}",
            self.photos,
            self.layout.0,
            self.layout.1,
            self.render_s
                .map_or("rendered earlier (reused)".to_string(), |s| format!(
                    "rendered in {s:.0} s"
                ))
        )?;
        writeln!(f, "pairs: {}", self.pair_note)?;
        writeln!(f, "pairs verified: {} of {}", self.pairs.1, self.pairs.0)?;
        for (s, secs, peak) in &self.stages {
            writeln!(f, "stage {s}: {secs:.1} s, peak RSS {}", mib(*peak))?;
        }
        let c = &self.check;
        writeln!(
            f,
            "tracks: {} ({} in 3 or more photos), {:.2} % correct (every measurement within 2 px of the truth), measurement RMS {:.3} px",
            c.tracks,
            c.tracks_3plus,
            100.0 * c.correct as f64 / c.tracks.max(1) as f64,
            c.rms_px
        )?;
        writeln!(
            f,
            "photos in the block: {} of {}",
            self.in_block, self.photos
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_are_about_half_root_n_strips() {
        assert_eq!(layout(1000), (16, 63));
        assert_eq!(layout(24), (2, 12));
        assert_eq!(layout(1), (1, 1));
    }
}
