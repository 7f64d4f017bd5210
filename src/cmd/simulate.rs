//! `ppkat simulate`: a survey flight or an adjustment project with exact truth.

use anyhow::{bail, Context, Result};
use integration::ins::spec::Grade;
use integration::simulate::{self, block, Scenario};
use std::path::{Path, PathBuf};

/// Simulate a survey flight with exact truth, or a ready-to-run adjustment project.
///
/// A flight (--scenario FILE.toml, or --builtin demo, block20, long or hard-sky) writes into the output
/// folder: rover.obs (10 Hz, flag-5 events at the exposures), base.obs, nav.rnx (a synthetic
/// constellation), truth_trajectory.csv, truth_exposures.csv, ground_points.csv,
/// image_observations.csv and truth_blunders.csv; with --raw ubx also rover.ubx and base.ubx,
/// the same observations as u-blox logs (RXM-RAWX, and TIM-TM2 time marks at the exposures);
/// with --raw rtcm3 rover.rtcm3 and base.rtcm3, RTCM 3 logs (MSM7, station position 1005; no
/// events: RTCM carries none); with --raw sbf rover.sbf and base.sbf, Septentrio SBF logs
/// (GPSNav/GALNav ephemerides, GPSIon/GPSUtc, MeasEpoch, ExtEvent at the exposures; no station
/// position: SBF carries none); with --sp3 orbits.sp3, the constellation as precise orbits. The scenario keys are shown in
/// fixtures/scenario_small.toml; every error source can be switched under `[errors]`.
///
/// hard-sky is a flight where GNSS alone stays float at every strip start (5–6 satellites above
/// 32°, every satellite lost at each turn and again 30–60 s into each strip, a base 20 km
/// away); it also runs PPK and the exposures and writes rover_ppk.pos, antennas.csv,
/// images.csv, project.toml (coupling = "loose": the PPK antenna positions) and
/// project_tight.toml (coupling = "tight": the double-difference carrier phase itself).
///
/// ins is a survey flight for the GNSS/INS: 30 s standing, 20 s speeding up east to 60 m/s,
/// then four strips joined by three 180° turns at 3 °/s (banked 17.8°) to ten minutes; an
/// IMU of --imu-grade (tactical unless told) at 200 Hz (imu.csv + imu.csv.tag, the
/// RTKLIB-style log), GNSS antenna positions at 1 Hz (gnss.pos), the IMU's truth at 10 Hz
/// (truth_ins.csv, the columns insstat.py reads) and ins.toml (`ppkat ins --config`, the GNSS
/// withheld from 299 to 329 s, in the second strip).
///
/// long-baseline is a 250 km pair of static geodetic receivers (GPS L1/L2, 30 s, 24 h) with
/// the ionosphere and troposphere differing between the ends beyond the broadcast models and
/// code biases of two receiver types, and a navigation file that also holds stale sets of an
/// older upload as merged daily files do: OUT/ppk.toml, rover.obs, base.obs, nav.rnx,
/// truth_trajectory.csv, truth.toml, README.txt; the same pair observing Galileo E1/E5a
/// beside GPS in OUT/gps-galileo/.
///
/// lowcost is the test bench of low-cost receivers, with exact truth: OUT/walk/ holds a u-blox
/// M8P-like rover on a pole staking out points 3–30 m from a base of the same kind (20 min,
/// 1 Hz, GPS/GLONASS L1, standing 70 % of the time), both receivers carrying what a real pair
/// was measured to do (shared/data/lowcost-fingerprint: time tags milliseconds off GPS time,
/// wandering clocks, losses of lock in bursts, unflagged phase jumps, slowly varying code
/// errors with excursions of metres, heavy-tailed Doppler) as rover.ubx, against base.ubx
/// mixing UBX, RTCM 3 (1005, MSM7, 1230) and NMEA, whose UBX and RTCM epochs each have gaps of
/// their own. OUT/walk-open/ holds the kinder walk of before: a rover walking a river trail
/// (GPS/GLONASS/QZSS L1, under trees half the time) against a base a few hundred metres away.
/// OUT/drone/ holds a DJI Phantom 4 RTK-like flight (5.7 min, 5 Hz, GPS/GLONASS/Galileo L1/L2)
/// as PPKRAW.bin (RTCM 3 MSM7 opening with stale GPS ephemerides of other weeks) with
/// Timestamp.MRK, against a CORS's base.obs. Each folder has ppk.toml (`ppkat ppk --config
/// OUT/walk/ppk.toml`), truth_trajectory.csv (the antenna at the true reception time of every
/// rover epoch), nav.rnx, the RINEX of each receiver and README.txt with the figures simulated.
///
/// An adjustment project (--builtin classic-block, close-range, block1000, nav-block,
/// sparse-control or textured-block: the classic 2-strip 1:8000 block, a close-range pair, a
/// 1000-image block, a block with navigation-grade GPS, a 0.8 s latency and sparse control,
/// 290 images shaped like a real film block (most images measure one control point, 88 two
/// to five; GNSS 14 m off, 0.8 s late; no tie points), a small block with rendered photos)
/// writes project.toml and its tables, ready for `ppkat adjust --project OUT/project.toml`
/// (nav-block and sparse-control also write project_gcp_only.toml and their truth).
///
/// textured-block renders its 3 × 8 photos (1600 × 1200 px, 5 cm on the ground, 8-bit grey
/// PNG in OUT/photos/<image id>.png) of a textured terrain through the exact camera, for
/// checking feature matchers: camera.toml holds the exact camera as a [[camera]] table,
/// antennas.csv the GNSS antenna positions, image_observations.csv the exact pixels of the
/// tie, control and check points, and truth.toml, truth_exposures.csv and truth_points.csv
/// the truth (terrain seed, exact poses, points). Pixels: column right, row down, origin at
/// the top-left corner of the top-left pixel (pixel centres at i + 0.5). About 20 s on two
/// cores.
///
/// Prints a summary of what was simulated. The results are the same for the same scenario
/// on every run.
#[derive(clap::Args)]
pub struct Args {
    /// Flight scenario file (TOML; keys as in fixtures/scenario_small.toml).
    #[arg(long, value_name = "FILE.toml", conflicts_with = "builtin")]
    scenario: Option<PathBuf>,
    /// Built-in scenario: demo, block20, long or hard-sky (flights), lowcost or long-baseline
    /// (GNSS benches), ins (an IMU and GNSS flight for `ppkat ins`), or classic-block, close-range, block1000, nav-block, sparse-control or
    /// textured-block (adjustment projects).
    #[arg(long, value_name = "NAME")]
    builtin: Option<String>,
    /// Output folder (created; files of the same names are replaced).
    #[arg(short = 'o', long, value_name = "DIR")]
    out: PathBuf,
    /// Also write the rover and base as raw receiver logs of this format (flights only).
    #[arg(long, value_enum, value_name = "FORMAT")]
    raw: Option<RawArg>,
    /// Draw another realisation of the built-in scenario (or of the scenario file): its noise,
    /// losses of lock, slips, errors and, where they are drawn, its paths and points; the
    /// layout stays. Without it each built-in keeps its own seed, so its files are those the
    /// tests and benches know. Check several seeds before trusting a figure.
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// Also write orbits.sp3: the synthetic constellation as precise orbits (SP3-c, positions
    /// and clocks every 5 minutes from an hour before the flight to an hour after), for
    /// trying `--sp3` without `--nav` (flights only).
    #[arg(long)]
    sp3: bool,
    /// The IMU of --builtin ins: navigation, tactical or mems (the presets `ppkat ins
    /// --grade` knows; its ins.toml names the same grade).
    #[arg(long, value_name = "GRADE", value_parser = super::ins::grade)]
    imu_grade: Option<Grade>,
}

