//! `ppkat` command line: parse the arguments, hand them to the subcommand's module
//! ([`cmd`]), map its result to the exit code: 0 all done, 3 finished but inputs skipped (named
//! and counted on standard error, [`cmd::Incomplete`]), 1 failed or produced nothing usable;
//! clap exits with 2 on bad usage.

// The doc comments of the argument structs are clap's `--help` text, written for people at a
// terminal (`[[camera]]` tables, `<image id>`), not rustdoc markdown.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]

mod cmd;

use anyhow::{Context, Result};
use clap::{CommandFactory, Parser, Subcommand};

/// The command line: one global option and a subcommand.
#[derive(Parser)]
#[command(
    name = "ppkat",
    version,
    about = "Flight GNSS post-processing and GNSS-supported aerial triangulation",
    long_about = "Flight GNSS post-processing and GNSS-supported aerial triangulation in one \
                  tool: single-point and carrier-phase (PPK) positioning from RINEX files, \
                  camera projection centres from exposure events, and the joint GNSS-supported \
                  bundle adjustment of photogrammetric blocks, with a flight simulator to try \
                  it all on known truth.\n\nStart with `ppkat demo`; `ppkat COMMAND --help` \
                  describes each command's inputs, outputs and options."
)]
struct Cli {
    /// Worker threads (default: all cores); results are identical whatever the number.
    #[arg(
        long,
        global = true,
        value_name = "N",
        help_heading = "Global options",
        value_parser = thread_count
    )]
    threads: Option<usize>,
    /// No progress bars and no notes on standard error; warnings about skipped inputs and
    /// errors are still printed. (Progress bars appear only when standard error is a
    /// terminal.)
    #[arg(long, short = 'q', global = true, help_heading = "Global options")]
    quiet: bool,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    Info(cmd::info::Args),
    Convert(cmd::convert::Args),
    Spp(cmd::spp::Args),
    Ppk(cmd::ppk::Args),
    Ppp(cmd::ppp::Args),
    Exposures(cmd::exposures::Args),
    Ins(cmd::ins::Args),
    Leverarm(cmd::leverarm::Args),
    Bal(cmd::bal::Args),
    Simulate(cmd::simulate::Args),
    Adjust(cmd::adjust::Args),
    Import(cmd::import::Args),
    Match(cmd::tiepoints::Args),
    Demo(cmd::demo::Args),
    Batch(cmd::batch::Args),
    Bench(cmd::bench::Args),
}

/// `--threads N`: a whole number, at least 1.
fn thread_count(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err("give a whole number of threads, 1 or more".to_string()),
    }
}

fn main() {
    // `ppkat … | head` must end quietly, as other command-line tools do, not panic in print!.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    common::memory::keep_large_buffers();
    let expanded = match cmd::config::expand(&Cli::command(), std::env::args_os().collect()) {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: {}", e.0);
            std::process::exit(e.exit_code());
        }
    };
    let cli = Cli::parse_from(expanded.args);
    cmd::set_quiet(cli.quiet);
    for n in &expanded.notes {
        cmd::note(n);
    }
    if let Err(e) = run(cli) {
        if let Some(i) = e.downcast_ref::<cmd::Incomplete>() {
            eprintln!("warning: {i}");
            std::process::exit(3);
        }
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Size rayon's global pool once and run the subcommand on it: every parallel stage then
/// starts from a worker of the pool, not from outside it (which costs a hand-over per
/// parallel call).
fn run(cli: Cli) -> Result<()> {
    let threads = cli.threads;
    cmd::set_quiet(cli.quiet);
    if let Some(n) = threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("cannot start the worker threads")?;
    }
    let mut result = None;
    rayon::scope(|_| result = Some(dispatch(cli.cmd, threads)));
    result.unwrap_or_else(|| Ok(()))
}

/// Run one subcommand.
fn dispatch(cmd: Cmd, threads: Option<usize>) -> Result<()> {
    match cmd {
        Cmd::Info(a) => cmd::info::run(a),
        Cmd::Convert(a) => cmd::convert::run(a),
        Cmd::Spp(a) => cmd::spp::run(a),
        Cmd::Ppk(a) => cmd::ppk::run(a),
        Cmd::Ppp(a) => cmd::ppp::run(a),
        Cmd::Exposures(a) => cmd::exposures::run(a),
        Cmd::Ins(a) => cmd::ins::run(a),
        Cmd::Leverarm(a) => cmd::leverarm::run(a),
        Cmd::Bal(a) => cmd::bal::run(a, threads),
        Cmd::Simulate(a) => cmd::simulate::run(a),
        Cmd::Adjust(a) => cmd::adjust::run(a, threads),
        Cmd::Import(a) => cmd::import::run(a),
        Cmd::Match(a) => cmd::tiepoints::run(a),
        Cmd::Demo(a) => cmd::demo::run(a, threads),
        Cmd::Batch(a) => cmd::batch::run(a),
        Cmd::Bench(a) => cmd::bench::run(a, threads),
    }
}

#[cfg(test)]
mod tests {
    use super::Cli;
    use clap::CommandFactory;

    #[test]
    fn the_command_line_is_consistent() {
        Cli::command().debug_assert();
    }

    /// Every subcommand says what it does (about and long about), and every argument of every
    /// subcommand, at any depth, has a help text.
    #[test]
    fn every_subcommand_and_argument_has_help() {
        fn walk(cmd: &clap::Command, path: &str, missing: &mut Vec<String>) {
            for arg in cmd.get_arguments() {
                let id = arg.get_id().as_str();
                if id == "help" || id == "version" {
                    continue;
                }
                let text = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
                if text.trim().is_empty() {
                    missing.push(format!("{path}: argument {id} has no help"));
                }
            }
            for sub in cmd.get_subcommands() {
                let name = format!("{path} {}", sub.get_name());
                if sub.get_name() == "help" {
                    continue;
                }
                if sub.get_about().is_none() {
                    missing.push(format!("{name}: no about"));
                }
                if sub.get_long_about().is_none() {
                    missing.push(format!("{name}: no long about"));
                }
                walk(sub, &name, missing);
            }
        }
        let mut cmd = Cli::command();
        cmd.build();
        let mut missing = Vec::new();
        walk(&cmd, "ppkat", &mut missing);
        assert!(missing.is_empty(), "{}", missing.join("\n"));
        assert!(
            cmd.get_subcommands().count() >= 10,
            "the walk sees the subcommands"
        );
    }
}
