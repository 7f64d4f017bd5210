//! One module per subcommand. Each holds the subcommand's clap arguments (with their help
//! texts) and a `run` that converts them into the library's options, calls one library
//! function and prints its report. Argument conversions shared by several commands live here.

pub mod adjust;
pub mod bal;
pub mod batch;
pub mod batch_cluster;
pub mod batch_flight;
pub mod bench;
pub mod config;
pub mod convert;
pub mod demo;
pub mod exposures;
pub mod import;
pub mod info;
pub mod ins;
pub mod leverarm;
pub mod ppk;
pub mod ppp;
pub mod progress;
pub mod simulate;
pub mod spp;
pub mod tiepoints;

use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use integration::gnss::obs::ObsFormat;
use integration::gnss::raw::{RawFormat, TimeHint};
use integration::gnss::solution::PosFormat;
use integration::gnss::sv::Constellation;
use integration::vector::TrajectoryFormat;

static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// `--quiet`: no progress bars and no notes on standard error (warnings about skipped inputs
/// and errors are still printed).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

/// Whether `--quiet` was given.
pub fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

/// A non-essential remark on standard error (`note: …`), left out with `--quiet`.
pub fn note(text: &str) {
    if !quiet() {
        eprintln!("note: {text}");
    }
}

/// A run that finished but left inputs out: `ppkat` exits with code 3 and prints this on
/// standard error (the count, then each input named with the reason).
#[derive(Debug)]
pub struct Incomplete(pub Vec<String>);

impl std::fmt::Display for Incomplete {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "finished, but {} input(s) skipped:", self.0.len())?;
        for s in self.0.iter().take(50) {
            write!(f, "\n  {s}")?;
        }
        if self.0.len() > 50 {
            write!(f, "\n  … {} more (see the report above)", self.0.len() - 50)?;
        }
        Ok(())
    }
}

impl std::error::Error for Incomplete {}

/// `Ok` when nothing was skipped, else the [`Incomplete`] error that makes the exit code 3.
pub fn complete(skipped: Vec<String>) -> Result<()> {
    if skipped.is_empty() {
        Ok(())
    } else {
        Err(Incomplete(skipped).into())
    }
}

/// The format of an observation input.
#[derive(Clone, Copy, ValueEnum)]
pub enum ObsFormatArg {
    /// Tell it from the content: RINEX (its first line, or gzip) or a raw receiver log (UBX,
    /// RTCM 3 or SBF frames with valid checksums)
    Auto,
    /// RINEX 2/3/4 observations (plain, gzip, Hatanaka)
    Rinex,
    /// u-blox UBX log (RXM-RAWX measurements, RXM-SFRBX ephemerides, TIM-TM2 time marks)
    Ubx,
    /// RTCM 3 log (MSM4/5/6/7 observations), e.g. DJI PPKRAW.bin
    Rtcm3,
    /// Septentrio SBF log (MeasEpoch measurements, GPS/GAL/BDS/GLO nav blocks, ExtEvent)
    Sbf,
}

impl From<ObsFormatArg> for Option<ObsFormat> {
    fn from(f: ObsFormatArg) -> Option<ObsFormat> {
        match f {
            ObsFormatArg::Auto => None,
            ObsFormatArg::Rinex => Some(ObsFormat::Rinex),
            ObsFormatArg::Ubx => Some(ObsFormat::Raw(RawFormat::Ubx)),
            ObsFormatArg::Rtcm3 => Some(ObsFormat::Raw(RawFormat::Rtcm3)),
            ObsFormatArg::Sbf => Some(ObsFormat::Raw(RawFormat::Sbf)),
        }
    }
}

/// When an RTCM 3 log was recorded: its observations carry the time of week only, and its
/// GPS ephemerides the week modulo 1024.
#[derive(clap::Args, Clone, Copy)]
pub struct TimeHintArgs {
    /// Year an RTCM 3 log was recorded: picks the 1024-week cycle of its GPS and QZSS
    /// ephemeris weeks when no Galileo or BeiDou ephemeris dates the log (without it: the
    /// cycle from 2019-04-07 to 2038-11-20). Not enough when the log carries no ephemeris of
    /// the observations' time: then give --date-hint.
    #[arg(long, value_name = "YYYY", value_parser = clap::value_parser!(i32).range(1980..=2200), conflicts_with = "date_hint")]
    year_hint: Option<i32>,
    /// Day (GPST) an RTCM 3 log begins, within 3 days: places its observations in their GPS
    /// week. Needed when the log carries no ephemeris of the observations' time (1019, 1042,
    /// 1044, 1045, 1046). It wins over a week that only GPS/QZSS ephemerides (weeks modulo
    /// 1024) point at, with a warning when they differ; a contradiction with Galileo or
    /// BeiDou ephemerides of the observations' time is an error naming both weeks.
    #[arg(long, value_name = "YYYY-MM-DD", value_parser = date_hint)]
    date_hint: Option<TimeHint>,
}

