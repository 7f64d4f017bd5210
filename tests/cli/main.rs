//! End-to-end tests of the `ppkat` binary, one integration-test binary with topic modules.
//!
//! Bad input gives a clear error naming the file (and the line where it applies) with exit
//! code 1, or a warning plus the usable data — never a panic (exit code 101); bad usage is
//! clap's exit code 2. Tests on real data read `../shared/data` beside the repository: they
//! skip with a message when it is absent, and fail on CI (`CI=true`), where it must be present.

mod adjust;
mod bal;
mod batch;
mod config;
mod convert;
mod exposures;
mod gnss;
mod help;
mod import;
mod info;
mod inputs;
mod ins;
mod kill;
mod lowcost;
mod outputs;
mod precise;
mod raw;
mod reliability;
mod slurm;
mod threads;
mod tiepoints;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Run the binary with `args`.
fn ppkat(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ppkat"))
        .args(args)
        .output()
        .expect("run ppkat")
}

/// Standard output followed by standard error.
fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Assert exit code 0; the output text.
fn succeeds(o: &Output) -> String {
    let t = text(o);
    assert_eq!(o.status.code(), Some(0), "expected success: {t}");
    t
}

/// Assert a clean failure (exit code 1) whose message contains every needle.
fn fails_with(o: &Output, needles: &[&str]) {
    let t = text(o);
    assert_eq!(
        o.status.code(),
        Some(1),
        "expected a clean failure, got {:?}: {t}",
        o.status
    );
    for n in needles {
        assert!(t.contains(n), "message lacks '{n}': {t}");
    }
}

/// A path in this test run's own scratch folder.
use testkit::scratch_path as tmp;

/// A file of the repository's `fixtures/`.
fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

/// A file of `../shared/data`, or `None` (with a "skipped" message) when it is absent;
/// panics on CI, where the data must be present.
use testkit::shared_data as shared;

/// Several files of `../shared/data` (see [`shared`]): all of them, or `None`.
fn shared_all<const N: usize>(rel: [&str; N]) -> Option<[PathBuf; N]> {
    let found = rel.map(shared);
    if found.iter().any(Option::is_none) {
        return None;
    }
    Some(found.map(Option::unwrap))
}

/// `match` options that reduce a few real photos to a run of seconds, for tests of what is not
/// the matching figure (messages, counts, outputs).
const QUICK_MATCH: [&str; 4] = ["--max-image-size", "800", "--max-features", "1000"];

/// The GEONET rover, base and navigation files of 2 April 2005 (120 rover epochs).
const GEONET_ROVER: &str = "gnss/geonet-2005/07590920.05o";
const GEONET_BASE: &str = "gnss/geonet-2005/30400920.05o";
const GEONET_NAV: &str = "gnss/geonet-2005/07590920.05n";

/// The GEONET base station's marker position, as the flag.
const GEONET_BASE_POS: &str = "--base-pos=-3978241.958,3382840.234,3649900.853";

/// The GEONET rover, base and navigation files, or `None` (skipped) without shared data.
fn geonet() -> Option<[PathBuf; 3]> {
    shared_all([GEONET_ROVER, GEONET_BASE, GEONET_NAV])
}

/// The files under `dir`, recursively, by their path inside it, sorted.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let path = e.unwrap().path();
            if path.is_dir() {
                todo.push(path);
            } else {
                out.push(path.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out.sort();
    out
}

/// The data rows of a `.pos` file (header lines start with '%'), split at blanks.
fn pos_rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('%'))
        .map(|l| l.split_whitespace().map(str::to_string).collect())
        .collect()
}

/// The folder of one `ppkat demo` run, made once and shared by the tests that only read it
/// (rover, base, navigation, trajectory, adjustment project).
fn demo_dir() -> &'static Path {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let d = tmp("shared-demo");
        succeeds(&ppkat(&["demo", "--out", p(&d)]));
        d
    })
}

