//! `ppkat batch`: flights, one per subfolder, found by what their files hold; and the summary
//! table of their runs.
//!
//! A flight folder holds the rover's and the base's observations (RINEX, plain, gzip or
//! Hatanaka, or a raw UBX/RTCM 3 log: the file whose name contains "base" is the base),
//! broadcast navigation files, optionally a DJI `*.MRK`, the photos (JPEG in the folder or in
//! a `photos/` subfolder), and optionally `ppk.toml` and `exposures.toml`: the options of
//! `ppkat ppk` and `ppkat exposures` as their `--config` files take them. What a file names
//! wins over what was found.

use common::lines::Lines;
use gnss::error::{Error, Result};
use gnss::obs::{detect_format, ObsFormat};
use std::path::{Path, PathBuf};

/// One flight: its folder and the files found in it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Flight {
    /// The folder's name, used for its outputs and in the summary.
    pub name: String,
    /// The folder.
    pub dir: PathBuf,
    /// `ppk.toml`: options of `ppkat ppk`.
    pub ppk_config: Option<PathBuf>,
    /// `exposures.toml`: options of `ppkat exposures`.
    pub exposures_config: Option<PathBuf>,
    /// The rover's observations.
    pub rover: Option<PathBuf>,
    /// The base's observations.
    pub base: Option<PathBuf>,
    /// Broadcast navigation files.
    pub nav: Vec<PathBuf>,
    /// A DJI Timestamp.MRK.
    pub mrk: Option<PathBuf>,
    /// The folder of the photos.
    pub photos: Option<PathBuf>,
    /// What could not be settled from the files (several MRK files, observation files that
    /// cannot be told apart); the run of the flight fails with these unless its config file
    /// sets the option named.
    pub problems: Vec<Problem>,
}

/// Something the files of a flight leave open.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// The option that settles it (`rover`, `base` in ppk.toml; `mrk` in exposures.toml).
    pub option: &'static str,
    /// What is open.
    pub text: String,
}

impl Problem {
    fn new(option: &'static str, text: String) -> Problem {
        Problem { option, text }
    }
}

/// What a file holds, from its first bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Observations,
    Navigation,
    Other,
}

/// The flights of `dir`: its subfolders in name order, each with the files found in it.
/// Subfolders holding no observation file and no config file are left out (an output folder
/// beside the flights, say).
pub fn find_flights(dir: &Path) -> Result<Vec<Flight>> {
    let mut out = Vec::new();
    for sub in sorted_entries(dir)? {
        if sub.is_dir() {
            let f = find_flight(&sub)?;
            if f.rover.is_some() || f.base.is_some() || f.ppk_config.is_some() {
                out.push(f);
            }
        }
    }
    Ok(out)
}

