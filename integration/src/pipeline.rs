//! Whole-stage runs used by the command line: read inputs, check they fit together, process,
//! write outputs atomically, and return a report of what was done and what was rejected.
//!
//! Enters: a job naming the input files and holding the library options ([`SppJob`],
//! [`PpkJob`], [`ExposureJob`]). Leaves: the output file (`.pos` or an exposure export) and a
//! report ([`SppReport`], [`PpkReport`], [`ExposureReport`]) whose `Display` is what `ppkat`
//! prints. Uses `gnss` (RINEX, orbits, SPP, PPK, `.pos`) and [`crate::exposure`]; prints
//! nothing itself.

use crate::orbits::check_glonass_channels;
pub use crate::orbits::{check_overlap, load_orbits};
use gnss::error::{Error, Result};
use gnss::rinex::ObsFile;
use gnss::solution::{PosRecord, Quality};
use gnss::spp::{SppOptions, SppRun};
use gnss::time::format_ymdhms;
use hifitime::Epoch;
use std::fmt;
use std::path::PathBuf;

/// Inputs of a single-point run.
#[derive(Clone, Debug)]
pub struct SppJob {
    /// Observation file.
    pub obs: PathBuf,
    /// Navigation files (optional with SP3 files).
    pub nav: Vec<PathBuf>,
    /// Precise orbits (SP3; any number, merged), used instead of the broadcast ones when given.
    pub sp3: Vec<PathBuf>,
    /// RINEX clock files (any number, merged), used instead of the SP3 clocks when given.
    pub clk: Vec<PathBuf>,
    /// Processing options.
    pub options: SppOptions,
    /// Layout of the trajectory written (`.pos` llh/xyz, KML, GeoJSON, GPX).
    pub format: crate::vector::TrajectoryFormat,
    /// Output `.pos`.
    pub out: PathBuf,
}

/// What a single-point run did.
#[derive(Clone, Debug)]
pub struct SppReport {
    /// Epochs read.
    pub epochs: usize,
    /// Epochs solved.
    pub solved: usize,
    /// What the solver did.
    pub run: SppRun,
    /// Problems with the inputs (reading went on).
    pub warnings: Vec<String>,
    /// The `.pos` written.
    pub out: PathBuf,
}

/// What reading an observation file noticed, each as `path:line: what`.
fn file_warnings(f: &ObsFile) -> impl Iterator<Item = String> + '_ {
    f.warnings
        .iter()
        .map(|w| format!("{}:{}: {}", f.path.display(), w.line, w.what))
}

/// Run single-point positioning over a file and write the `.pos` output.
pub fn spp(job: &SppJob) -> Result<SppReport> {
    let obs = ObsFile::read(&job.obs)?;
    let (orbits, mut warnings) = load_orbits(&job.nav, &job.sp3, &job.clk)?;
    check_overlap(&obs, &orbits, &job.nav)?;
    warnings.extend(check_glonass_channels(&obs, &orbits, &job.options.systems)?);
    warnings.extend(file_warnings(&obs));
    let run = gnss::spp::run(&obs.epochs, &obs.header, &orbits, &job.options);
    let records: Vec<PosRecord> = run
        .solutions
        .iter()
        .map(|s| PosRecord {
            time: s.time,
            pos: s.pos,
            quality: Quality::Single,
            nsat: s.nsat,
            cov: s.cov,
            age: 0.0,
            ratio: 0.0,
        })
        .collect();
    let systems: String = job.options.systems.iter().map(|s| s.letter()).collect();
    let header = vec![
        format!(
            "program   : ppkat {} (single point)",
            env!("CARGO_PKG_VERSION")
        ),
        format!("inp file  : {}", job.obs.display()),
        format!("elev mask : {:.1} deg", job.options.elev_mask.to_degrees()),
        format!("systems   : {systems}"),
        format!(
            "epochs    : {} read, {} solved",
            obs.epochs.len(),
            records.len()
        ),
    ];
    let mut header = header;
    for n in job.nav.iter().chain(&job.sp3).chain(&job.clk).rev() {
        header.insert(2, format!("inp file  : {}", n.display()));
    }
    crate::vector::write(&job.out, &header, &records, job.format)?;
    Ok(SppReport {
        epochs: obs.epochs.len(),
        solved: records.len(),
        run,
        warnings,
        out: job.out.clone(),
    })
}

