//! `ppkat ppp`: read the observation file, precise orbits and clocks and ANTEX files, find a
//! start position by single-point positioning, run [`gnss::ppp::process`], write the `.pos`
//! (and in static mode `OUT.pos.json` with the final coordinate), and report.
//!
//! Enters: a [`PppJob`]. Leaves: the files and a [`PppReport`] whose `Display` is what the
//! command prints.

use crate::orbits::{check_overlap, load_orbits};
pub use crate::ppp_report::PppReport;
use crate::ppp_report::{decimal_year, Untimed};
use crate::survey::{enu_sigmas, refer_name};
use common::atomic::side_path;
use common::atomic::write_atomic;
use gnss::error::{Error, Result};
use gnss::frame::{enu_rotation, Ecef};
use gnss::model::antex::Antex;
use gnss::orbit::{ClockSource, Orbits};
use gnss::ppk::{Motion, Reference};
use gnss::ppp::PppOptions;
use gnss::rinex::ObsFile;
use gnss::solution::{PosRecord, Quality};
use gnss::spp::{solve_epoch, SppOptions};
use gnss::time::format_ymdhms;
use serde_json::json;
use std::path::PathBuf;

/// Inputs of a PPP run.
#[derive(Clone, Debug)]
pub struct PppJob {
    /// Observation file.
    pub obs: PathBuf,
    /// SP3 files (merged).
    pub sp3: Vec<PathBuf>,
    /// RINEX clock files (merged), preferred to the SP3 clocks.
    pub clk: Vec<PathBuf>,
    /// Navigation files (optional: GLONASS channels only).
    pub nav: Vec<PathBuf>,
    /// ANTEX files: the model first (see [`PppOptions::antex`]).
    pub antex: Vec<PathBuf>,
    /// Options (the ANTEX files are filled in from `antex`).
    pub options: PppOptions,
    /// Layout of the trajectory file (`.pos` in llh or xyz, KML, GeoJSON, GPX).
    pub format: crate::vector::TrajectoryFormat,
    /// Output `.pos`.
    pub out: PathBuf,
    /// The observation file's format (`None`: told from the content).
    pub obs_format: Option<gnss::obs::ObsFormat>,
    /// When an RTCM 3 log was recorded (its week), if given.
    pub time_hint: Option<gnss::raw::TimeHint>,
    /// Heights written (the trajectory file and, with an orthometric model, the static
    /// summary's orthometric height beside the ellipsoidal one).
    pub heights: crate::height::Heights,
}

