//! `ppkat info`: what an observation file holds.

use anyhow::Result;
use integration::gnss::rinex::summary::ObsSummary;
use integration::gnss::rinex::ObsFile;
use std::path::PathBuf;

/// Describe an observation file: version, span, interval, systems, signals, events, problems.
///
/// Reads one RINEX observation file (versions 2.x, 3.x and 4.x; Hatanaka-compressed CRINEX 1
/// and 3 and gzip files too) and prints its format and version, marker, receiver and antenna,
/// approximate position, time span (GPST), interval, number of epochs, camera events (flag-5
/// records), the satellites and signals of each system, and anything suspicious found while
/// reading (a truncated last epoch, unreadable lines with their line numbers, dropped
/// satellites). Writes nothing.
#[derive(clap::Args)]
pub struct Args {
    /// RINEX observation file to describe (.obs, .rnx, .YYo, .crx, .YYd, optionally .gz).
    #[arg(value_name = "FILE")]
    file: PathBuf,
}

/// Read the file and print its summary.
pub fn run(args: Args) -> Result<()> {
    let f = ObsFile::read(&args.file)?;
    print!("{}", ObsSummary::of(&f));
    Ok(())
}
