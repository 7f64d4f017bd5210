//! `ppkat convert`: a raw receiver log to RINEX 3.04 observations and camera events.

use anyhow::Result;
use clap::ValueEnum;
use integration::gnss::raw::convert::{convert_with_progress, Outputs};
use integration::gnss::raw::RawFormat;
use std::path::PathBuf;

/// The format of the log.
#[derive(Clone, Copy, ValueEnum)]
pub enum FormatArg {
    /// Recognise the format from the file's content (UBX, RTCM 3 or SBF frames with a valid
    /// checksum)
    Auto,
    /// u-blox UBX (RXM-RAWX measurements, TIM-TM2 time marks); RTCM 3 and NMEA frames in the
    /// same log are read too
    Ubx,
    /// RTCM 3 (MSM4/5/6/7 observations, 1020 GLONASS channels, 1005/1006 station position);
    /// the same reader as ubx: a log may mix UBX, RTCM 3 and NMEA
    Rtcm3,
    /// Septentrio SBF (MeasEpoch measurements, GPSNav/GALNav/BDSNav/GLONav, ExtEvent)
    Sbf,
}

/// Convert a raw receiver log to a RINEX 3.04 observation file with flag-5 event records.
///
/// Reads a u-blox UBX log (M8T/M8P/F9P/F9T…): RXM-RAWX measurements become pseudorange,
/// carrier phase, Doppler and C/N0 with their loss-of-lock indicators as RTKLIB convbin
/// writes them (signal codes with the combined attribute: GPS C1C/C2X, Galileo C1X/C7X,
/// BeiDou C2I…), and one slip more: a lock time that grew by less than the time since the
/// signal's previous epoch (a loop that locked again inside a gap of the log); TIM-TM2 time marks become flag-5 event records (falling edges, as convbin)
/// and, with --events, a CSV of every edge. With --nav, the ephemerides decoded from the
/// navigation subframes (RXM-SFRBX; GPS/QZSS words parity-checked, Galileo pages CRC-checked,
/// BeiDou D1/D2 words BCH-checked, GLONASS strings Hamming-checked) go to a RINEX 3.04
/// navigation file. RTCM 3 logs give MSM observations, their ephemeris
/// messages and the station position. Septentrio SBF logs give MeasEpoch measurements (RINEX
/// codes as RTKLIB and Septentrio's converter name them: GPS C1C/C2W/C2L/C5Q, Galileo
/// C1C/C5Q/C7Q …; loss of lock from the lock time and the half-cycle flag), the decoded
/// navigation blocks (GPSNav, GALNav, BDSNav, GLONav) for --nav, and ExtEvent time marks as
/// flag-5 events. A log may mix UBX, RTCM 3 and NMEA (a u-blox base logging RXM-RAWX beside
/// the corrections it sends): every frame is read as its protocol, observations come from
/// RXM-RAWX when there are any (else from the MSMs), the station from 1005/1006/1033, and GGA
/// gives the receiver's own solution for --nmea. MSM observations carry the time of week
/// only: the week is the consensus of the log's ephemerides of the observations' time
/// (Galileo and BeiDou weeks are whole, GPS/QZSS ones modulo 1024); stale ephemerides of other
/// days are counted, named and not used. The format is recognised from the content, not the file name. Prints what was read and everything skipped: checksum failures, truncated
/// frames, unused message types with their counts, dropped measurements by reason.
#[derive(clap::Args)]
pub struct Args {
    /// Raw receiver log to convert.
    #[arg(long = "in", value_name = "FILE")]
    input: PathBuf,
    /// Format of the log; auto recognises it from the content.
    #[arg(long, value_enum, default_value = "auto")]
    format: FormatArg,
    /// RINEX 3.04 observation file to write.
    #[arg(short = 'o', long = "out", value_name = "OUT.obs")]
    out: PathBuf,
    /// CSV of the time-mark edges to write (week, tow, edge, count, valid).
    #[arg(long, value_name = "OUT.csv")]
    events: Option<PathBuf>,
    /// RINEX 3.04 mixed navigation file to write, of the ephemerides decoded from the log's
    /// navigation subframes (RXM-SFRBX: GPS/QZSS LNAV, Galileo I/NAV, BeiDou D1/D2, GLONASS).
    #[arg(long, value_name = "OUT.nav")]
    nav: Option<PathBuf>,
    /// RTKLIB .pos (lat/lon/ellipsoidal height, GPST) of the receiver's own solution read from
    /// the log's NMEA GGA sentences, to compare ppkat's with: height = altitude + the geoid
    /// separation GGA states; Q 1 where GGA says RTK fixed (4), 2 RTK float (5), 5 any other
    /// fix; GGA gives the UTC time of day, placed on the log's day and moved to GPST by the
    /// leap seconds.
    #[arg(long, value_name = "OUT.pos")]
    nmea: Option<PathBuf>,
    #[command(flatten)]
    time: super::TimeHintArgs,
}

/// Convert and print the report.
pub fn run(a: Args) -> Result<()> {
    let format = match a.format {
        FormatArg::Auto => None,
        FormatArg::Ubx => Some(RawFormat::Ubx),
        FormatArg::Rtcm3 => Some(RawFormat::Rtcm3),
        FormatArg::Sbf => Some(RawFormat::Sbf),
    };
    let outs = Outputs {
        obs: &a.out,
        nav: a.nav.as_deref(),
        events: a.events.as_deref(),
        nmea: a.nmea.as_deref(),
    };
    let bar = super::progress::Bar::new();
    let st = convert_with_progress(&a.input, format, a.time.hint(), outs, &bar);
    drop(bar);
    let st = st?;
    print!("{st}");
    for p in [
        Some(&a.out),
        a.nav.as_ref(),
        a.events.as_ref(),
        a.nmea.as_ref(),
    ]
    .into_iter()
    .flatten()
    {
        println!("wrote {}", p.display());
    }
    Ok(())
}
