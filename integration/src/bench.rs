//! Benchmarks run by `ppkat bench`: throughput and peak memory of the stages. Enters: an
//! observation file ([`ingest`]: RINEX plain, gzip or Hatanaka, parsed by `gnss::rinex`; or a
//! raw receiver log, converted by `gnss::raw::convert`) or a block size
//! ([`adjust`](fn@adjust): simulated by [`crate::simulate::block`], adjusted by the `adjust`
//! crate), or a finished `ppk` run ([`PpkBench::of`]). Leaves: an [`Ingest`], [`PpkBench`] or
//! [`AdjustBench`] with wall times (s) and the peak resident memory of the process (Linux
//! `VmHWM`, KiB); nothing is kept but temporary files (removed), the benchmark block's
//! folder and the `ppk` run's outputs.

use gnss::error::Result;
use gnss::obs::{detect_format, ObsFormat};
use gnss::raw::convert::{convert, Outputs};
use gnss::raw::RawStats;
use gnss::rinex::{ObsReader, Record};
use std::path::Path;
use std::time::Instant;

/// Result of an ingest benchmark: RINEX parsing or raw-log conversion.
#[derive(Clone, Debug)]
pub enum Ingest {
    /// A RINEX observation file parsed.
    Rinex(IngestBench),
    /// A raw receiver log converted (boxed: its statistics are large).
    Raw(Box<ConvertBench>),
}

impl std::fmt::Display for Ingest {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Ingest::Rinex(b) => b.fmt(f),
            Ingest::Raw(b) => b.fmt(f),
        }
    }
}

/// Result of converting a raw log (as `ppkat convert --nav` does, the navigation file left
/// out when the log has no ephemeris), repeated until at least a second has passed so that
/// small logs give a stable figure.
#[derive(Clone, Debug)]
pub struct ConvertBench {
    /// The log's format.
    pub format: gnss::raw::RawFormat,
    /// Bytes of the log.
    pub bytes: u64,
    /// Conversions run.
    pub runs: usize,
    /// Wall time of all runs, seconds.
    pub seconds: f64,
    /// CPU time of the process's main thread over the runs, seconds (Linux; None where
    /// unknown): on a loaded machine the wall time overstates the cost.
    pub cpu_seconds: Option<f64>,
    /// What one conversion read and dropped.
    pub stats: RawStats,
    /// Peak resident set size of the process, KiB (None where unknown).
    pub peak_rss_kib: Option<u64>,
}

impl ConvertBench {
    /// Megabytes of log converted per second.
    pub fn mb_per_s(&self) -> f64 {
        self.bytes as f64 * self.runs as f64 / 1e6 / self.seconds
    }
}

impl std::fmt::Display for ConvertBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "convert: {:.1} MB of {} log ({} epochs, {} ephemerides) to RINEX observations and \
             navigation, {} runs in {:.3} s = {:.0} MB/s",
            self.bytes as f64 / 1e6,
            self.format.name(),
            self.stats.epochs,
            self.stats.nav.ephemerides,
            self.runs,
            self.seconds,
            self.mb_per_s()
        )?;
        if let Some(c) = self.cpu_seconds {
            writeln!(
                f,
                "CPU time: {c:.3} s = {:.0} MB/s per CPU second (files written with fsync)",
                self.bytes as f64 * self.runs as f64 / 1e6 / c
            )?;
        }
        writeln!(f, "peak RSS: {}", mib(self.peak_rss_kib))?;
        if let Some(k) = self.peak_rss_kib {
            writeln!(
                f,
                "memory factor: peak RSS = {:.2} × the log",
                k as f64 * 1024.0 / self.bytes.max(1) as f64
            )?;
        }
        Ok(())
    }
}

/// CPU time this thread has run, seconds (Linux `/proc/thread-self/schedstat`).
fn thread_cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns as f64 * 1e-9)
}

/// Convert a raw log to temporary RINEX observation and navigation files, repeatedly.
fn convert_bench(path: &Path, format: gnss::raw::RawFormat) -> Result<ConvertBench> {
    let dir = std::env::temp_dir();
    let id = std::process::id();
    let (obs, nav) = (
        dir.join(format!("ppkat-bench-{id}.obs")),
        dir.join(format!("ppkat-bench-{id}.nav")),
    );
    // A first, untimed run warms the file cache and says whether the log has ephemerides
    // (without any, convert refuses a navigation file).
    let first = convert(
        path,
        Some(format),
        None,
        Outputs {
            obs: &obs,
            nav: None,
            events: None,
            nmea: None,
        },
    );
    let with_nav = first.as_ref().is_ok_and(|s| s.nav.ephemerides > 0);
    let outs = Outputs {
        obs: &obs,
        nav: with_nav.then_some(nav.as_path()),
        events: None,
        nmea: None,
    };
    let (t, cpu0) = (Instant::now(), thread_cpu_seconds());
    let mut runs = 0;
    let mut last = first;
    while last.is_ok() && (runs == 0 || (t.elapsed().as_secs_f64() < 1.0 && runs < 1000)) {
        last = convert(path, Some(format), None, outs);
        runs += 1;
    }
    let seconds = t.elapsed().as_secs_f64();
    let cpu_seconds = cpu0.zip(thread_cpu_seconds()).map(|(a, b)| b - a);
    let _ = std::fs::remove_file(&obs);
    let _ = std::fs::remove_file(&nav);
    let stats = last?;
    Ok(ConvertBench {
        format,
        bytes: stats.bytes,
        runs,
        seconds,
        cpu_seconds,
        stats,
        peak_rss_kib: peak_rss_kib(),
    })
}