impl fmt::Display for SppReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "single point: {} of {} epochs solved → {}",
            self.solved,
            self.epochs,
            self.out.display()
        )?;
        let mut reasons: std::collections::BTreeMap<String, (usize, Option<Epoch>)> =
            Default::default();
        for (t, why) in &self.run.failures {
            let e = reasons
                .entry(why.kind().to_string())
                .or_insert((0, Some(*t)));
            e.0 += 1;
        }
        for (why, (n, first)) in reasons {
            writeln!(
                f,
                "  {n} epochs unsolved: {why} (first at {})",
                first.map(format_ymdhms).unwrap_or_default()
            )?;
        }
        for (r, n) in &self.run.rejections {
            writeln!(f, "  satellite-epochs rejected, {r}: {n}")?;
        }
        for w in self.warnings.iter().take(20) {
            writeln!(f, "  warning: {w}")?;
        }
        if self.warnings.len() > 20 {
            writeln!(f, "  … {} more warnings", self.warnings.len() - 20)?;
        }
        Ok(())
    }
}

/// Inputs of a carrier-phase run.
#[derive(Clone, Debug)]
pub struct PpkJob {
    /// Rover observation file.
    pub rover: PathBuf,
    /// Base observation file.
    pub base: PathBuf,
    /// Navigation files (optional with SP3 files).
    pub nav: Vec<PathBuf>,
    /// Precise orbits (SP3; any number, merged), used instead of the broadcast ones when given.
    pub sp3: Vec<PathBuf>,
    /// RINEX clock files (any number, merged), used instead of the SP3 clocks when given.
    pub clk: Vec<PathBuf>,
    /// Where the base antenna is.
    pub base_position: gnss::ppk::BasePosition,
    /// Find the base marker by static PPP on the base file first (needs SP3), instead of
    /// `base_position`.
    pub base_from_ppp: bool,
    /// Processing options.
    pub options: gnss::ppk::PpkOptions,
    /// Layout of the trajectory written (`.pos` llh/xyz, KML, GeoJSON, GPX).
    pub format: crate::vector::TrajectoryFormat,
    /// Output `.pos`.
    pub out: PathBuf,
    /// The quality report to write (HTML), if any.
    pub report: Option<PathBuf>,
}

/// What a carrier-phase run did.
#[derive(Clone, Debug)]
pub struct PpkReport {
    /// The carrier-phase result (trajectory, pass counters, unsolved epochs).
    pub result: gnss::ppk::PpkResult,
    /// The `.pos` written.
    pub out: PathBuf,
    /// The static summary written beside it (`OUT.pos.json`; static runs only).
    pub summary: Option<PathBuf>,
    /// The quality report written (HTML), when asked for.
    pub report: Option<PathBuf>,
    /// The point of the rover the positions describe.
    pub refer: gnss::ppk::Reference,
    /// Problems with the inputs and the run.
    pub warnings: Vec<String>,
    /// Wall time, seconds.
    pub seconds: f64,
    /// Of it, reading and checking the inputs, seconds.
    pub read_seconds: f64,
    /// Of it, the carrier-phase engine, seconds.
    pub process_seconds: f64,
}

/// `OUT.pos` → `OUT.pos.json`.
fn summary_path(out: &std::path::Path) -> PathBuf {
    let mut name = out.as_os_str().to_owned();
    name.push(".json");
    PathBuf::from(name)
}