/// A raw log format the simulator writes.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum RawArg {
    /// u-blox UBX: RXM-RAWX measurements, TIM-TM2 time marks
    Ubx,
    /// RTCM 3: MSM7 per system and epoch, 1005, 1019 (week), 1020 (GLONASS channels); no events
    Rtcm3,
    /// Septentrio SBF: GPSNav/GALNav, GPSIon/GPSUtc, MeasEpoch per epoch, ExtEvent per exposure
    Sbf,
}

/// Simulate the built-in project or the flight scenario named by the arguments and print the
/// summary.
pub fn run(args: Args) -> Result<()> {
    let project = args
        .builtin
        .as_deref()
        .is_some_and(|b| block::BUILTINS.contains(&b));
    if project && args.raw.is_some() {
        bail!("--raw applies to flights (a scenario, or --builtin demo, block20 or long), not to adjustment projects");
    }
    if args.imu_grade.is_some() && args.builtin.as_deref() != Some("ins") {
        bail!("--imu-grade applies to --builtin ins only");
    }
    let plain_flight = !project
        && !matches!(
            args.builtin.as_deref(),
            Some("lowcost" | "long-baseline" | "hard-sky" | "ins")
        );
    if args.sp3 && !plain_flight {
        bail!("--sp3 applies to flights (a scenario, or --builtin demo, block20 or long)");
    }
    if let Some(r) = args
        .builtin
        .as_deref()
        .and_then(|b| block::builtin_seeded(b, &args.out, args.seed))
    {
        println!("{}", r?);
        return Ok(());
    }
    if args.builtin.as_deref() == Some("lowcost") {
        if args.raw.is_some() {
            bail!("--raw does not apply to lowcost: its folders hold the logs low-cost receivers write (u-blox UBX, a UBX + RTCM 3 + NMEA base log)");
        }
        print!(
            "{}",
            simulate::lowcost::run(&args.out, args.seed.unwrap_or(simulate::lowcost::SEED))?
        );
        return Ok(());
    }
    if args.builtin.as_deref() == Some("ins") {
        if args.raw.is_some() {
            bail!("--raw does not apply to ins: its folder holds an IMU log and a GNSS .pos");
        }
        let grade = args.imu_grade.unwrap_or(Grade::Tactical);
        print!(
            "{}",
            simulate::ins_flight::run(
                &args.out,
                args.seed.unwrap_or(simulate::ins_flight::SEED),
                grade,
            )?
        );
        return Ok(());
    }
    if args.builtin.as_deref() == Some("long-baseline") {
        if args.raw.is_some() {
            bail!("--raw does not apply to long-baseline: its receivers write RINEX");
        }
        let r = simulate::longbase::run(&args.out, args.seed.unwrap_or(simulate::longbase::SEED))?;
        println!(
            "long-baseline: {:.1} km, rover {} epochs, base {} epochs → {} (ppkat ppk --config {})",
            r.baseline_km,
            r.rover.epochs,
            r.base.epochs,
            args.out.display(),
            args.out.join("ppk.toml").display()
        );
        return Ok(());
    }
    let mut s = scenario(args.scenario.as_deref(), args.builtin.as_deref())?;
    if let Some(seed) = args.seed {
        s.seed = seed;
    }
    if args.builtin.as_deref() == Some("hard-sky") && args.raw.is_none() {
        print!("{}", integration::hard_sky::run_scenario(&args.out, &s)?);
        return Ok(());
    }
    let rep = simulate::run(&s, &args.out)?;
    print!("{rep}");
    if args.sp3 {
        let p = simulate::write_sp3(&rep)?;
        println!("precise orbits: {} (SP3-c, 5 min)", p.display());
    }
    let raw = match args.raw {
        None => None,
        Some(RawArg::Ubx) => Some((simulate::write_ubx(&rep)?, "u-blox UBX", "UBX", "")),
        Some(RawArg::Rtcm3) => Some((simulate::write_rtcm(&rep)?, "RTCM 3", "RTCM", "")),
        Some(RawArg::Sbf) => Some((
            simulate::write_sbf(&rep)?,
            "Septentrio SBF",
            "SBF",
            "; no station position: SBF carries none",
        )),
    };
    if let Some(((rover, base, dropped), format, short, note)) = raw {
        println!(
            "raw logs: {} and {} ({format}; {dropped} measurements {short} cannot carry{note})",
            rover.display(),
            base.display()
        );
    }
    Ok(())
}

/// The flight scenario: read from `--scenario`, or the built-in one named by `--builtin`.
fn scenario(file: Option<&Path>, builtin: Option<&str>) -> Result<Scenario> {
    Ok(match (file, builtin) {
        (Some(p), _) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("{}: cannot read the scenario", p.display()))?;
            Scenario::from_toml(&text).with_context(|| format!("{}", p.display()))?
        }
        (None, Some(name)) => simulate::builtin(name).with_context(|| {
            format!(
                "no built-in scenario '{name}' (flights: {}; adjustment projects: {})",
                simulate::BUILTINS.join(", "),
                block::BUILTINS.join(", ")
            )
        })?,
        (None, None) => bail!(
            "give --scenario FILE.toml or --builtin NAME ({})",
            simulate::BUILTINS.join(", ")
        ),
    })
}