/// Run PPP as the job says.
pub fn ppp(job: &PppJob, progress: &dyn common::progress::Progress) -> Result<PppReport> {
    let t0 = std::time::Instant::now();
    for ext in ["", ".json", ".ztd.csv", ".html"] {
        common::atomic::clean_stale(&side_path(&job.out, ext));
    }
    // RINEX or a raw receiver log, told from the content unless the job says.
    let input = crate::observations::read_observations(&job.obs, job.obs_format, job.time_hint)?;
    let obs = input.obs;
    gnss::ppk::require_phase(&obs, "observation")?;
    let log_nav = input.nav.as_ref();
    let (orbits, mut warnings) = load_orbits(&job.nav, log_nav, &job.sp3, &job.clk)?;
    warnings.extend(input.warnings);
    check_overlap(
        &obs,
        &orbits,
        &crate::observations::nav_sources(&job.nav, log_nav),
    )?;
    let mut options = job.options.clone();
    options.antex = job
        .antex
        .iter()
        .map(|p| Antex::read(p))
        .collect::<Result<_>>()?;
    if let Some(p) = &orbits.precise {
        if p.clock_source == ClockSource::Sp3 {
            warnings.push(clock_warning(p.clock_interval()));
        }
    }
    let start = start_position(&obs, &orbits)?;
    let mut result = gnss::ppp::process(&obs, &orbits, &options, start, progress)?;
    result.warnings.splice(0..0, warnings);
    if result.epochs.is_empty() {
        return Err(Error::NoData(format!(
            "{}: no epoch solved (fewer than 4 satellites with two frequencies, precise orbits and clocks above the mask)",
            job.obs.display()
        )));
    }
    let frame = orbits
        .precise
        .as_ref()
        .map(|p| p.frame.clone())
        .unwrap_or_default();
    let last = (options.motion == Motion::Static)
        .then(|| result.epochs.last().map(|e| (e.pos, e.cov)))
        .flatten();
    let report = PppReport {
        result,
        last,
        refer: options.refer,
        motion: options.motion,
        out: job.out.clone(),
        summary: None,
        html: None,
        ztd: None,
        frame,
        seconds: 0.0,
        header_position: header_point(&obs, options.refer),
    };
    crate::vector::write(
        &job.out,
        &pos_header(&report, job),
        &pos_records(&report),
        job.format,
        &job.heights,
    )?;
    let mut report = report;
    if let Some(json) = static_json(&report, &job.heights)? {
        let path = side_path(&job.out, ".json");
        write_atomic(&path, |w| w.write_all(json.as_bytes()))?;
        report.summary = Some(path);
    }
    report.seconds = t0.elapsed().as_secs_f64();
    let ztd_path = side_path(&job.out, ".ztd.csv");
    write_atomic(&ztd_path, |w| {
        writeln!(w, "gpst,zenith_total_delay_m,sigma_m,satellites")?;
        for e in &report.result.epochs {
            writeln!(
                w,
                "{},{:.4},{:.4},{}",
                format_ymdhms(e.time),
                e.ztd.0,
                e.ztd.1,
                e.nsat
            )?;
        }
        Ok(())
    })?;
    report.ztd = Some(ztd_path);
    let html_path = side_path(&job.out, ".html");
    let page = crate::ppp_report::html(
        &report,
        &job.obs.display().to_string(),
        &Untimed(&report).to_string(),
    );
    write_atomic(&html_path, |w| w.write_all(page.as_bytes()))?;
    report.html = Some(html_path);
    Ok(report)
}

/// The base marker from static PPP on the base file (for `ppk --base-from-ppp`): position,
/// the header line that states it with its σ, and the run's warnings.
pub fn base_from_ppp(
    base: &ObsFile,
    orbits: &Orbits,
    antex: Option<&Antex>,
    systems: &[gnss::sv::Constellation],
) -> Result<(Ecef, String, Vec<String>)> {
    use gnss::sv::Constellation;
    let systems: Vec<Constellation> = systems
        .iter()
        .copied()
        .filter(|s| matches!(s, Constellation::Gps | Constellation::Galileo))
        .collect();
    let options = PppOptions {
        systems,
        antex: antex.cloned().into_iter().collect(),
        ..PppOptions::default()
    };
    let start = start_position(base, orbits)?;
    let r = gnss::ppp::process(base, orbits, &options, start, &common::progress::NoProgress)?;
    let Some(last) = r.epochs.last() else {
        return Err(Error::input(
            &base.path,
            "PPP on the base file solved no epoch: give the base position (--base-pos or --base-llh)",
        ));
    };
    let sd = enu_sigmas(&last.pos, &last.cov);
    let frame = orbits
        .precise
        .as_ref()
        .map(|p| p.frame.clone())
        .unwrap_or_default();
    let line = format!(
        "base from : static PPP on the base file, {} epochs, σ E/N/U {:.1}/{:.1}/{:.1} mm, frame {frame}",
        r.epochs.len(),
        sd[0] * 1e3,
        sd[1] * 1e3,
        sd[2] * 1e3
    );
    let warnings = r
        .warnings
        .iter()
        .map(|w| format!("base PPP: {w}"))
        .collect();
    Ok((last.pos, line, warnings))
}

/// The warning about clocks interpolated from SP3 records.
fn clock_warning(interval: f64) -> String {
    format!(
        "satellite clocks from the SP3 file ({interval:.0} s records, interpolated linearly): expect centimetres of clock error per epoch; 30-s clock files (--clk) do better"
    )
}