/// The entries of a folder, sorted by name (so every run sees them in one order).
fn sorted_entries(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(Error::io(dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    v.sort();
    Ok(v)
}

/// The files of one flight folder.
pub fn find_flight(dir: &Path) -> Result<Flight> {
    let mut f = Flight {
        name: dir
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default(),
        dir: dir.to_path_buf(),
        ..Flight::default()
    };
    let mut obs = Vec::new();
    let mut mrk = Vec::new();
    for p in sorted_entries(dir)? {
        let name = p
            .file_name()
            .map(|n| n.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if p.is_dir() {
            if name == "photos" || name == "images" {
                f.photos = Some(p);
            }
            continue;
        }
        let ext = name.rsplit('.').next().unwrap_or("");
        match (name.as_str(), ext) {
            ("ppk.toml", _) => f.ppk_config = Some(p),
            ("exposures.toml", _) => f.exposures_config = Some(p),
            (_, "mrk") => mrk.push(p),
            (_, "jpg" | "jpeg") => f.photos = f.photos.take().or(Some(dir.to_path_buf())),
            (_, "pos" | "csv" | "html" | "json" | "txt" | "toml" | "md" | "conf") => {}
            _ => match kind(&p) {
                Kind::Observations => obs.push(p),
                Kind::Navigation => f.nav.push(p),
                Kind::Other => {}
            },
        }
    }
    match mrk.len() {
        0 => {}
        1 => f.mrk = mrk.pop(),
        n => f.problems.push(Problem::new(
            "mrk",
            format!("{n} MRK files; name the one to use in exposures.toml (mrk = \"…\")"),
        )),
    }
    assign_rover_and_base(&mut f, obs);
    Ok(f)
}

/// The base is the observation file whose name contains "base", the rover the other one.
fn assign_rover_and_base(f: &mut Flight, obs: Vec<PathBuf>) {
    let is_base = |p: &PathBuf| {
        p.file_name()
            .is_some_and(|n| n.to_string_lossy().to_ascii_lowercase().contains("base"))
    };
    let (bases, rovers): (Vec<PathBuf>, Vec<PathBuf>) = obs.into_iter().partition(is_base);
    let names = |v: &[PathBuf]| -> String {
        v.iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().to_string()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match bases.len() {
        1 => f.base = bases.into_iter().next(),
        0 => f.problems.push(Problem::new(
            "base",
            "no base observations (a file whose name contains \"base\"); or set base in ppk.toml"
                .to_string(),
        )),
        _ => f.problems.push(Problem::new(
            "base",
            format!(
                "several base observation files ({}); set base in ppk.toml",
                names(&bases)
            ),
        )),
    }
    match rovers.len() {
        1 => f.rover = rovers.into_iter().next(),
        0 => f.problems.push(Problem::new(
            "rover",
            "no rover observations; or set rover in ppk.toml".to_string(),
        )),
        _ => f.problems.push(Problem::new(
            "rover",
            format!(
                "several rover observation files ({}); set rover in ppk.toml",
                names(&rovers)
            ),
        )),
    }
}

/// What a file holds: RINEX observations or navigation (from the type letter of its first
/// line; Hatanaka-compressed files are observations), a raw receiver log, or something else.
fn kind(path: &Path) -> Kind {
    let first = Lines::open(path)
        .ok()
        .and_then(|mut l| l.next_line().ok().flatten().map(<[u8]>::to_vec));
    if let Some(line) = first {
        let label = line.get(60..).unwrap_or(&[]);
        if label.starts_with(b"CRINEX VERS") {
            return Kind::Observations;
        }
        if label.starts_with(b"RINEX VERSION / TYPE") {
            return match line.get(20) {
                Some(b'O') => Kind::Observations,
                Some(b'N' | b'G' | b'H' | b'L' | b'P' | b'B' | b'E' | b'J' | b'I') => {
                    Kind::Navigation
                }
                _ => Kind::Other,
            };
        }
    }
    match detect_format(path) {
        Ok(ObsFormat::Raw(_)) => Kind::Observations,
        _ => Kind::Other,
    }
}

/// Whether a rover observation file holds exposure events (flag-5 records with a time): a
/// RINEX file is read for them; raw logs are not (their events are converted by
/// `ppkat convert`).
pub fn has_events(rover: &Path) -> bool {
    matches!(detect_format(rover), Ok(ObsFormat::Rinex))
        && gnss::rinex::ObsFile::read(rover)
            .map(|o| o.exposure_events().next().is_some())
            .unwrap_or(false)
}

/// How one flight's run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Everything asked was done.
    Done,
    /// Done, but inputs were skipped (exposures refused, photos not matched).
    Skipped,
    /// Failed: nothing usable, or no trajectory.
    Failed,
    /// Its task left no result (never ran, killed, still running): from a merge.
    NotRun,
}

/// One line of the summary table.
#[derive(Clone, Debug, PartialEq)]
pub struct SummaryRow {
    /// The flight's name.
    pub flight: String,
    /// How its run ended.
    pub outcome: Outcome,
    /// Rover epochs read.
    pub epochs: usize,
    /// Epochs solved.
    pub solved: usize,
    /// Epochs fixed.
    pub fixed: usize,
    /// Median 3D σ of the solved epochs, metres (NaN when none).
    pub sigma_3d: f64,
    /// Exposures written (`None`: no exposure times in the flight).
    pub exposures: Option<usize>,
    /// Warnings and skipped inputs.
    pub warnings: usize,
    /// The error, or the first warning, on one line.
    pub message: String,
}

impl SummaryRow {
    /// The row of a flight that solved nothing (yet): `outcome` with `message`, no counts.
    pub fn empty(flight: &str, outcome: Outcome, message: String) -> SummaryRow {
        SummaryRow {
            flight: flight.to_string(),
            outcome,
            epochs: 0,
            solved: 0,
            fixed: 0,
            sigma_3d: f64::NAN,
            exposures: None,
            warnings: 0,
            message,
        }
    }

    /// Fixed epochs, percent of solved.
    pub fn fix_percent(&self) -> f64 {
        100.0 * self.fixed as f64 / self.solved.max(1) as f64
    }
}

/// The median of the 3D σ (√trace of the covariance) of a trajectory's epochs, metres.
pub fn median_sigma_3d(t: &gnss::trajectory::Trajectory) -> f64 {
    let mut s: Vec<f64> = t.epochs.iter().map(|e| e.cov.trace().sqrt()).collect();
    if s.is_empty() {
        return f64::NAN;
    }
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

/// The summary as CSV text: a header, then a row per flight.
pub fn summary_csv(rows: &[SummaryRow]) -> String {
    let mut s = String::from(
        "flight,outcome,rover_epochs,solved,fixed,fix_percent,sigma_3d_median_m,exposures,warnings,message\n",
    );
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{},{:.1},{},{},{},\"{}\"\n",
            r.flight,
            outcome_word(r.outcome),
            r.epochs,
            r.solved,
            r.fixed,
            r.fix_percent(),
            if r.sigma_3d.is_finite() {
                format!("{:.4}", r.sigma_3d)
            } else {
                String::new()
            },
            r.exposures.map(|n| n.to_string()).unwrap_or_default(),
            r.warnings,
            r.message.replace('"', "'")
        ));
    }
    s
}

/// The word for an outcome, in the summary.
pub fn outcome_word(o: Outcome) -> &'static str {
    match o {
        Outcome::Done => "done",
        Outcome::Skipped => "skipped inputs",
        Outcome::Failed => "FAILED",
        Outcome::NotRun => "NOT RUN",
    }
}