/// Run PPK and write the `.pos` output. `progress(n)` is called as epochs are processed.
pub fn ppk(job: &PpkJob, progress: &(dyn Fn(usize) + Sync)) -> Result<PpkReport> {
    let t0 = std::time::Instant::now();
    let rover = ObsFile::read(&job.rover)?;
    let base = ObsFile::read(&job.base)?;
    gnss::ppk::require_phase(&rover, "rover")?;
    gnss::ppk::require_phase(&base, "base")?;
    let (orbits, mut warnings) = load_orbits(&job.nav, &job.sp3, &job.clk)?;
    check_overlap(&rover, &orbits, &job.nav)?;
    warnings.extend(check_glonass_channels(
        &rover,
        &orbits,
        &job.options.systems,
    )?);
    warnings.extend(file_warnings(&rover).chain(file_warnings(&base)));
    let mut base_position = job.base_position;
    let mut base_line = None;
    if job.base_from_ppp {
        if orbits.precise.is_none() {
            return Err(Error::NoData(
                "--base-from-ppp needs precise orbits (--sp3)".into(),
            ));
        }
        let (p, line, w) = crate::ppp::base_from_ppp(
            &base,
            &orbits,
            job.options.antex.as_deref(),
            &job.options.systems,
        )?;
        base_position = gnss::ppk::BasePosition::Given(p);
        base_line = Some(line);
        warnings.extend(w);
    }
    let read_seconds = t0.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    let result = gnss::ppk::process(
        &rover,
        &base,
        base_position,
        &orbits,
        &job.options,
        progress,
    )?;
    let process_seconds = t1.elapsed().as_secs_f64();
    warnings.extend(result.warnings.iter().cloned());
    let o = &job.options;
    let b = result.base_marker;
    let motion = match o.motion {
        gnss::ppk::Motion::Kinematic => "kinematic",
        gnss::ppk::Motion::Static => "static",
    };
    let d = rover.header.antenna_delta;
    let point = match o.refer {
        gnss::ppk::Reference::Arp => "rover antenna reference point (ARP)",
        gnss::ppk::Reference::Marker => "rover marker (ARP minus the antenna delta)",
    };
    let header = vec![
        format!(
            "program   : ppkat {} (carrier-phase {motion})",
            env!("CARGO_PKG_VERSION")
        ),
        format!("inp file  : {}", job.rover.display()),
        format!("inp file  : {}", job.base.display()),
        format!(
            "pos mode  : {motion}, filter {:?}, ambiguities {:?}, ratio {:.1}",
            if o.motion == gnss::ppk::Motion::Static {
                gnss::ppk::FilterMode::Forward
            } else {
                o.filter
            },
            o.ar,
            o.ratio_threshold
        ),
        format!(
            "positions : {point}; rover ANTENNA: DELTA H/E/N {:.4} {:.4} {:.4} m",
            d.up, d.east, d.north
        ),
        format!("elev mask : {:.1} deg", o.elev_mask.to_degrees()),
        format!(
            "systems   : {}",
            o.systems.iter().map(|s| s.letter()).collect::<String>()
        ),
        gnss::solution::ref_pos_line(&b, job.format.pos_format()),
        "ref point : base marker, in the coordinates of the body (RTKLIB's layout)".into(),
        base_line.unwrap_or_else(|| "base from : given position or the base header".into()),
        format!(
            "epochs    : {} rover, {} solved, {} fixed",
            result.rover_epochs,
            result.trajectory.epochs.len(),
            result.fixed()
        ),
    ];
    let records = result.trajectory.records();
    crate::vector::write(&job.out, &header, &records, job.format)?;
    let mut summary = None;
    if let Some(st) = &result.static_solution {
        let path = summary_path(&job.out);
        let text = crate::survey::json(st, o.refer, &result.base_marker);
        gnss::solution::write_atomic(&path, |w| w.write_all(text.as_bytes()))?;
        summary = Some(path);
    }
    let mut report = PpkReport {
        result,
        summary,
        report: None,
        refer: o.refer,
        read_seconds,
        process_seconds,
        out: job.out.clone(),
        warnings,
        seconds: t0.elapsed().as_secs_f64(),
    };
    if let Some(path) = &job.report {
        let events: Vec<Epoch> = rover
            .events
            .iter()
            .filter(|e| e.flag == 5)
            .filter_map(|e| e.time)
            .collect();
        report.report = Some(path.clone());
        let page = crate::ppk_report::html(&report, &header, &events);
        gnss::solution::write_atomic(path, |w| w.write_all(page.as_bytes()))?;
    }
    Ok(report)
}

