//! End-to-end tests of the `ppkat` binary: bad input gives a clear error naming the file (and
//! the line where it applies) with exit code 1, or a warning plus the usable data — never a
//! panic (exit code 101).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn ppkat(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ppkat"))
        .args(args)
        .output()
        .expect("run ppkat")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ppkat-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

fn shared(rel: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(rel);
    if p.exists() {
        return Some(p);
    }
    assert!(
        std::env::var("CI").map(|v| v != "true").unwrap_or(true),
        "{} missing on CI",
        p.display()
    );
    eprintln!("skipped: {} not found (shared data absent)", p.display());
    None
}

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

fn p(x: &Path) -> &str {
    x.to_str().unwrap()
}

#[test]
fn empty_file() {
    let f = tmp("empty.obs");
    std::fs::write(&f, "").unwrap();
    fails_with(&ppkat(&["info", p(&f)]), &["empty.obs", "empty"]);
}

#[test]
fn missing_file() {
    let f = tmp("does-not-exist.obs");
    fails_with(
        &ppkat(&["info", p(&f)]),
        &["does-not-exist.obs", "cannot read"],
    );
}

#[test]
fn navigation_file_given_as_observations() {
    let Some(nav) = shared("gnss/geonet-2005/07590920.05n") else {
        return;
    };
    fails_with(
        &ppkat(&["info", p(&nav)]),
        &["07590920.05n", "navigation file", "--nav"],
    );
}

#[test]
fn unknown_rinex_version() {
    let src = std::fs::read_to_string(fixture("events_v304.rnx")).unwrap();
    let f = tmp("v9.obs");
    std::fs::write(&f, src.replacen("     3.04", "     9.01", 1)).unwrap();
    fails_with(
        &ppkat(&["info", p(&f)]),
        &["v9.obs", "version 9.01", "not supported"],
    );
}

