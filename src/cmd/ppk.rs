//! `ppkat ppk`: carrier-phase kinematic positioning of a rover against a base.

use super::{elev_mask, systems, triple, ObsFormatArg, TimeHintArgs, TrajectoryFormatArg};
use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use integration::gnss::frame::{Ecef, Geodetic};
use integration::gnss::model::antex::Antex;
use integration::gnss::ppk::{
    ArMode, BasePosition, Estimate, FilterMode, Motion, PpkOptions, Reference,
};
use integration::pipeline;
use std::path::PathBuf;
use std::sync::Arc;

/// Carrier-phase kinematic positioning of a rover against a base (double differences,
/// integer ambiguities), written as an RTKLIB-compatible .pos file.
///
/// Reads the rover's and the base's observation files — RINEX or raw u-blox UBX logs, each
/// told apart by content (or by --obs-format) — and the orbits (navigation files, or SP3
/// precise orbits with clocks from the SP3 or RINEX clock files; without either, the
/// ephemerides a UBX log decoded from its navigation subframes), forms double
/// differences of carrier phase and code between rover and base, runs a Kalman filter
/// forward and/or backward in time, resolves the integer ambiguities (LAMBDA, partial
/// resolution by success rate, ratio test) and writes an RTKLIB-compatible `.pos` file in
/// GPS time: Q = 1 fixed, Q = 2 float, with the filter's sigmas, the age of the base epoch
/// and the ratio. Prints what was solved and fixed, and why epochs were not.
///
/// Beyond 10 km of baseline the ionosphere (a slant delay per satellite) and the rover's
/// zenith wet delay are estimated, and the combined solution is the two-filter smoother's:
/// every epoch sees the whole arc of each ambiguity, and a fix must agree with what the data
/// before and after it fix alone.
///
/// The base position comes from --base-pos or --base-llh; without either, the approximate
/// position in the base file's header is used, with a warning (its error goes straight into
/// every rover position). Give negative coordinates with '=', e.g.
/// --base-pos=-3978241.958,3382840.234,3649900.853.
///
/// With --sp3 the satellite positions come from the precise orbits (satellite centre of mass;
/// no satellite antenna offset is applied: in double differences the difference to the
/// broadcast antenna phase centre largely cancels).
#[derive(clap::Args)]
pub struct Args {
    /// Observation file of the moving receiver: RINEX, or a raw receiver log (u-blox UBX, RTCM 3, Septentrio SBF).
    #[arg(long, value_name = "FILE")]
    rover: PathBuf,
    /// Observation file of the base (reference) receiver: RINEX, or a raw receiver log (u-blox UBX, RTCM 3, Septentrio SBF).
    #[arg(long, value_name = "FILE")]
    base: PathBuf,
    /// Format of both observation files; auto tells each from its content (so a UBX rover
    /// and a RINEX base mix).
    #[arg(long, value_enum, value_name = "FORMAT", default_value = "auto")]
    obs_format: ObsFormatArg,
    #[command(flatten)]
    time: TimeHintArgs,
    /// Navigation file (RINEX 2/3/4 broadcast ephemerides); give the flag once per file
    /// (e.g. one per constellation). Required unless --sp3 is given or a UBX log carries
    /// ephemerides (the rover's are used, else the base's); with --sp3 it still
    /// gives the GLONASS frequency channels when the observation headers lack them.
    #[arg(long, value_name = "FILE")]
    nav: Vec<PathBuf>,
    /// Precise orbits and clocks (SP3-a/b/c/d, plain or gzip), used instead of the broadcast
    /// ones; give the flag once per file: the previous, current and next day's files cover
    /// the day's edges (they are merged; an epoch in several files is taken from the file
    /// holding it most centrally). Positions are interpolated (degree 10), clocks linearly;
    /// a satellite outside the files or in a gap of their records is not used.
    #[arg(long, value_name = "FILE")]
    sp3: Vec<PathBuf>,
    /// RINEX clock file (2.x/3.x, plain or gzip) whose satellite clocks (AS records) are used
    /// instead of the SP3 clocks; give the flag once per file. Needs --sp3. Clocks are
    /// interpolated linearly between records, never across a gap of more than 2 record
    /// intervals: a satellite without a clock then is not used (counted as without orbit).
    #[arg(long, value_name = "FILE", requires = "sp3")]
    clk: Vec<PathBuf>,
    /// Base marker position, ECEF metres: X,Y,Z (default: the base file's header position).
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        conflicts_with = "base_llh"
    )]
    base_pos: Option<String>,
    /// Base marker position: latitude,longitude in degrees and ellipsoidal height in metres
    /// (default: the base file's header position).
    #[arg(long, value_name = "LAT,LON,H", allow_hyphen_values = true)]
    base_llh: Option<String>,
    /// Find the base marker first by static precise point positioning on the base file
    /// (as `ppkat ppp` does, GPS and Galileo, with --sp3/--clk and the --antex model),
    /// stated with its σ in the .pos header. Needs --sp3; a few hours of base data give
    /// centimetres.
    #[arg(long, requires = "sp3", conflicts_with_all = ["base_pos", "base_llh"])]
    base_from_ppp: bool,
    /// Which filter passes run.
    #[arg(long, value_enum, default_value = "combined")]
    filter: FilterArg,
    /// Estimate a slant ionospheric delay per satellite (needed beyond about 10 km).
    #[arg(long, value_enum, default_value = "auto")]
    iono: EstimateArg,
    /// Estimate the rover's zenith wet delay on top of the a-priori troposphere (needed
    /// beyond about 10 km or with large height differences).
    #[arg(long, value_enum, default_value = "auto")]
    tropo: EstimateArg,
    /// How the rover moves. `static` estimates one position over the whole span (for a
    /// temporary base from a CORS station): the filter runs forward, each .pos line is the
    /// solution accumulated so far (the last line is the final one), and OUT.pos.json holds
    /// the final position with its σ, epochs, fix state and residual summary.
    #[arg(long, value_enum, default_value = "kinematic")]
    mode: MotionArg,
    /// The point of the rover the positions describe: the antenna reference point, or the
    /// marker below it (ARP minus the rover header's ANTENNA: DELTA H/E/N). Stated in the
    /// .pos header.
    #[arg(long, value_enum, default_value = "arp")]
    refer: ReferArg,
    /// Carrier frequencies used per system: 1 (L1/E1/B1 only), 2 (plus L2/E5b/B2…) or 3.
    /// Single-frequency data fix only when the success rate and ratio are safe: prefer float
    /// to a wrong integer.
    #[arg(long, value_name = "N", default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=3))]
    frequencies: u8,
    /// Integer ambiguity resolution.
    #[arg(long, value_enum, default_value = "fix-and-hold")]
    ar: ArArg,
    /// Elevation mask, degrees (0 to 90), for the satellites used and the ambiguities fixed
    /// (low satellites are down-weighted by 1/sin(elevation), not dropped).
    #[arg(long, value_name = "DEG", default_value_t = 10.0)]
    elev_mask: f64,
    /// Elevation mask of the ambiguities fixed, degrees (default: --elev-mask); satellites
    /// between the two masks are used with float ambiguities.
    #[arg(long, value_name = "DEG")]
    ar_elev_mask: Option<f64>,
    /// Ratio-test threshold: the second-best integer candidate's squared distance over the
    /// best's must reach it for a fix (RTKLIB's pos2-arthres).
    #[arg(long, value_name = "RATIO", default_value_t = 3.0, value_parser = at_least_one)]
    ratio: f64,
    /// Epochs an ambiguity must be locked before it may be fixed (RTKLIB's pos2-arlockcnt).
    #[arg(long, value_name = "N", default_value_t = 1)]
    min_lock: usize,
    /// Largest 3D position sigma of an epoch reported fixed, metres: a fix whose position is
    /// less certain (few satellites, a long baseline) is not used and the epoch stays float:
    /// the integers may be right and the position still decimetres off. Default 0.08, except
    /// that on short baselines an epoch whose integers all continue arcs held since a
    /// stronger geometry fixed them stays fixed, with its larger sigma; given, the limit
    /// holds for every epoch.
    #[arg(long, value_name = "M", value_parser = positive)]
    max_fixed_sigma: Option<f64>,
    /// Largest time difference between a rover epoch and the base epoch it is differenced
    /// with, seconds (RTKLIB's pos2-maxage).
    #[arg(long, value_name = "S", default_value_t = 30.0, value_parser = positive)]
    max_age: f64,
    /// Difference a rover epoch that falls in a gap of the base's log with the nearer base
    /// epoch, aged, instead of base observations interpolated across the gap (the default:
    /// the base's residual against the modelled range is interpolated between the epochs on
    /// either side, within 2 × --max-age, phase dropped across a base slip; its error grows
    /// with d₀·d₁/span instead of the age).
    #[arg(long)]
    no_base_interpolation: bool,
    /// Start the rover's position afresh from its code solution at every epoch, also where
    /// the carrier phase says it stood still (by default the position is held from one epoch
    /// to the next there, within the sway of a hand-held pole, 5 mm/√s: the code of a whole
    /// stand then averages into one position; the summary says how much of the track was
    /// still).
    #[arg(long)]
    no_stillness: bool,
    /// Undifferenced carrier-phase sigma √(a² + (b/sin el)²): a,b in metres (RTKLIB's
    /// stats-errphase and stats-errphaseel).
    #[arg(long, value_name = "A,B", default_value = "0.003,0.003")]
    phase_sigma: String,
    /// Code sigma over carrier-phase sigma (RTKLIB's stats-eratio1).
    #[arg(long, value_name = "RATIO", default_value_t = 100.0, value_parser = positive)]
    code_phase_ratio: f64,
    /// Receiver antenna calibrations (ANTEX) for the antenna types in the file headers
    /// (default: no phase-centre corrections).
    #[arg(long, value_name = "FILE")]
    antex: Option<PathBuf>,
    /// Systems to use, letters separated by commas: G GPS, E Galileo, C BeiDou, J QZSS,
    /// R GLONASS (its ambiguities stay float: the inter-channel phase biases of two receivers
    /// differ unless they are identical; its inter-channel code bias is estimated). GLONASS
    /// adds geometry where satellites are few (under trees, in valleys).
    #[arg(long, value_name = "LIST", default_value = "G,E,C,J,R")]
    systems: String,
    /// Options from a TOML file: each key a flag of this command without its dashes
    /// (`elev-mask = 15`, `nav = ["a.nav", "b.nav"]`, `base-from-ppp = true`); relative paths
    /// are read from the file's folder. Flags on the command line win over the file. An
    /// unknown key is an error. See the README for an example.
    #[arg(long, value_name = "FILE.toml")]
    config: Option<PathBuf>,
    /// Options from an RTKLIB configuration file (rnx2rtkp/RTKPOST .conf: pos1-*, pos2-*,
    /// stats-*, out-*, ant2-*, file-rcvantfile). What was mapped to which flag, and what was
    /// ignored, is printed; --config and the command line win over it.
    #[arg(long, value_name = "FILE.conf")]
    rtklib_conf: Option<PathBuf>,
    /// Layout of the output: an RTKLIB .pos in llh or xyz, or KML, GeoJSON or GPX (WGS84,
    /// heights as --height; times in UTC) with every epoch's time, Q, satellites and σ.
    #[arg(long, value_enum, default_value = "llh")]
    format: TrajectoryFormatArg,
    /// Heights written: ellipsoidal (WGS84, GNSS's own), egm96 (orthometric above the EGM96
    /// geoid, built in: NGA's spherical harmonics to degree 360), egm2008 (orthometric above
    /// EGM2008, from the grid found in PROJ's or GeographicLib's data folders: PROJ_DATA,
    /// PROJ_LIB, ~/.local/share/proj, /usr/share/proj, GeographicLib's geoids; the file used
    /// is named) or geoid:FILE (orthometric above a grid file, bilinear: PROJ's GeoTIFF such
    /// as us_nga_egm08_25.tif, a GeographicLib .pgm such as egm2008-1.pgm, NGA's raw EGM2008
    /// grid, a PROJ .gtx, or text lines LAT LON N; a crop of NGA's raw grid as
    /// geoid:FILE@LAT,LON,MINUTES with its north-west node and spacing). Every output's header says which.
    #[arg(long, value_name = "HEIGHT", default_value = "ellipsoidal", value_parser = super::height_arg)]
    height: String,
    /// Output file, a .pos or the --format chosen (replaced if it exists; not written on
    /// failure).
    #[arg(short = 'o', long, value_name = "OUT.pos")]
    out: PathBuf,
    /// Also write a quality report: a self-contained HTML page with the ground track
    /// coloured by Q (exposure events circled), satellites, ratio, σ east/north/up and age
    /// over time, the fix rate, the ambiguity segments and the settings used.
    #[arg(long, value_name = "OUT.html")]
    report: Option<PathBuf>,
}

