//! The exposure stage as one run: events and trajectory read, projection centres computed and
//! written, photos matched and geotagged; the report names everything left out.

use gnss::error::{Error, Result};
use gnss::rinex::ObsFile;
use gnss::time::format_ymdhms;
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
    /// Photographs to match to the exposures (their names become the station labels).
    pub photos: Option<PathBuf>,
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
    /// Photo matching: Ok(number matched) or the mismatch found.
    pub photos: Option<std::result::Result<usize, String>>,
    /// Geotagged copies written.
    pub geotagged: usize,
    /// Photos with a problem (EXIF unreadable, not geotagged), each with the reason.
    pub photo_problems: Vec<(PathBuf, String)>,
}

/// Read events and trajectory, compute projection centres, write them.
pub fn exposures(job: &ExposureJob) -> Result<ExposureReport> {
    use crate::exposure::{compute, events, export};
    use gnss::trajectory::Trajectory;
    let traj = Trajectory::read_pos(&job.trajectory)?;
    let (evs, clock_correction) = match &job.events {
        EventSource::Rinex(p) => {
            let obs = ObsFile::read(p)?;
            let (e, c) = events::from_rinex(&obs, &traj);
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
    };
    let n = evs.len();
    let mut result = compute(evs, &traj, &job.options);
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
    let mut photos = None;
    let mut geotagged = 0;
    let mut photo_problems = Vec::new();
    if let Some(dir) = &job.photos {
        use crate::exposure::photos;
        let list = photos::list(dir)?;
        photo_problems.extend(
            list.iter()
                .filter_map(|p| Some((p.path.clone(), p.exif_error.clone()?))),
        );
        match photos::check(&list, &result.stations) {
            Ok(()) => {
                for (s, p) in result.stations.iter_mut().zip(&list) {
                    s.id = p.name.clone();
                }
                if let Some(g) = &job.geotag {
                    let done = photos::geotag(&list, &result.stations, g, &job.heights)?;
                    geotagged = done.written.len();
                    photo_problems.retain(|(p, _)| !done.skipped.iter().any(|(q, _)| p == q));
                    photo_problems.extend(done.skipped);
                }
                photos = Some(Ok(list.len()));
            }
            Err(why) => {
                if job.geotag.is_some() {
                    return Err(Error::input(
                        dir,
                        format!("the photos do not match the exposures, nothing geotagged: {why}"),
                    ));
                }
                photos = Some(Err(why));
            }
        }
    }
    export::write(
        &job.out,
        &result.stations,
        job.format,
        job.projection,
        &job.heights,
    )?;
    Ok(ExposureReport {
        result,
        events: n,
        clock_correction,
        out: job.out.clone(),
        photos,
        geotagged,
        photo_problems,
    })
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
        if self.clock_correction > 0.0 {
            writeln!(
                f,
                "  event times corrected by the receiver clock (up to {:.3} ms)",
                self.clock_correction * 1e3
            )?;
        }
        match &self.photos {
            Some(Ok(n)) => writeln!(f, "  {n} photos matched to the exposures (names used as labels); {} geotagged copies written", self.geotagged)?,
            Some(Err(why)) => writeln!(f, "  PHOTOS DO NOT MATCH: {why}; stations keep their event numbers")?,
            None => {}
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
