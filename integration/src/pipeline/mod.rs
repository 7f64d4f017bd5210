//! Whole-stage runs used by the command line: read inputs, check they fit together, process,
//! write outputs atomically, and return a report of what was done and what was rejected.
//!
//! Enters: a job naming the input files and holding the library options ([`SppJob`],
//! [`PpkJob`], [`ExposureJob`]). Leaves: the output file (`.pos` or an exposure export) and a
//! report ([`SppReport`], [`PpkReport`], [`ExposureReport`]) whose `Display` is what `ppkat`
//! prints. Uses `gnss` (RINEX, orbits, SPP, PPK, `.pos`) and [`crate::exposure`]; prints
//! nothing itself.

use crate::observations::{nav_sources, read_observations};
use crate::orbits::{broadcast_warning, check_glonass_channels};
pub use crate::orbits::{check_overlap, load_orbits};
use gnss::error::{Error, Result};
use gnss::obs::ObsFormat;
use gnss::raw::TimeHint;
use gnss::rinex::ObsFile;
use gnss::solution::{PosRecord, Quality};
use gnss::spp::{SppOptions, SppRun};
use gnss::time::format_ymdhms;
use hifitime::Epoch;
use std::fmt;
use std::path::PathBuf;

mod exposures;
mod swap;
pub use crate::ppk_summary::PpkReport;
use common::atomic::side_path;
pub use exposures::{exposures, EventSource, ExposureJob, ExposureReport};

/// Inputs of a single-point run.
#[derive(Clone, Debug)]
pub struct SppJob {
    /// Observation file: RINEX or raw receiver log.
    pub obs: PathBuf,
    /// Its format (`None`: told from the content).
    pub obs_format: Option<ObsFormat>,
    /// When an RTCM 3 log was recorded (its week), if the user said.
    pub time_hint: Option<TimeHint>,
    /// Navigation files (optional with SP3 files, or with a raw log carrying ephemerides).
    pub nav: Vec<PathBuf>,
    /// Precise orbits (SP3; any number, merged), used instead of the broadcast ones when given.
    pub sp3: Vec<PathBuf>,
    /// RINEX clock files (any number, merged), used instead of the SP3 clocks when given.
    pub clk: Vec<PathBuf>,
    /// Processing options.
    pub options: SppOptions,
    /// Layout of the trajectory written (`.pos` llh/xyz, KML, GeoJSON, GPX).
    pub format: crate::vector::TrajectoryFormat,
    /// Heights written: ellipsoidal or above a geoid.
    pub heights: crate::height::Heights,
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
    /// What the run took from raw logs themselves (their ephemerides, their GPS week), for
    /// standard error.
    pub notes: Vec<String>,
    /// The `.pos` written.
    pub out: PathBuf,
}

/// What reading an observation file noticed, each as `path:line: what`.
fn file_warnings(f: &ObsFile) -> impl Iterator<Item = String> + '_ {
    f.warnings
        .iter()
        .map(|w| format!("{}:{}: {}", f.path.display(), w.line, w.what))
}

/// The error of a run that solved no epoch: how many epochs, why (the reasons counted, most
/// frequent first), and what to check. No `.pos` is written then: a header alone is no result.
fn nothing_solved(what: &str, epochs: usize, reasons: Vec<String>, details: &[String]) -> Error {
    let mut count: std::collections::BTreeMap<String, usize> = Default::default();
    for r in reasons {
        *count.entry(r).or_default() += 1;
    }
    let mut count: Vec<(String, usize)> = count.into_iter().collect();
    count.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    let why: Vec<String> = count
        .iter()
        .take(3)
        .map(|(r, n)| format!("{n} × {r}"))
        .chain(details.iter().take(3).cloned())
        .collect();
    Error::NoData(format!(
        "{what}: none of the {epochs} epochs could be solved, no output written ({}); check that \
         --systems names systems the files contain, that --elev-mask is not too high, and \
         that the navigation or orbit files are complete and cover the observations",
        if why.is_empty() {
            "no epoch to solve".to_string()
        } else {
            why.join("; ")
        }
    ))
}

