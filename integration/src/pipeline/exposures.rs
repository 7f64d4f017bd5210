//! The exposure stage as one run: events and trajectory read, exposures named (photos, a
//! names file, DJI numbers, `E0001`), projection centres computed and written, photos
//! geotagged; the report names everything left out.

use crate::exposure::events::{self, ExposureEvent};
use crate::exposure::names::{self, PhotoMatch};
use crate::exposure::photos::Photo;
use crate::exposure::CameraStation;
use gnss::error::{Error, Result};
use gnss::rinex::ObsFile;
use gnss::time::format_ymdhms;
use std::collections::HashMap;
use std::fmt;
use std::path::PathBuf;

/// Where the exposure times come from.
#[derive(Clone, Debug)]
pub enum EventSource {
    /// Flag-5 events of a RINEX observation file (receiver clock removed).
    Rinex(PathBuf),
    /// A DJI `Timestamp.MRK`.
    Mrk(PathBuf),
    /// A CSV of times in the given time system.
    Times(PathBuf, crate::exposure::events::TimeSystem),
}

/// Inputs of the exposure stage.
#[derive(Clone, Debug)]
pub struct ExposureJob {
    /// The trajectory (`.pos`, ours or RTKLIB's).
    pub trajectory: PathBuf,
    /// Where the exposure times come from.
    pub events: EventSource,
    /// Lever arm, attitude, delay, gap limit.
    pub options: crate::exposure::ExposureOptions,
    /// Output layout.
    pub format: crate::exposure::export::Format,
    /// Horizontal coordinates of the output.
    pub projection: crate::exposure::export::Projection,
    /// Heights of the output and of the geotags: ellipsoidal or above a geoid.
    pub heights: crate::height::Heights,
    /// Output file.
    pub out: PathBuf,
    /// Photographs to pair with the exposures (their file names become the exposure names;
    /// see [`crate::exposure::names::match_photos`]).
    pub photos: Option<PathBuf>,
    /// A names file: one name per exposure, in exposure order (instead of `photos`).
    pub names: Option<PathBuf>,
    /// Write geotagged copies of the photos into this folder (originals untouched).
    pub geotag: Option<PathBuf>,
}

/// What the exposure stage did.
#[derive(Clone, Debug)]
pub struct ExposureReport {
    /// The stations and what was refused.
    pub result: crate::exposure::ExposureResult,
    /// Exposures read.
    pub events: usize,
    /// Largest receiver clock correction applied to the event times, seconds.
    pub clock_correction: f64,
    /// The file written.
    pub out: PathBuf,
    /// Where the exposure names came from.
    pub names: String,
    /// Set when the exposures got only `E0001`-style names: what to give for better ones
    /// (`ppkat` prints it on standard error).
    pub names_note: Option<String>,
    /// Photo pairing: Ok(number paired) or the mismatch found.
    pub photos: Option<std::result::Result<usize, String>>,
    /// Geotagged copies written.
    pub geotagged: usize,
    /// Photos with a problem (EXIF unreadable, not geotagged), each with the reason.
    pub photo_problems: Vec<(PathBuf, String)>,
}

