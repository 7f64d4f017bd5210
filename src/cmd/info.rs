//! `ppkat info`: what an observation file holds.

use super::{ObsFormatArg, TimeHintArgs};
use anyhow::Result;
use integration::gnss::obs::{read_obs, ObsFormat};
use integration::gnss::rinex::summary::ObsSummary;
use std::path::PathBuf;

/// Describe an observation file: version, span, interval, systems, signals, events, problems.
///
/// Reads one RINEX observation file (versions 2.x, 3.x and 4.x; Hatanaka-compressed CRINEX 1
/// and 3 and gzip files too) or a raw u-blox UBX log (told apart by content, or by
/// --obs-format; a log is described as its RINEX conversion would be, followed by what its
/// decoding read and dropped) and prints its format and version, marker, receiver and antenna,
/// approximate position, time span (GPST), interval, number of epochs, camera events (flag-5
/// records), the satellites and signals of each system, and anything suspicious found while
/// reading (a truncated last epoch, unreadable lines with their line numbers, dropped
/// satellites). Writes nothing.
#[derive(clap::Args)]
pub struct Args {
    /// Observation file to describe: RINEX (.obs, .rnx, .YYo, .crx, .YYd, optionally .gz) or
    /// a u-blox UBX log.
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// Format of the file; auto tells it from the content.
    #[arg(long, value_enum, value_name = "FORMAT", default_value = "auto")]
    obs_format: ObsFormatArg,
    #[command(flatten)]
    time: TimeHintArgs,
}

/// Read the file and print its summary.
pub fn run(args: Args) -> Result<()> {
    let input = read_obs(&args.file, args.obs_format.into(), args.time.hint())?;
    if let (ObsFormat::Raw(f), Some(st)) = (input.format, &input.raw) {
        println!(
            "{} log, described as its RINEX 3.04 conversion (ppkat convert):",
            st.log_kind(f)
        );
    }
    print!("{}", ObsSummary::of(&input.obs));
    if let Some(st) = &input.raw {
        print!("{st}");
    }
    Ok(())
}