/// Result of an ingest benchmark.
#[derive(Clone, Debug)]
pub struct IngestBench {
    /// Bytes of the file given (compressed or not).
    pub input_bytes: u64,
    /// Bytes of plain RINEX text parsed (the file expanded).
    pub bytes: u64,
    /// Wall time of the parse, seconds.
    pub seconds: f64,
    /// Observation epochs read.
    pub epochs: usize,
    /// Satellite records read.
    pub sat_records: usize,
    /// Peak resident set size of the process, KiB (None where unknown).
    pub peak_rss_kib: Option<u64>,
}

impl std::fmt::Display for IngestBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "ingest: {:.1} MB of RINEX text, {} epochs, {} satellite records in {:.3} s = {:.0} MB/s",
            self.bytes as f64 / 1e6,
            self.epochs,
            self.sat_records,
            self.seconds,
            self.bytes as f64 / 1e6 / self.seconds
        )?;
        writeln!(f, "peak RSS: {}", mib(self.peak_rss_kib))?;
        if let Some(k) = self.peak_rss_kib {
            let rss = k as f64 * 1024.0;
            writeln!(
                f,
                "memory factor: peak RSS = {:.2} × the input file ({:.1} MB), {:.2} × the RINEX \
                 text ({:.1} MB)",
                rss / self.input_bytes.max(1) as f64,
                self.input_bytes as f64 / 1e6,
                rss / self.bytes.max(1) as f64,
                self.bytes as f64 / 1e6
            )?;
        }
        Ok(())
    }
}

/// A memory size in KiB as `12.3 MiB`, or `unknown`.
fn mib(kib: Option<u64>) -> String {
    match kib {
        Some(k) => format!("{:.1} MiB", k as f64 / 1024.0),
        None => "unknown".into(),
    }
}

/// Peak resident set size of this process (Linux), KiB.
pub fn peak_rss_kib() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse().ok())
}

/// Benchmark the ingest of an observation file, its format told from the content: a raw log
/// is converted ([`ConvertBench`]), a RINEX file parsed ([`rinex_ingest`]).
pub fn ingest(path: &Path) -> Result<Ingest> {
    match detect_format(path)? {
        ObsFormat::Raw(f) => convert_bench(path, f).map(|b| Ingest::Raw(Box::new(b))),
        ObsFormat::Rinex => rinex_ingest(path).map(Ingest::Rinex),
    }
}

/// Stream an observation file through the parser, keeping nothing (the pure parse cost).
/// A compressed file (gzip, Hatanaka) is first expanded to a temporary plain RINEX file, so the
/// figure is the parser's speed on plain text, as the benchmark target is stated.
pub fn rinex_ingest(path: &Path) -> Result<IngestBench> {
    let plain = std::env::temp_dir().join(format!("ppkat-bench-{}.rnx", std::process::id()));
    let io = gnss::Error::io(&plain);
    let mut f = std::io::BufWriter::new(std::fs::File::create(&plain).map_err(io)?);
    gnss::rinex::write_plain_text(path, &mut f)?;
    std::io::Write::flush(&mut f).map_err(io)?;
    drop(f);
    let r = ingest_plain(&plain);
    let _ = std::fs::remove_file(&plain);
    let input_bytes = std::fs::metadata(path)
        .map_err(gnss::Error::io(path))?
        .len();
    r.map(|b| IngestBench { input_bytes, ..b })
}

fn ingest_plain(path: &Path) -> Result<IngestBench> {
    let t = Instant::now();
    let mut r = ObsReader::open(path)?;
    let mut epochs = 0;
    let mut sat_records = 0;
    while let Some(rec) = r.next_record()? {
        if let Record::Epoch(e) = rec {
            epochs += 1;
            sat_records += e.sats.len();
        }
    }
    let seconds = t.elapsed().as_secs_f64();
    Ok(IngestBench {
        input_bytes: r.stats().bytes,
        bytes: r.stats().bytes,
        seconds,
        epochs,
        sat_records,
        peak_rss_kib: peak_rss_kib(),
    })
}