/// Write the summary table to `path` (whole or not at all).
pub fn write_summary(path: &Path, rows: &[SummaryRow]) -> Result<()> {
    let text = summary_csv(rows);
    common::atomic::write_atomic(path, |w| w.write_all(text.as_bytes())).map_err(Error::from)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obs_header(kind: char) -> String {
        format!(
            "{:<60}RINEX VERSION / TYPE\n",
            format!("     3.04           {kind}: OBS        M")
        )
    }

    #[test]
    fn files_are_told_apart_by_content_and_the_base_by_name() {
        let d = testkit::scratch_dir("batch");
        let f = d.join("flight-1");
        std::fs::create_dir_all(f.join("photos")).unwrap();
        std::fs::write(f.join("ROVR0010.25o"), obs_header('O')).unwrap();
        std::fs::write(f.join("base_ab.rnx"), obs_header('O')).unwrap();
        std::fs::write(f.join("brdc.rnx"), obs_header('N')).unwrap();
        std::fs::write(f.join("notes.dat"), "hello").unwrap();
        std::fs::write(f.join("Timestamp.MRK"), "").unwrap();
        std::fs::write(f.join("ppk.toml"), "").unwrap();
        std::fs::create_dir_all(d.join("empty")).unwrap();
        let flights = find_flights(&d).unwrap();
        assert_eq!(
            flights.len(),
            1,
            "a folder without observations is no flight"
        );
        let g = &flights[0];
        assert_eq!(g.name, "flight-1");
        assert_eq!(g.rover, Some(f.join("ROVR0010.25o")));
        assert_eq!(g.base, Some(f.join("base_ab.rnx")));
        assert_eq!(g.nav, vec![f.join("brdc.rnx")]);
        assert_eq!(g.mrk, Some(f.join("Timestamp.MRK")));
        assert_eq!(g.photos, Some(f.join("photos")));
        assert_eq!(g.ppk_config, Some(f.join("ppk.toml")));
        assert!(g.problems.is_empty(), "{:?}", g.problems);

        std::fs::write(f.join("ROVR0020.25o"), obs_header('O')).unwrap();
        std::fs::write(f.join("other.MRK"), "").unwrap();
        let g = find_flight(&f).unwrap();
        let p: Vec<String> = g.problems.iter().map(|p| p.text.clone()).collect();
        let p = p.join("\n");
        assert!(
            p.contains("2 MRK files") && p.contains("several rover"),
            "{p}"
        );
        assert_eq!(g.rover, None);
    }

    #[test]
    fn the_summary_has_a_row_per_flight() {
        let row = SummaryRow {
            flight: "f1".into(),
            outcome: Outcome::Skipped,
            epochs: 120,
            solved: 115,
            fixed: 113,
            sigma_3d: 0.0123,
            exposures: Some(26),
            warnings: 1,
            message: "exposure 3: \"gap\"".into(),
        };
        let csv = summary_csv(&[row]);
        assert_eq!(
            csv.lines().nth(1),
            Some("f1,skipped inputs,120,115,113,98.3,0.0123,26,1,\"exposure 3: 'gap'\"")
        );
    }
}
