//! `ppkat convert` on a real u-blox log (the RINEX it writes is read back by `info`) and on
//! files that are not UBX logs.

use super::*;

#[test]
fn converts_the_f9t_log_and_info_reads_it() {
    let Some(log) = shared("gnss/ubx-navsol-2025/F9T-L2-5min.ubx") else {
        return;
    };
    let (out, csv) = (tmp("f9t.obs"), tmp("f9t-events.csv"));
    let t = succeeds(&ppkat(&[
        "convert",
        "--in",
        p(&log),
        "-o",
        p(&out),
        "--events",
        p(&csv),
    ]));
    assert!(t.contains("299 observation epochs, 0 events"), "{t}");
    assert!(t.contains("0 checksum failures"), "{t}");
    assert!(
        t.contains("measurements dropped: C sigId 5 (no RINEX 3 slot) ×2533"),
        "{t}"
    );
    assert!(t.contains("NAV-PVT ×299"), "{t}");
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
        "week,tow,edge,count,valid\n"
    );
    let i = succeeds(&ppkat(&["info", p(&out)]));
    assert!(i.contains("299"), "{i}");
}

#[test]
fn rinex_given_as_a_raw_log_is_refused() {
    let f = fixture("events_v304.rnx");
    let out = tmp("never.obs");
    fails_with(
        &ppkat(&["convert", "--in", p(&f), "-o", p(&out)]),
        &["events_v304.rnx", "not a u-blox log"],
    );
    assert!(!out.exists());
    // Forced to UBX: no measurement epoch, said so.
    fails_with(
        &ppkat(&["convert", "--in", p(&f), "--format", "ubx", "-o", p(&out)]),
        &["events_v304.rnx", "no RXM-RAWX"],
    );
    assert!(!out.exists());
}