impl fmt::Display for PpkReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.result;
        let solved = r.trajectory.epochs.len();
        writeln!(
            f,
            "ppk: {} rover epochs, {} solved, {} fixed ({:.1} % of solved) in {:.2} s → {}",
            r.rover_epochs,
            solved,
            r.fixed(),
            100.0 * r.fixed() as f64 / solved.max(1) as f64,
            self.seconds,
            self.out.display()
        )?;
        let m = &r.models;
        let estimated: Vec<&str> = [
            (m.iono, "slant ionosphere per satellite"),
            (m.tropo, "rover zenith wet delay"),
        ]
        .iter()
        .filter(|(on, _)| *on)
        .map(|(_, what)| *what)
        .collect();
        writeln!(
            f,
            "  longest baseline {:.1} km; estimated: {}",
            m.longest_baseline / 1000.0,
            if estimated.is_empty() {
                "no atmospheric delays (a-priori models only)".to_string()
            } else {
                estimated.join(", ")
            }
        )?;
        let mut reasons: std::collections::BTreeMap<&str, (usize, Epoch)> = Default::default();
        for (t, why) in &r.unsolved {
            reasons.entry(why.as_str()).or_insert((0, *t)).0 += 1;
        }
        for (why, (n, first)) in reasons {
            writeln!(
                f,
                "  {n} epochs unsolved: {why} (first at {})",
                format_ymdhms(first)
            )?;
        }
        for (name, s) in [("forward", &r.forward), ("backward", &r.backward)] {
            let Some(s) = s else { continue };
            let slips: Vec<String> = s.slips.iter().map(|(c, n)| format!("{c:?} {n}")).collect();
            let gated: Vec<String> = s
                .rejected
                .iter()
                .map(|(c, n)| format!("{c:?} {n}"))
                .collect();
            writeln!(
                f,
                "  {name}: ambiguity resets {} [{}], post-fit outliers {}, innovations rejected {} [{}], satellite-epochs below mask {}, without orbit {}",
                s.slips.values().sum::<usize>(),
                slips.join(", "),
                s.outlier_resets,
                s.rejected_innovations(),
                gated.join(", "),
                s.below_mask,
                s.no_orbit
            )?;
        }
        if let Some(st) = &r.static_solution {
            for l in crate::survey::lines(st, self.refer) {
                writeln!(f, "  {l}")?;
            }
            if let Some(p) = &self.summary {
                writeln!(f, "  summary → {}", p.display())?;
            }
        }
        if let Some(p) = &self.report {
            writeln!(f, "  report → {}", p.display())?;
        }
        for w in self.warnings.iter().take(20) {
            writeln!(f, "  warning: {w}")?;
        }
        Ok(())
    }
}

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
    if let Some(dir) = &job.photos {
        let list = crate::exposure::photos::list(dir)?;
        match crate::exposure::photos::check(&list, &result.stations) {
            Ok(()) => {
                for (s, p) in result.stations.iter_mut().zip(&list) {
                    s.id = p.name.clone();
                }
                if let Some(g) = &job.geotag {
                    geotagged = crate::exposure::photos::geotag(&list, &result.stations, g)?.len();
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
    export::write(&job.out, &result.stations, job.format, job.projection)?;
    Ok(ExposureReport {
        result,
        events: n,
        clock_correction,
        out: job.out.clone(),
        photos,
        geotagged,
    })
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
        for w in &r.warnings {
            writeln!(f, "  warning: {w}")?;
        }
        for n in &r.notes {
            writeln!(f, "  note: {n}")?;
        }
        Ok(())
    }
}
