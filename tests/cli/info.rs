//! `ppkat info` on good and broken observation files: a clear error naming the file, or a
//! warning (with the line) plus the usable data.

use super::*;

/// The number on the summary's `epochs` line.
fn epochs(t: &str) -> Option<&str> {
    t.lines()
        .find(|l| l.starts_with("epochs"))
        .and_then(|l| l.split_whitespace().last())
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
    let Some(nav) = shared(GEONET_NAV) else {
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
    let t = succeeds(&ppkat(&["info", p(&f)]));
    assert!(
        t.contains("truncated") && t.contains("1 of 2 satellites"),
        "{t}"
    );
    assert_eq!(epochs(&t), Some("3"), "{t}");
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
    let t = succeeds(&ppkat(&["info", p(&f)]));
    assert!(
        t.contains(&format!("line {}", at + 1)) && t.contains("garbage"),
        "{t}"
    );
    assert_eq!(epochs(&t), Some("3"), "{t}");
}

#[test]
fn garbage_number_drops_only_that_satellite() {
    let src = std::fs::read_to_string(fixture("events_v211.rnx")).unwrap();
    let f = tmp("badnumber.obs");
    std::fs::write(&f, src.replacen("21000100.123", "21000X00.123", 1)).unwrap();
    let t = succeeds(&ppkat(&["info", p(&f)]));
    assert!(t.contains("G05 dropped from this epoch"), "{t}");
}