/// A start position: the first epoch a single-point solution passes its checks, else the
/// header's approximate position.
fn start_position(obs: &ObsFile, orbits: &Orbits) -> Result<Ecef> {
    let opts = SppOptions::default();
    let prior = obs.header.approx_position;
    for e in obs.epochs.iter().take(50) {
        if let Ok(s) = solve_epoch(e, &obs.header, orbits, &opts, prior) {
            return Ok(s.pos);
        }
    }
    prior.ok_or_else(|| {
        Error::input(
            &obs.path,
            "no single-point solution in the first 50 epochs and no approximate position in the header: cannot start PPP",
        )
    })
}

/// The header's approximate position (of the marker) at the point asked for.
fn header_point(obs: &ObsFile, refer: Reference) -> Option<Ecef> {
    let p = obs.header.approx_position?;
    let d = obs.header.antenna_delta;
    Some(match refer {
        Reference::Marker => p,
        Reference::Arp => {
            let r = enu_rotation(&p.to_geodetic());
            Ecef(p.0 + r.transpose() * nalgebra::Vector3::new(d.east, d.north, d.up))
        }
    })
}

/// The `.pos` header lines of a run.
fn pos_header(this: &PppReport, job: &PppJob) -> Vec<String> {
    let motion = match this.motion {
        Motion::Static => "static",
        Motion::Kinematic => "kinematic",
    };
    vec![
        format!(
            "program   : ppkat {} (PPP {motion})",
            env!("CARGO_PKG_VERSION")
        ),
        format!("inp file  : {}", job.obs.display()),
        format!("positions : {} (Q=6: PPP float)", refer_name(this.refer)),
        format!(
            "frame     : {} (the orbits' frame, at the epoch of the data)",
            this.frame
        ),
        format!(
            "epochs    : {} read, {} solved",
            this.result.input_epochs,
            this.result.epochs.len()
        ),
    ]
}

/// The `.pos` records of a run.
fn pos_records(this: &PppReport) -> Vec<PosRecord> {
    this.result
        .epochs
        .iter()
        .map(|e| PosRecord {
            time: e.time,
            pos: e.pos,
            quality: Quality::Ppp,
            nsat: e.nsat,
            cov: e.cov,
            age: 0.0,
            ratio: 0.0,
        })
        .collect()
}

/// The JSON summary of a static run.
fn static_json(this: &PppReport, heights: &crate::height::Heights) -> Result<Option<String>> {
    let (Some((pos, cov)), Some(first), Some(lastep)) = (
        this.last,
        this.result.epochs.first(),
        this.result.epochs.last(),
    ) else {
        return Ok(None);
    };
    let g = pos.to_geodetic();
    let sd = enu_sigmas(&pos, &cov);
    let mut v = json!({
        "program": format!("ppkat {}", env!("CARGO_PKG_VERSION")),
        "mode": "ppp-static",
        "refers_to": refer_name(this.refer),
        "frame": this.frame,
        "epoch_decimal_year": decimal_year(first.time, lastep.time),
        "position": {
            "ecef_m": [pos.0.x, pos.0.y, pos.0.z],
            "latitude_deg": g.lat.to_degrees(),
            "longitude_deg": g.lon.to_degrees(),
            "ellipsoidal_height_m": g.h,
        },
        "sigma_m": { "east": sd[0], "north": sd[1], "up": sd[2] },
        "first_epoch_gpst": format_ymdhms(first.time),
        "last_epoch_gpst": format_ymdhms(lastep.time),
        "epochs": this.result.epochs.len(),
        "zenith_total_delay_m": lastep.ztd.0,
        "residual_rms_m": { "phase": this.result.residual_rms(0), "code": this.result.residual_rms(1) },
        "rejected": this.result.rejected.iter().map(|(k, n)| (k.describe().to_string(), *n)).collect::<std::collections::BTreeMap<_, _>>(),
        "ambiguity_restarts": this.result.slips,
    });
    crate::survey::add_orthometric(&mut v["position"], &g, heights)?;
    Ok(serde_json::to_string_pretty(&v).ok().map(|s| s + "\n"))
}
