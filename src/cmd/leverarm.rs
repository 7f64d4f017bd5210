//! `ppkat leverarm`: the lever arm from four tape lengths.

use anyhow::{Context, Result};
use integration::exposure::leverarm::Tapes;

/// The lever arm from tape lengths: D0 (origin mark → antenna) and DX,DY,DZ (marks at
/// distance A along the body axes → antenna).
///
/// Solves the antenna offset (u, v, w) in the camera (body) frame by the law of cosines,
/// u = (D0² + A² − DX²)/(2A) and likewise v and w, checks that the lengths are consistent
/// (u² + v² + w² = D0²), and prints the offset and its sigmas (error propagation from the
/// sigma of one tape length), metres. Reads and writes no files.
#[derive(clap::Args)]
pub struct Args {
    /// The four tape lengths D0,DX,DY,DZ, metres, separated by commas.
    #[arg(long, value_name = "D0,DX,DY,DZ")]
    tapes: String,
    /// Distance A of the x, y and z marks from the origin mark, metres.
    #[arg(long, value_name = "A", value_parser = super::finite_number)]
    ruler: f64,
    /// Sigma of one tape length, metres.
    #[arg(long, value_name = "M", default_value_t = 0.002, value_parser = super::finite_number)]
    sigma: f64,
}

/// Parse the tapes, solve and print the lever arm with its sigmas.
pub fn run(args: Args) -> Result<()> {
    let tapes: Tapes = args.tapes.parse().context("--tapes")?;
    println!("{}", tapes.solve(args.ruler, args.sigma)?);
    Ok(())
}
