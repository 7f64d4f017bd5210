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