/// Which filter passes run.
#[derive(Clone, Copy, ValueEnum)]
enum FilterArg {
    /// Forward in time only
    Forward,
    /// Backward in time only
    Backward,
    /// Forward and backward: on long baselines the two-filter smoother, else the two passes
    /// combined epoch by epoch
    Combined,
}

/// How the rover moves.
#[derive(Clone, Copy, ValueEnum)]
enum MotionArg {
    /// A position per epoch (no dynamics model)
    Kinematic,
    /// One position over the whole span
    Static,
}

/// The point of the rover the positions describe.
#[derive(Clone, Copy, ValueEnum)]
enum ReferArg {
    /// Antenna reference point
    Arp,
    /// Marker (ARP minus ANTENNA: DELTA H/E/N)
    Marker,
}

/// Whether an atmospheric delay is estimated.
#[derive(Clone, Copy, ValueEnum)]
enum EstimateArg {
    /// When some rover epoch is more than 10 km from the base
    Auto,
    /// Never (a-priori models only)
    Off,
    /// Always
    On,
}

impl From<EstimateArg> for Estimate {
    fn from(a: EstimateArg) -> Estimate {
        match a {
            EstimateArg::Auto => Estimate::Auto,
            EstimateArg::Off => Estimate::Off,
            EstimateArg::On => Estimate::On,
        }
    }
}