#[test]
fn truncated_last_epoch_keeps_the_data() {
    let src = std::fs::read_to_string(fixture("events_v304.rnx")).unwrap();
    // Cut the file inside the last epoch, after its first satellite record.
    let cut = src.trim_end().rfind('\n').unwrap();
    let f = tmp("truncated.obs");
    std::fs::write(&f, &src[..cut]).unwrap();
    let o = ppkat(&["info", p(&f)]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(
        t.contains("truncated") && t.contains("1 of 2 satellites"),
        "{t}"
    );
    assert!(
        t.lines()
            .any(|l| l.starts_with("epochs") && l.trim_end().ends_with('3')),
        "{t}"
    );
}

#[test]
fn garbage_line_mid_file_is_skipped_with_its_line_number() {
    let src = std::fs::read_to_string(fixture("events_v304.rnx")).unwrap();
    let mut lines: Vec<&str> = src.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.starts_with("> 2024 03 10 12 00 01.0000000"))
        .unwrap();
    lines.insert(at, "#### this line is garbage ####");
    let f = tmp("garbage.obs");
    std::fs::write(&f, lines.join("\n") + "\n").unwrap();
    let o = ppkat(&["info", p(&f)]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(
        t.contains(&format!("line {}", at + 1)) && t.contains("garbage"),
        "{t}"
    );
    assert!(
        t.lines()
            .any(|l| l.starts_with("epochs") && l.trim_end().ends_with('3')),
        "{t}"
    );
}

#[test]
fn garbage_number_drops_only_that_satellite() {
    let src = std::fs::read_to_string(fixture("events_v211.rnx")).unwrap();
    let f = tmp("badnumber.obs");
    std::fs::write(&f, src.replacen("21000100.123", "21000X00.123", 1)).unwrap();
    let o = ppkat(&["info", p(&f)]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("G05 dropped from this epoch"), "{t}");
}

#[test]
fn observations_and_navigation_without_time_overlap() {
    let (Some(obs), Some(nav)) = (
        shared("gnss/geonet-2005/07590920.05o"),
        shared("gnss/esbc-2020-177/ESBC00DNK_R_20201770000_01D_MN.rnx.gz"),
    ) else {
        return;
    };
    let out = tmp("nooverlap.pos");
    let o = ppkat(&["spp", "--obs", p(&obs), "--nav", p(&nav), "-o", p(&out)]);
    fails_with(
        &o,
        &[
            "07590920.05o",
            "do not overlap",
            "ESBC00DNK_R_20201770000_01D_MN.rnx.gz",
        ],
    );
    assert!(!out.exists(), "no output on failure");
}

#[test]
fn spp_writes_an_rtklib_pos_file() {
    let (Some(obs), Some(nav)) = (
        shared("gnss/geonet-2005/07590920.05o"),
        shared("gnss/geonet-2005/07590920.05n"),
    ) else {
        return;
    };
    for (fmt, cols) in [("llh", "latitude(deg)"), ("xyz", "x-ecef(m)")] {
        let out = tmp(&format!("geonet-{fmt}.pos"));
        let o = ppkat(&[
            "spp",
            "--obs",
            p(&obs),
            "--nav",
            p(&nav),
            "--format",
            fmt,
            "-o",
            p(&out),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let pos = std::fs::read_to_string(&out).unwrap();
        assert!(pos.lines().any(|l| l.starts_with('%') && l.contains(cols)));
        let data: Vec<&str> = pos.lines().filter(|l| !l.starts_with('%')).collect();
        assert!(data.len() >= 110);
        // yyyy/mm/dd hh:mm:ss.sss  a b c  Q ns sdn sde sdu sdne sdeu sdun age ratio
        let f: Vec<&str> = data[0].split_whitespace().collect();
        assert_eq!(f.len(), 15, "{}", data[0]);
        assert_eq!(f[0], "2005/04/02");
        assert_eq!(f[5], "5", "Q = 5 for single point");
        if fmt == "llh" {
            let lat: f64 = f[2].parse().unwrap();
            assert!((lat - 35.1608).abs() < 1e-3);
        }
    }
}

/// The GEONET rover, base and navigation files, or `None` (skipped) without shared data.
fn geonet() -> Option<(PathBuf, PathBuf, PathBuf)> {
    Some((
        shared("gnss/geonet-2005/07590920.05o")?,
        shared("gnss/geonet-2005/30400920.05o")?,
        shared("gnss/geonet-2005/07590920.05n")?,
    ))
}

const GEONET_BASE_POS: &str = "--base-pos=-3978241.958,3382840.234,3649900.853";

#[test]
fn ppk_geonet_writes_fixed_solutions_with_quality_columns() {
    let Some((rover, base, nav)) = geonet() else {
        return;
    };
    let out = tmp("geonet-ppk.pos");
    let o = ppkat(&[
        "ppk",
        "--rover",
        p(&rover),
        "--base",
        p(&base),
        "--nav",
        p(&nav),
        GEONET_BASE_POS,
        "-o",
        p(&out),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("115 fixed (100.0 % of solved)"), "{t}");
    assert!(
        t.contains("no single-point solution"),
        "unsolved epochs say why: {t}"
    );
    let pos = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<&str>> = pos
        .lines()
        .filter(|l| !l.starts_with('%'))
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert_eq!(rows.len(), 115);
    for r in &rows {
        assert_eq!(r[5], "1", "Q = 1 fixed");
        let sdu: f64 = r[9].parse().unwrap();
        assert!(sdu > 0.001 && sdu < 0.1, "a real vertical sigma: {sdu}");
        let ratio: f64 = r[14].parse().unwrap();
        assert!(ratio >= 3.0);
    }
}

#[test]
fn ppk_without_common_epochs() {
    let (Some(rover), Some(base), Some(nav)) = (
        shared("gnss/geonet-2005/07590920.05o"),
        shared("gnss/spirent-rose-2023/Base-static_MO_Spirent.obs"),
        shared("gnss/geonet-2005/07590920.05n"),
    ) else {
        return;
    };
    let out = tmp("nocommon.pos");
    let o = ppkat(&[
        "ppk",
        "--rover",
        p(&rover),
        "--base",
        p(&base),
        "--nav",
        p(&nav),
        GEONET_BASE_POS,
        "-o",
        p(&out),
    ]);
    fails_with(
        &o,
        &[
            "07590920.05o",
            "Base-static_MO_Spirent.obs",
            "no rover epoch has a base epoch",
        ],
    );
}

#[test]
fn ppk_rover_without_phase() {
    let src = std::fs::read_to_string(fixture("events_v304.rnx")).unwrap();
    let f = tmp("codeonly.obs");
    std::fs::write(
        &f,
        src.replace("G    4 C1C L1C C2W L2W", "G    4 C1C D1C C2W D2W")
            .replace("E    2 C1C L1C", "E    2 C1C D1C"),
    )
    .unwrap();
    let base = fixture("events_v304.rnx");
    let out = tmp("codeonly.pos");
    let o = ppkat(&[
        "ppk",
        "--rover",
        p(&f),
        "--base",
        p(&base),
        "--nav",
        p(&base),
        "-o",
        p(&out),
    ]);
    fails_with(&o, &["codeonly.obs", "no carrier-phase"]);
}

#[test]
fn ppk_without_any_base_position() {
    let Some((rover, base, nav)) = geonet() else {
        return;
    };
    let src = std::fs::read_to_string(&base).unwrap();
    let nopos: String = src
        .lines()
        .filter(|l| !l.contains("APPROX POSITION XYZ"))
        .map(|l| format!("{l}\n"))
        .collect();
    let f = tmp("base-nopos.05o");
    std::fs::write(&f, nopos).unwrap();
    let out = tmp("nopos.pos");
    let o = ppkat(&[
        "ppk",
        "--rover",
        p(&rover),
        "--base",
        p(&f),
        "--nav",
        p(&nav),
        "-o",
        p(&out),
    ]);
    fails_with(&o, &["base-nopos.05o", "--base-pos", "--base-llh"]);
    // With the header position only: solved, with a loud warning.
    let o = ppkat(&[
        "ppk",
        "--rover",
        p(&rover),
        "--base",
        p(&base),
        "--nav",
        p(&nav),
        "-o",
        p(&out),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("BASE POSITION TAKEN FROM THE HEADER"), "{t}");
}

#[test]
fn ppk_navigation_not_covering_the_span() {
    let (Some(rover), Some(base), Some(nav)) = (
        shared("gnss/geonet-2005/07590920.05o"),
        shared("gnss/geonet-2005/30400920.05o"),
        shared("gnss/cssrlib-2021-265/SEPT2650.21P"),
    ) else {
        return;
    };
    let out = tmp("navspan.pos");
    let o = ppkat(&[
        "ppk",
        "--rover",
        p(&rover),
        "--base",
        p(&base),
        "--nav",
        p(&nav),
        GEONET_BASE_POS,
        "-o",
        p(&out),
    ]);
    fails_with(&o, &["07590920.05o", "do not overlap", "SEPT2650.21P"]);
}

/// A 1 Hz rover against a 30 s base (the base file decimated): every rover epoch is solved
/// against the nearest base epoch within 30 s, and the age of that base epoch is reported.
#[test]
fn ppk_high_rate_rover_against_a_30_s_base() {
    let (Some(rover), Some(base), Some(gn), Some(en)) = (
        shared("gnss/spirent-rose-2023/Rover-static-2km-east_MO_Spirent.obs"),
        shared("gnss/spirent-rose-2023/Base-static_MO_Spirent.obs"),
        shared("gnss/spirent-rose-2023/RINEX_GN_Spirent.23N"),
        shared("gnss/spirent-rose-2023/RINEX_EN_Spirent.23L"),
    ) else {
        return;
    };
    let src = std::fs::read_to_string(&base).unwrap();
    let mut keep = true;
    let mut dec = String::new();
    for l in src.lines() {
        if l.starts_with('>') {
            let sec: f64 = l[18..29].trim().parse().unwrap();
            keep = sec == 0.0 || sec == 30.0;
        }
        if keep {
            dec.push_str(l);
            dec.push('\n');
        }
    }
    let b30 = tmp("base-30s.obs");
    std::fs::write(&b30, dec).unwrap();
    let out = tmp("rate.pos");
    let o = ppkat(&[
        "ppk",
        "--rover",
        p(&rover),
        "--base",
        p(&b30),
        "--nav",
        p(&gn),
        "--nav",
        p(&en),
        "--base-pos=4157177.06580187,671230.476590636,4774767.03105544",
        "--format",
        "xyz",
        "-o",
        p(&out),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    let rows: Vec<Vec<f64>> = std::fs::read_to_string(&out)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('%'))
        .map(|l| {
            l.split_whitespace()
                .skip(2)
                .map(|x| x.parse().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 601, "{t}");
    let max_age = rows.iter().map(|r| r[11].abs()).fold(0.0, f64::max);
    assert!(
        (14.0..=15.0).contains(&max_age),
        "age of the base epoch reported: {max_age}"
    );
    let truth = [4156857.1195929, 673209.028774142, 4774767.03105544];
    let fixed: Vec<&Vec<f64>> = rows.iter().filter(|r| r[3] == 1.0).collect();
    assert!(
        fixed.len() as f64 >= 0.95 * rows.len() as f64,
        "{} fixed",
        fixed.len()
    );
    let worst = fixed
        .iter()
        .map(|r| {
            ((r[0] - truth[0]).powi(2) + (r[1] - truth[1]).powi(2) + (r[2] - truth[2]).powi(2))
                .sqrt()
        })
        .fold(0.0, f64::max);
    assert!(worst < 0.02, "worst fixed error with a 30 s base: {worst}");
}

/// With an ANTEX calibration putting the rover's phase centre 10 cm above its reference point,
/// the reported rover (reference point) is 10 cm lower than without it.
#[test]
fn ppk_applies_antex_phase_centre_offsets() {
    let Some((rover, base, nav)) = geonet() else {
        return;
    };
    let src = std::fs::read_to_string(&rover).unwrap();
    let renamed = src.replacen("TRM29659.00         ", "PPKATTEST           ", 1);
    assert_ne!(src, renamed);
    let r2 = tmp("rover-testant.05o");
    std::fs::write(&r2, renamed).unwrap();
    let heights = |extra: &[&str]| -> Vec<f64> {
        let out = tmp(&format!("antex-{}.pos", extra.len()));
        let mut args = vec![
            "ppk",
            "--rover",
            p(&r2),
            "--base",
            p(&base),
            "--nav",
            p(&nav),
            GEONET_BASE_POS,
            "-o",
            p(&out),
        ];
        args.extend_from_slice(extra);
        let o = ppkat(&args);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        std::fs::read_to_string(&out)
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('%'))
            .map(|l| l.split_whitespace().nth(4).unwrap().parse().unwrap())
            .collect()
    };
    let atx = fixture("test.atx");
    let without = heights(&[]);
    let with = heights(&["--antex", p(&atx)]);
    assert_eq!(without.len(), with.len());
    for (a, b) in without.iter().zip(&with) {
        assert!((a - b - 0.10).abs() < 0.003, "height change {}", a - b);
    }
}

#[test]
fn demo_runs_the_chain_and_reports_accuracy() {
    let out = tmp("demo");
    let o = ppkat(&["demo", "--out", p(&out)]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    // "carrier phase: N epochs, M fixed (P %), fixed 3D RMS X mm, worst Y mm vs truth"
    let line = t
        .lines()
        .find(|l| l.starts_with("carrier phase:"))
        .expect("a carrier-phase line");
    let pct: f64 = line
        .split('(')
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let rms: f64 = line
        .split("3D RMS ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(pct >= 99.0 && rms <= 20.0, "{line}");
    for f in [
        "rover.obs",
        "base.obs",
        "nav.rnx",
        "truth_trajectory.csv",
        "truth_exposures.csv",
        "image_observations.csv",
        "rover_ppk.pos",
        "antennas.csv",
        "project.toml",
        "adjust/report.html",
        "adjust/report.json",
        "adjust/orientations.csv",
        "adjust/points.csv",
    ] {
        assert!(out.join(f).exists(), "{f} written");
    }
    // "check points: N, RMS E/N/U a b c m (theoretical d e f m)": the demo's adjustment is
    // as good as its own precision says (6 check points: within 2×).
    let line = t
        .lines()
        .find(|l| l.starts_with("check points:"))
        .expect("a check-point line");
    let nums: Vec<f64> = line
        .replace(['(', ')', ','], " ")
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    assert_eq!(nums.len(), 7, "{line}");
    for a in 0..3 {
        assert!(nums[1 + a] < 2.0 * nums[4 + a] + 0.01, "{line}");
    }
}

/// A simulated project through `ppkat adjust`: outputs, summary, and a broken project.
#[test]
fn adjust_a_simulated_block_end_to_end() {
    let dir = tmp("adjust-classic");
    let o = ppkat(&["simulate", "--builtin", "classic-block", "--out", p(&dir)]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("29 images"), "{}", text(&o));
    let out = dir.join("out");
    let o = ppkat(&[
        "adjust",
        "--project",
        p(&dir.join("project.toml")),
        "-o",
        p(&out),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(
        t.contains("29 images") && t.contains("lever arm (cam)") && t.contains("check points:"),
        "{t}"
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 4, "four plots");
    let json = std::fs::read_to_string(out.join("report.json")).unwrap();
    assert!(json.contains("\"checks\"") && json.contains("\"removed\""));
    let orient = std::fs::read_to_string(out.join("orientations.csv")).unwrap();
    assert_eq!(orient.lines().filter(|l| !l.starts_with('#')).count(), 30);
    // The same bits on one thread.
    let one = dir.join("out-1");
    let o = Command::new(env!("CARGO_BIN_EXE_ppkat"))
        .args([
            "adjust",
            "--project",
            p(&dir.join("project.toml")),
            "-o",
            p(&one),
        ])
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0));
    for f in ["report.json", "orientations.csv", "points.csv"] {
        assert_eq!(
            std::fs::read(out.join(f)).unwrap(),
            std::fs::read(one.join(f)).unwrap(),
            "{f} differs on one thread"
        );
    }
    // A project naming a missing table: the file is named, no outputs.
    let bad = dir.join("bad.toml");
    let src = std::fs::read_to_string(dir.join("project.toml")).unwrap();
    std::fs::write(&bad, src.replace("antennas.csv", "nosuch.csv")).unwrap();
    let o = ppkat(&["adjust", "--project", p(&bad), "-o", p(&dir.join("out2"))]);
    fails_with(&o, &["nosuch.csv", "cannot read"]);
    assert!(!dir.join("out2/report.json").exists());
}

#[test]
fn simulate_rejects_a_bad_scenario_naming_the_key() {
    let src = std::fs::read_to_string(fixture("scenario_small.toml")).unwrap();
    let f = tmp("bad-scenario.toml");
    std::fs::write(&f, src.replace("speed = 55.0", "speed = -55.0")).unwrap();
    let o = ppkat(&["simulate", "--scenario", p(&f), "--out", p(&tmp("bad-sim"))]);
    fails_with(&o, &["bad-scenario.toml", "flight.speed"]);
    let o = ppkat(&[
        "simulate",
        "--builtin",
        "nosuch",
        "--out",
        p(&tmp("bad-sim2")),
    ]);
    fails_with(&o, &["nosuch", "demo", "classic-block"]);
}

#[test]
fn leverarm_from_tapes() {
    let o = ppkat(&[
        "leverarm",
        "--tapes",
        "1.840674,1.868176,2.087123,0.904479",
        "--ruler",
        "1.0",
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("0.4490 0.0160 1.7850"), "{t}");
    let o = ppkat(&["leverarm", "--tapes", "1.0,0.5,0.5", "--ruler", "1.0"]);
    fails_with(&o, &["--tapes", "four lengths"]);
}

/// The demo's rover events on its PPK trajectory, in every export format; the report says
/// where the ambiguity segments came from.
#[test]
fn exposures_in_every_format() {
    let dir = tmp("exp-formats");
    let o = ppkat(&["demo", "--out", p(&dir)]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let traj = dir.join("rover_ppk.pos");
    let rover = dir.join("rover.obs");
    for (fmt, needle) in [
        ("csv", "id,week,tow,lat,lon"),
        ("metashape", "#label,longitude"),
        ("pix4d", "imagename,latitude"),
        ("odm", "EPSG:4326"),
        ("pos", "latitude(deg)"),
        (
            "antenna",
            "id,week,tow,lat,lon,h,c_ee,c_en,c_eu,c_nn,c_nu,c_uu,quality,segment",
        ),
    ] {
        let out = dir.join(format!("stations.{fmt}"));
        let o = ppkat(&[
            "exposures",
            "--trajectory",
            p(&traj),
            "--events",
            p(&rover),
            "--lever-arm",
            "0.10,-0.05,0.45",
            "--format",
            fmt,
            "-o",
            p(&out),
        ]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(0), "{t}");
        assert!(
            t.contains("camera stations written") && t.contains("heading"),
            "{t}"
        );
        // A .pos carries no ambiguity segments: the report says they were derived.
        assert!(
            t.contains("note: ambiguity segments derived from Q changes and gaps of")
                && t.contains("rover_ppk.pos"),
            "{t}"
        );
        let body = std::fs::read_to_string(&out).unwrap();
        assert!(
            body.contains(needle),
            "{fmt}: {}",
            &body[..body.len().min(300)]
        );
        assert!(body.lines().count() > 100, "{fmt}");
    }
    let out = dir.join("stations-utm.csv");
    let o = ppkat(&[
        "exposures",
        "--trajectory",
        p(&traj),
        "--events",
        p(&rover),
        "--projection",
        "utm",
        "-o",
        p(&out),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let body = std::fs::read_to_string(&out).unwrap();
    assert!(
        body.contains("UTM zone 32N") && body.contains("easting,northing"),
        "{}",
        &body[..300]
    );
    // An observation file without events is refused by name.
    let o = ppkat(&[
        "exposures",
        "--trajectory",
        p(&traj),
        "--events",
        p(&dir.join("base.obs")),
        "-o",
        p(&dir.join("x.csv")),
    ]);
    fails_with(&o, &["base.obs", "no flag-5 event"]);
}