/// Read events and trajectory, name the exposures, compute projection centres, write them.
pub fn exposures(job: &ExposureJob) -> Result<ExposureReport> {
    use crate::exposure::{compute, export};
    let traj = gnss::trajectory::Trajectory::read_pos(&job.trajectory)?;
    let (mut evs, clock_correction) = read_events(&job.events, &traj)?;
    let n = evs.len();
    let naming = name_events(job, &mut evs)?;
    let result = compute(evs, &traj, &job.options);
    if result.stations.is_empty() {
        return Err(Error::NoData(format!(
            "none of the {n} exposures could be placed on the trajectory {} (first refusal: {})",
            job.trajectory.display(),
            result
                .refused
                .first()
                .map(|r| format!("{} at {}: {}", r.id, format_ymdhms(r.time), r.why))
                .unwrap_or_default()
        )));
    }
    let mut photo_problems = naming.problems;
    let mut geotagged = 0;
    let mut staged = None;
    if let (Some(g), Some(Ok(m))) = (&job.geotag, &naming.photos) {
        let (photos, stations) = paired(m, &result.stations);
        let (done, dir) =
            crate::exposure::photos::geotag_staged(&photos, &stations, g, &job.heights)?;
        geotagged = done.written.len();
        staged = Some(dir);
        photo_problems.retain(|(p, _)| !done.skipped.iter().any(|(q, _)| p == q));
        photo_problems.extend(done.skipped);
    }
    // The tagged copies wait staged until the stations file is written, then are swapped in
    // right after it: a run killed on the way leaves both outputs old, or (in the moment
    // between the two renames) the new file beside the old folder.
    export::write(
        &job.out,
        &result.stations,
        job.format,
        job.projection,
        &job.heights,
    )?;
    if let Some(dir) = staged {
        dir.commit()?;
    }
    Ok(ExposureReport {
        result,
        events: n,
        clock_correction,
        out: job.out.clone(),
        names: naming.source,
        names_note: naming.note,
        photos: naming.photos.map(|r| r.map(|m| m.pairs.len())),
        geotagged,
        photo_problems,
    })
}

/// The exposures of a source, and the largest receiver-clock correction applied (s).
fn read_events(
    source: &EventSource,
    traj: &gnss::trajectory::Trajectory,
) -> Result<(Vec<ExposureEvent>, f64)> {
    Ok(match source {
        EventSource::Rinex(p) => {
            let obs = ObsFile::read(p)?;
            let (e, c) = events::from_rinex(&obs, traj);
            if e.is_empty() {
                return Err(Error::input(
                    p,
                    "the file holds no flag-5 event (camera exposure) records",
                ));
            }
            (e, c)
        }
        EventSource::Mrk(p) => (events::read_mrk(p)?, 0.0),
        EventSource::Times(p, sys) => (events::read_times_csv(p, *sys)?, 0.0),
    })
}

/// How the exposures were named.
struct Naming {
    /// Where the names came from.
    source: String,
    /// Set for `E0001`-style names: what to give instead.
    note: Option<String>,
    /// The photos' pairing, or why they do not match.
    photos: Option<std::result::Result<PhotoMatch, String>>,
    /// Photos (or exposures) that could not be used, with the reason.
    problems: Vec<(PathBuf, String)>,
}

/// Name the exposures: from the names file, else from the photos when they pair, else as
/// their source names them (`DJI_NNNN`, the CSV's ids, `E0001` with a note). Photos that do
/// not match are an error when geotagged copies are asked for.
fn name_events(job: &ExposureJob, evs: &mut [ExposureEvent]) -> Result<Naming> {
    let mut naming = Naming {
        source: String::new(),
        note: None,
        photos: None,
        problems: Vec::new(),
    };
    if let Some(path) = &job.names {
        names::apply_file(evs, names::read_file(path)?, path)?;
        naming.source = format!("from {}", path.display());
        return Ok(naming);
    }
    if let Some(dir) = &job.photos {
        let list = crate::exposure::photos::list(dir)?;
        naming.problems.extend(
            list.iter()
                .filter_map(|p| Some((p.path.clone(), p.exif_error.clone()?))),
        );
        match names::match_photos(evs, list) {
            Ok(m) => {
                names::apply_photos(evs, &m);
                naming.source = format!(
                    "the photos' file names ({} paired {})",
                    m.pairs.len(),
                    m.order
                );
                naming.problems.extend(m.unpaired_photos.iter().cloned());
                naming.problems.extend(
                    m.unpaired_exposures
                        .iter()
                        .map(|e| (dir.clone(), e.clone())),
                );
                naming.photos = Some(Ok(m));
                return Ok(naming);
            }
            Err(why) if job.geotag.is_some() => {
                return Err(Error::input(
                    dir,
                    format!("the photos do not match the exposures, nothing geotagged: {why}"),
                ));
            }
            Err(why) => naming.photos = Some(Err(why)),
        }
    }
    let generic = evs
        .iter()
        .enumerate()
        .all(|(k, e)| e.id == names::generic(k));
    naming.source = match &job.events {
        EventSource::Mrk(_) => "DJI_NNNN from the MRK indices".into(),
        EventSource::Times(p, _) if !generic => format!("the id column of {}", p.display()),
        _ => "E0001, E0002 … in exposure order".into(),
    };
    if generic && naming.photos.is_none() {
        naming.note = Some(format!("the {} exposures are named E0001 … E{:04}: give --photos DIR (names from the photographs) or --names FILE (one name per line) for names other tools can join to the images", evs.len(), evs.len()));
    }
    Ok(naming)
}