/// Wall time and peak memory of the joint adjustment of a simulated block.
#[derive(Clone, Debug)]
pub struct AdjustBench {
    /// Images adjusted.
    pub images: usize,
    /// Ground points adjusted.
    pub points: usize,
    /// Observations (components).
    pub observations: usize,
    /// Unknowns.
    pub unknowns: usize,
    /// Wall time of the simulation, seconds.
    pub simulate_s: f64,
    /// Wall time of the adjustment with statistics and reports, seconds.
    pub adjust_s: f64,
    /// A-posteriori σ0.
    pub sigma0: f64,
    /// Peak resident set size of the process, KiB (None where unknown).
    pub peak_rss_kib: Option<u64>,
    /// The solver's timed stages: what, how many times, seconds in all.
    pub stages: Vec<(&'static str, usize, f64)>,
}

impl std::fmt::Display for AdjustBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "adjust: {} images, {} points, {} observations, {} unknowns",
            self.images, self.points, self.observations, self.unknowns
        )?;
        writeln!(
            f,
            "simulated in {:.2} s; adjusted (snooping, variance components, statistics, reports) in {:.2} s; σ0 {:.3}",
            self.simulate_s, self.adjust_s, self.sigma0
        )?;
        writeln!(
            f,
            "stages (nested: snooping includes its solves and cofactors, a solve its iterations):"
        )?;
        for (what, n, s) in &self.stages {
            writeln!(
                f,
                "  {what}: {n} × {:.2} s on average, {s:.2} s in all",
                s / *n as f64
            )?;
        }
        writeln!(f, "peak RSS {}", mib(self.peak_rss_kib))
    }
}

/// Result of a carrier-phase benchmark: the engine's time per rover epoch.
#[derive(Clone, Debug)]
pub struct PpkBench {
    /// Rover epochs.
    pub rover_epochs: usize,
    /// Passes of the filter over them (1 or 2).
    pub passes: usize,
    /// Reading and checking the inputs, seconds.
    pub read_s: f64,
    /// The carrier-phase engine, seconds.
    pub process_s: f64,
    /// Peak resident set size of the process, KiB (None where unknown).
    pub peak_rss_kib: Option<u64>,
}

impl PpkBench {
    /// The figures of a finished `ppk` run.
    pub fn of(r: &crate::pipeline::PpkReport) -> Self {
        PpkBench {
            rover_epochs: r.result.rover_epochs,
            passes: usize::from(r.result.forward.is_some())
                + usize::from(r.result.backward.is_some()),
            read_s: r.read_seconds,
            process_s: r.process_seconds,
            peak_rss_kib: peak_rss_kib(),
        }
    }
}

impl std::fmt::Display for PpkBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "bench ppk: {} rover epochs, {} pass(es): inputs read in {:.3} s, engine {:.3} s = {:.3} ms per rover epoch",
            self.rover_epochs,
            self.passes,
            self.read_s,
            self.process_s,
            1000.0 * self.process_s / self.rover_epochs.max(1) as f64
        )?;
        writeln!(f, "peak RSS: {}", mib(self.peak_rss_kib))
    }
}

/// Simulate a block of `strips` × `per_strip` photos into `dir` and adjust it.
pub fn adjust(
    strips: usize,
    per_strip: usize,
    dir: &Path,
    opts: &crate::adjust::RunOptions,
) -> std::result::Result<AdjustBench, crate::adjust::AdjustError> {
    let t0 = std::time::Instant::now();
    let mut spec = crate::simulate::block::BlockSpec::large(strips, per_strip);
    spec.project_options = crate::simulate::block::gnss_section(&spec, [0.0; 3], "strip", "offset");
    crate::simulate::block::aerial(&spec, dir)
        .map_err(|e| crate::adjust::AdjustError::Problem(e.to_string()))?;
    let simulate_s = t0.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    let r = crate::adjust::run(&dir.join("project.toml"), &dir.join("out"), opts)?;
    let mut stages: Vec<(&'static str, usize, f64)> = Vec::new();
    for t in &r.timings {
        match stages.iter_mut().find(|s| s.0 == t.what) {
            Some(s) => (s.1, s.2) = (s.1 + 1, s.2 + t.seconds),
            None => stages.push((t.what, 1, t.seconds)),
        }
    }
    Ok(AdjustBench {
        images: r.images.len(),
        points: r.points.len(),
        observations: r.observations,
        unknowns: r.unknowns,
        simulate_s,
        adjust_s: t1.elapsed().as_secs_f64(),
        sigma0: r.sigma0,
        peak_rss_kib: peak_rss_kib(),
        stages,
    })
}