/// Run single-point positioning over a file and write the `.pos` output; `progress` shows
/// the reading and counts the epochs solved. `Err` when no epoch is solved.
pub fn spp(job: &SppJob, progress: &dyn common::progress::Progress) -> Result<SppReport> {
    common::atomic::clean_stale(&job.out);
    progress.set_len("reading the observations", 0);
    let input = read_observations(&job.obs, job.obs_format, job.time_hint)?;
    let log_nav = input.nav.as_ref();
    let notes = log_notes(&[&input], &job.nav);
    let (orbits, mut warnings) = load_orbits(&job.nav, log_nav, &job.sp3, &job.clk)?;
    warnings.extend(broadcast_warning(&job.nav, log_nav, &orbits));
    let obs = input.obs;
    check_overlap(&obs, &orbits, &nav_sources(&job.nav, log_nav))?;
    warnings.extend(input.warnings);
    warnings.extend(check_glonass_channels(&obs, &orbits, &job.options.systems)?);
    warnings.extend(file_warnings(&obs));
    let run =
        gnss::spp::run_with_progress(&obs.epochs, &obs.header, &orbits, &job.options, progress);
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
    if records.is_empty() {
        let rejected: Vec<String> = run
            .rejections
            .iter()
            .map(|(r, n)| format!("satellite-epochs rejected, {r}: {n}"))
            .collect();
        let failures = run
            .failures
            .iter()
            .map(|(_, f)| f.kind().to_string())
            .collect();
        return Err(nothing_solved(
            &format!("single point on {}", job.obs.display()),
            obs.epochs.len(),
            failures,
            &rejected,
        ));
    }
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
    crate::vector::write(&job.out, &header, &records, job.format, &job.heights)?;
    Ok(SppReport {
        epochs: obs.epochs.len(),
        solved: records.len(),
        run,
        warnings,
        notes,
        out: job.out.clone(),
    })
}

/// What a run takes from its raw logs themselves: their GPS week and, without navigation
/// files, their ephemerides.
fn log_notes(inputs: &[&crate::observations::RunObs], nav: &[PathBuf]) -> Vec<String> {
    let mut notes: Vec<String> = inputs
        .iter()
        .flat_map(|i| {
            i.warnings
                .iter()
                .filter(|w| w.contains("GPS week of"))
                .cloned()
        })
        .collect();
    if nav.is_empty() {
        if let Some(n) = inputs.iter().find_map(|i| i.nav.as_ref()) {
            notes.push(format!(
                "no --nav given: using the {} ephemerides of {} itself",
                n.records.len(),
                n.path.display()
            ));
        }
    }
    notes
}

/// The `.pos` header line and the note of a base position taken from the station an RTCM
/// log announces (1005/1006), when the user gave none; `None` otherwise.
fn base_from_station(job: &PpkJob, base: &crate::observations::RunObs) -> Option<(String, String)> {
    if job.base_from_ppp || !matches!(job.base_position, gnss::ppk::BasePosition::Header) {
        return None;
    }
    let st = base.station.as_ref()?;
    let [x, y, z] = st.arp?;
    let m = base.obs.header.approx_position?;
    let h = st.height.unwrap_or(0.0);
    let what = format!(
        "the station position of {} (RTCM {}): ARP {x:.4} {y:.4} {z:.4}, antenna height \
         {h:.4} m, marker {:.4} {:.4} {:.4}",
        job.base.display(),
        if st.height.is_some() { 1006 } else { 1005 },
        m.0.x,
        m.0.y,
        m.0.z
    );
    Some((
        format!("base from : {what}"),
        format!("no --base-pos/--base-llh given: the base is {what}"),
    ))
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
    /// Rover observation file: RINEX or raw receiver log.
    pub rover: PathBuf,
    /// Base observation file: RINEX or raw receiver log.
    pub base: PathBuf,
    /// Format of both (`None`: each told from its content).
    pub obs_format: Option<ObsFormat>,
    /// When RTCM 3 logs were recorded (their week), if the user said.
    pub time_hint: Option<TimeHint>,
    /// Navigation files (optional with SP3 files, or with raw logs carrying ephemerides:
    /// the rover's are used, else the base's).
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
    /// Heights written: ellipsoidal or above a geoid.
    pub heights: crate::height::Heights,
    /// Output `.pos`.
    pub out: PathBuf,
    /// The quality report to write (HTML), if any.
    pub report: Option<PathBuf>,
}