/// The paired photos and the stations they belong to (by name), in the same order; photos
/// whose exposure got no station are left out.
fn paired(m: &PhotoMatch, stations: &[CameraStation]) -> (Vec<Photo>, Vec<CameraStation>) {
    let by_name: HashMap<&str, &CameraStation> =
        stations.iter().map(|s| (s.id.as_str(), s)).collect();
    m.pairs
        .iter()
        .filter_map(|&(_, j)| {
            let p = &m.photos[j];
            let s = by_name.get(p.name.as_str())?;
            Some((p.clone(), (*s).clone()))
        })
        .unzip()
}

impl ExposureReport {
    /// Every input left out or not fully used, each as "name: why" (refused exposures,
    /// photos that do not match, photos with a problem); empty when everything was used.
    pub fn skipped(&self) -> Vec<String> {
        let mut out: Vec<String> = self
            .result
            .refused
            .iter()
            .map(|r| format!("exposure {}: {}", r.id, r.why))
            .collect();
        if let Some(Err(why)) = &self.photos {
            out.push(format!("photos: they do not match the exposures ({why})"));
        }
        out.extend(
            self.photo_problems
                .iter()
                .map(|(p, why)| format!("{}: {why}", p.display())),
        );
        out
    }
}

impl fmt::Display for ExposureReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.result;
        writeln!(
            f,
            "exposures: {} read, {} camera stations written → {}",
            self.events,
            r.stations.len(),
            self.out.display()
        )?;
        writeln!(f, "  names: {}", self.names)?;
        if self.clock_correction > 0.0 {
            writeln!(
                f,
                "  event times corrected by the receiver clock (up to {:.3} ms)",
                self.clock_correction * 1e3
            )?;
        }
        match &self.photos {
            Some(Ok(_)) if self.geotagged > 0 => {
                writeln!(f, "  {} geotagged copies written", self.geotagged)?
            }
            Some(Err(why)) => writeln!(f, "  PHOTOS DO NOT MATCH: {why}")?,
            _ => {}
        }
        let flagged = r.stations.iter().filter(|s| !s.flags.is_empty()).count();
        if flagged > 0 {
            writeln!(
                f,
                "  {flagged} stations flagged (see the flags column): e.g. {}",
                r.stations
                    .iter()
                    .find(|s| !s.flags.is_empty())
                    .map(|s| s.flags.join("; "))
                    .unwrap_or_default()
            )?;
        }
        for x in r.refused.iter().take(20) {
            writeln!(
                f,
                "  refused {} at {}: {}",
                x.id,
                format_ymdhms(x.time),
                x.why
            )?;
        }
        if r.refused.len() > 20 {
            writeln!(f, "  … {} more refused", r.refused.len() - 20)?;
        }
        for (p, why) in &self.photo_problems {
            writeln!(f, "  photo {}: {why}", p.display())?;
        }
        for w in &r.warnings {
            writeln!(f, "  warning: {w}")?;
        }
        for n in &r.notes {
            writeln!(f, "  note: {n}")?;
        }
        Ok(())
    }
}