impl TimeHintArgs {
    /// The hint given, if any.
    pub fn hint(self) -> Option<TimeHint> {
        self.date_hint.or(self.year_hint.map(TimeHint::Year))
    }
}

/// A `--date-hint` value: a calendar date `YYYY-MM-DD`.
fn date_hint(s: &str) -> std::result::Result<TimeHint, String> {
    match TimeHint::parse(s)? {
        d @ TimeHint::Date(..) => Ok(d),
        TimeHint::Year(_) => Err(format!(
            "'{s}' is a year: give the day as YYYY-MM-DD (or use --year-hint)"
        )),
    }
}

/// Layout of a trajectory file (`spp`, `ppk`).
#[derive(Clone, Copy, ValueEnum)]
pub enum TrajectoryFormatArg {
    /// RTKLIB .pos: latitude, longitude (degrees), ellipsoidal height (m)
    Llh,
    /// RTKLIB .pos: Earth-centred, Earth-fixed X, Y, Z (m)
    Xyz,
    /// KML for Google Earth: the track and a placemark per epoch coloured by Q
    Kml,
    /// GeoJSON for QGIS: the track and a point per epoch with time, Q, σ
    Geojson,
    /// GPX 1.1: one track, a track point per epoch with time, Q, σ
    Gpx,
}

impl From<TrajectoryFormatArg> for TrajectoryFormat {
    fn from(f: TrajectoryFormatArg) -> TrajectoryFormat {
        match f {
            TrajectoryFormatArg::Llh => TrajectoryFormat::Pos(PosFormat::Llh),
            TrajectoryFormatArg::Xyz => TrajectoryFormat::Pos(PosFormat::Xyz),
            TrajectoryFormatArg::Kml => TrajectoryFormat::Kml,
            TrajectoryFormatArg::Geojson => TrajectoryFormat::GeoJson,
            TrajectoryFormatArg::Gpx => TrajectoryFormat::Gpx,
        }
    }
}

/// The `--height` value checked for its form (bad usage, exit code 2): `ellipsoidal`, `egm96`,
/// `egm2008` or `geoid:FILE`. The grid is found and read by [`heights`].
pub fn height_arg(s: &str) -> std::result::Result<String, String> {
    match s {
        "ellipsoidal" | "egm96" | "egm2008" => Ok(s.into()),
        g if g.starts_with("geoid:") && g.len() > 6 => Ok(s.into()),
        _ => Err(format!(
            "use ellipsoidal, egm96, egm2008 or geoid:FILE. {}",
            integration::height::EGM2008_AS_FILE
        )),
    }
}

/// The heights of a checked `--height` value, its grid found and read (a grid that cannot be
/// found or read is a failure, exit code 1: the reader's error already names the file).
pub fn heights(s: &str) -> Result<integration::height::Heights> {
    use integration::height::{Heights, HeightsError};
    let h = Heights::parse(s).map_err(|e| match e {
        HeightsError::File(e) => anyhow::anyhow!("--height: {e}"),
        HeightsError::Usage(m) | HeightsError::NotFound(m) => anyhow::anyhow!("{m}"),
    })?;
    if let integration::height::Heights::Grid(g) = &h {
        if let Some(m) = g.model() {
            note(&format!("--height {s}: {m} from {}", g.path().display()));
        }
    }
    Ok(h)
}

/// A flag's number: finite (NaN and infinities are refused as bad usage, exit code 2).
pub fn finite_number(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("'{s}' is not a finite number")),
    }
}

/// Three comma-separated finite numbers, for the flag `what`.
pub fn triple(what: &str, s: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .with_context(|| format!("{what} '{s}': give three numbers separated by commas"))?;
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        bail!("{what} '{s}': give exactly three numbers separated by commas");
    }
    Ok([v[0], v[1], v[2]])
}

/// Two non-negative numbers "A,B", e.g. `--phase-sigma 0.003,0.003`.
pub fn pair(what: &str, s: &str) -> Result<(f64, f64)> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .with_context(|| format!("{what} '{s}': give two numbers separated by a comma"))?;
    if v.len() != 2 || v.iter().any(|x| !x.is_finite() || *x < 0.0) || v[0] + v[1] <= 0.0 {
        bail!("{what} '{s}': give two numbers of at least 0, not both 0, separated by a comma");
    }
    Ok((v[0], v[1]))
}

/// The `--systems` list, e.g. "G,E,C,J,R".
pub fn systems(s: &str) -> Result<Vec<Constellation>> {
    match Constellation::parse_list(s) {
        Some(list) => Ok(list),
        None => bail!("--systems '{s}': use letters among G,E,C,J,R separated by commas"),
    }
}

/// The `--elev-mask` angle, degrees in [0, 90), as radians.
pub fn elev_mask(deg: f64) -> Result<f64> {
    if !(0.0..90.0).contains(&deg) {
        bail!("--elev-mask {deg}: give an angle in degrees between 0 and 90");
    }
    Ok(deg.to_radians())
}