/// The `.pos` header lines of a PPK run (RTKLIB's layout, with ppkat's own lines):
/// program, inputs, mode, the point the positions describe, mask, systems, the base and how
/// it was found (`base_line`), the epoch counts and GLONASS's ambiguities.
fn pos_header(
    job: &PpkJob,
    result: &gnss::ppk::PpkResult,
    rover: &ObsFile,
    base_line: Option<String>,
) -> Vec<String> {
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
    let mut header = vec![
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
    if result.models.glonass_float {
        header.push(
            "glonass   : ambiguities kept float (the receivers' inter-channel phase biases are not calibrated); inter-channel code bias estimated"
                .into(),
        );
    }
    header
}

/// Run PPK and write the `.pos` output; `progress` counts the epochs of each pass.
/// `Err` when no epoch is solved.
pub fn ppk(job: &PpkJob, progress: &dyn common::progress::Progress) -> Result<PpkReport> {
    let t0 = std::time::Instant::now();
    common::atomic::clean_stale(&job.out);
    progress.set_len("reading rover and base", 0);
    let mut rover_in = read_observations(&job.rover, job.obs_format, job.time_hint)?;
    let mut base_in = read_observations(&job.base, job.obs_format, job.time_hint)?;
    let (rover, base) = (&rover_in.obs, &base_in.obs);
    gnss::ppk::require_phase(rover, "rover")?;
    gnss::ppk::require_phase(base, "base")?;
    let log_nav = rover_in.nav.as_ref().or(base_in.nav.as_ref());
    let (orbits, mut warnings) = load_orbits(&job.nav, log_nav, &job.sp3, &job.clk)?;
    warnings.extend(broadcast_warning(&job.nav, log_nav, &orbits));
    check_overlap(rover, &orbits, &nav_sources(&job.nav, log_nav))?;
    warnings.extend(rover_in.warnings.iter().chain(&base_in.warnings).cloned());
    warnings.extend(check_glonass_channels(
        rover,
        &orbits,
        &job.options.systems,
    )?);
    warnings.extend(file_warnings(rover).chain(file_warnings(base)));
    let mut notes = log_notes(&[&rover_in, &base_in], &job.nav);
    let mut base_position = job.base_position;
    let mut base_line = None;
    if let Some((line, note)) = base_from_station(job, &base_in) {
        base_line = Some(line);
        notes.push(note);
    }
    if job.base_from_ppp {
        if orbits.precise.is_none() {
            return Err(Error::NoData(
                "--base-from-ppp needs precise orbits (--sp3)".into(),
            ));
        }
        let (p, line, w) = crate::ppp::base_from_ppp(
            base,
            &orbits,
            job.options.antex.as_deref(),
            &job.options.systems,
        )?;
        base_position = gnss::ppk::BasePosition::Given(p);
        base_line = Some(line);
        warnings.extend(w);
    }
    let stated = match base_position {
        gnss::ppk::BasePosition::Given(p) => Some(p),
        gnss::ppk::BasePosition::Header => base.header.approx_position,
    };
    progress.set_len("checking which receiver moves (single point)", 0);
    swap::check(
        (&job.rover, rover),
        (&job.base, base),
        stated,
        &orbits,
        &job.options.systems,
    )?;
    let read_seconds = t0.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    // The observation records are released once the passes' inputs are drawn from them.
    let result = gnss::ppk::process_releasing(
        &mut rover_in.obs,
        &mut base_in.obs,
        base_position,
        &orbits,
        &job.options,
        progress,
    )?;
    let rover = &rover_in.obs;
    let process_seconds = t1.elapsed().as_secs_f64();
    if result.trajectory.epochs.is_empty() {
        let reasons = result.unsolved.iter().map(|(_, w)| w.clone()).collect();
        return Err(nothing_solved(
            &format!("ppk of {}", job.rover.display()),
            result.rover_epochs,
            reasons,
            &result.warnings,
        ));
    }
    warnings.extend(result.warnings.iter().cloned());
    let o = &job.options;
    let header = pos_header(job, &result, rover, base_line);
    let records = result.trajectory.records();
    crate::vector::write(&job.out, &header, &records, job.format, &job.heights)?;
    let mut summary = None;
    if let Some(st) = &result.static_solution {
        let path = side_path(&job.out, ".json");
        let text = crate::survey::json(st, o.refer, &result.base_marker, &job.heights)?;
        common::atomic::write_atomic(&path, |w| w.write_all(text.as_bytes()))?;
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
        notes,
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
        common::atomic::write_atomic(path, |w| w.write_all(page.as_bytes()))?;
    }
    Ok(report)
}