/// Integer ambiguity resolution mode.
#[derive(Clone, Copy, ValueEnum)]
enum ArArg {
    /// Resolve every epoch; the filter keeps float ambiguities
    Continuous,
    /// Resolve every epoch from that epoch's data alone
    Instantaneous,
    /// Resolve, then constrain the filter to the fixed integers
    FixAndHold,
    /// Float ambiguities only
    Off,
}

/// Convert the arguments into a [`pipeline::PpkJob`], run it with a progress spinner and
/// print its report.
pub fn run(args: Args) -> Result<()> {
    let report = run_job(args)?;
    for n in &report.notes {
        eprintln!("note: {n}");
    }
    print!("{report}");
    Ok(())
}

/// Run the job the arguments describe with a progress spinner; its report.
pub fn run_job(args: Args) -> Result<pipeline::PpkReport> {
    let job = job(args)?;
    let bar = super::progress::Bar::new();
    let report = pipeline::ppk(&job, &bar);
    drop(bar);
    report.context("carrier-phase positioning failed")
}

/// The library's job for the arguments.
pub fn job(args: Args) -> Result<pipeline::PpkJob> {
    let base_position = base_position(args.base_pos.as_deref(), args.base_llh.as_deref())?;
    let systems = systems(&args.systems)?;
    let elev_mask = elev_mask(args.elev_mask)?;
    let ar_elev_mask = match args.ar_elev_mask {
        Some(m) => super::elev_mask(m).context("--ar-elev-mask")?,
        None => elev_mask,
    };
    let phase_sigma = super::pair("--phase-sigma", &args.phase_sigma)?;
    let options = PpkOptions {
        elev_mask,
        ar_elev_mask,
        ratio_threshold: args.ratio,
        min_lock: args.min_lock,
        max_fixed_sigma: args.max_fixed_sigma,
        max_age: args.max_age,
        interpolate_base: !args.no_base_interpolation,
        use_stillness: !args.no_stillness,
        phase_sigma,
        code_phase_ratio: args.code_phase_ratio,
        systems,
        motion: match args.mode {
            MotionArg::Kinematic => Motion::Kinematic,
            MotionArg::Static => Motion::Static,
        },
        refer: match args.refer {
            ReferArg::Arp => Reference::Arp,
            ReferArg::Marker => Reference::Marker,
        },
        nf: usize::from(args.frequencies),
        filter: match args.filter {
            FilterArg::Forward => FilterMode::Forward,
            FilterArg::Backward => FilterMode::Backward,
            FilterArg::Combined => FilterMode::Combined,
        },
        ar: match args.ar {
            ArArg::Continuous => ArMode::Continuous,
            ArArg::Instantaneous => ArMode::Instantaneous,
            ArArg::FixAndHold => ArMode::FixAndHold,
            ArArg::Off => ArMode::Off,
        },
        iono: args.iono.into(),
        tropo: args.tropo.into(),
        antex: match args.antex {
            Some(p) => Some(Arc::new(Antex::read(&p)?)),
            None => None,
        },
        ..PpkOptions::default()
    };
    let job = pipeline::PpkJob {
        rover: args.rover,
        base: args.base,
        obs_format: args.obs_format.into(),
        time_hint: args.time.hint(),
        nav: args.nav,
        sp3: args.sp3,
        clk: args.clk,
        base_position,
        base_from_ppp: args.base_from_ppp,
        options,
        format: args.format.into(),
        heights: super::heights(&args.height)?,
        out: args.out,
        report: args.report,
    };
    Ok(job)
}