/// Assert exit code 3 (finished, inputs skipped) and that standard error names every needle.
fn skips(o: &Output, needles: &[&str]) -> String {
    let t = text(o);
    assert_eq!(o.status.code(), Some(3), "expected exit code 3: {t}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("input(s) skipped"), "{err}");
    for n in needles {
        assert!(err.contains(n), "stderr lacks '{n}': {err}");
    }
    t
}

/// The arguments of `ppkat ppk` of `rover` against `base` with the navigation files and
/// `extra` flags into `out`.
fn ppk_args<'a>(
    rover: &'a Path,
    base: &'a Path,
    nav: &[&'a Path],
    out: &'a Path,
    extra: &[&'a str],
) -> Vec<&'a str> {
    let mut args = vec!["ppk", "--rover", p(rover), "--base", p(base)];
    for n in nav {
        args.extend(["--nav", p(n)]);
    }
    args.extend(["-o", p(out)]);
    args.extend_from_slice(extra);
    args
}

/// `ppkat spp` of `obs` with the navigation file `nav` in `format` into `out`.
fn spp_to(obs: &Path, nav: &Path, format: &str, out: &Path) -> Output {
    ppkat(&[
        "spp",
        "--obs",
        p(obs),
        "--nav",
        p(nav),
        "--format",
        format,
        "-o",
        p(out),
    ])
}

/// Column `name` of a CSV written by `ppkat adjust` (comment lines skipped).
fn column(path: &Path, name: &str) -> Vec<String> {
    let t = std::fs::read_to_string(path).unwrap();
    let mut rows = t.lines().filter(|l| !l.starts_with('#'));
    let head: Vec<&str> = rows.next().unwrap().split(',').collect();
    let c = head.iter().position(|h| *h == name).unwrap();
    rows.map(|r| r.split(',').nth(c).unwrap().to_string())
        .collect()
}

/// The base position `simulate` prints ("base: … at X Y Z (ECEF)"), as `X,Y,Z`.
fn simulated_base_xyz(t: &str) -> String {
    t.lines()
        .find_map(|l| l.trim().strip_prefix("base:"))
        .and_then(|l| l.split(" at ").nth(1))
        .map(|l| l.split_whitespace().take(3).collect::<Vec<_>>().join(","))
        .unwrap_or_else(|| panic!("no base position in\n{t}"))
}

/// The rows of a `--format xyz` `.pos` (as [`pos_rows`] gives them) from GPST second of the
/// day `from` on, against the simulator's `truth_trajectory.csv` in `dir`: how many were
/// compared, how many of them are fixed, and the worst fixed one's 3D error (m).
fn against_sim_truth(dir: &Path, rows: &[Vec<String>], from: f64) -> (usize, usize, f64) {
    let truth = sim_truth(&dir.join("truth_trajectory.csv"));
    let (mut compared, mut fixed, mut worst) = (0, 0, 0.0f64);
    for r in rows {
        let time = seconds_of_day(&r[1]);
        if time < from {
            continue;
        }
        let x = [2, 3, 4].map(|k| r[k].parse::<f64>().unwrap());
        let k = truth.partition_point(|(s, _)| *s < time - 1e-3);
        let (s, y) = truth[k.min(truth.len() - 1)];
        assert!((s - time).abs() < 1e-3, "{} has no truth", r[1]);
        let d = (0..3).map(|i| (x[i] - y[i]).powi(2)).sum::<f64>().sqrt();
        compared += 1;
        if r[5] == "1" {
            fixed += 1;
            worst = worst.max(d);
        }
    }
    (compared, fixed, worst)
}

/// The simulator's `truth_trajectory.csv`: (GPST seconds of the day, ECEF antenna position),
/// in time order.
fn sim_truth(path: &Path) -> Vec<(f64, [f64; 3])> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[1] % 86_400.0, [v[2], v[3], v[4]])
        })
        .collect()
}

/// Seconds of the day of a `.pos` time column (`hh:mm:ss.ssssss`).
fn seconds_of_day(hms: &str) -> f64 {
    hms.split(':')
        .map(|x| x.parse::<f64>().unwrap())
        .fold(0.0, |acc, x| acc * 60.0 + x)
}

/// The number that follows `marker` in `line` (up to the next space).
fn number_after(line: &str, marker: &str) -> f64 {
    let rest = line
        .split(marker)
        .nth(1)
        .unwrap_or_else(|| panic!("no '{marker}' in {line}"));
    let word = rest.split(' ').next().unwrap_or_default();
    word.parse()
        .unwrap_or_else(|_| panic!("'{word}' after '{marker}' is not a number in {line}"))
}

/// A path as a command-line argument.
fn p(x: &Path) -> &str {
    x.to_str().unwrap()
}