/// A number of at least 1 (the ratio threshold).
fn at_least_one(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v >= 1.0 && v.is_finite() => Ok(v),
        _ => Err("give a number of at least 1".to_string()),
    }
}

/// A finite number above 0.
fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err("give a number above 0".to_string()),
    }
}

/// `--base-pos X,Y,Z` (ECEF metres) or `--base-llh LAT,LON,H`, else the header's position.
pub(crate) fn base_position(pos: Option<&str>, llh: Option<&str>) -> Result<BasePosition> {
    Ok(match (pos, llh) {
        (Some(p), _) => {
            let [x, y, z] = triple("--base-pos", p)?;
            if Ecef::new(x, y, z).0.norm() < 6.0e6 {
                bail!("--base-pos {p}: not an ECEF position on the Earth (metres expected)");
            }
            BasePosition::Given(Ecef::new(x, y, z))
        }
        (None, Some(l)) => {
            let [lat, lon, h] = triple("--base-llh", l)?;
            if lat.abs() > 90.0 || lon.abs() > 360.0 {
                bail!("--base-llh {l}: latitude and longitude in degrees expected");
            }
            BasePosition::Given(Geodetic::from_degrees(lat, lon, h).to_ecef())
        }
        (None, None) => BasePosition::Header,
    })
}
