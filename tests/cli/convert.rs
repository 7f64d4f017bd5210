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
    // BeiDou B1C (sigId 5) is written as 1P (RINEX 3.04), not dropped as convbin does.
    assert!(!t.contains("no RINEX 3 slot"), "{t}");
    assert!(t.contains("NAV-PVT ×299"), "{t}");
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
        "week,tow,edge,count,valid\n"
    );
    let i = succeeds(&ppkat(&["info", p(&out)]));
    assert!(i.contains("299"), "{i}");
    assert!(i.contains("C1P L1P D1P S1P"), "{i}");
}

#[test]
fn rinex_given_as_a_raw_log_is_refused() {
    let f = fixture("events_v304.rnx");
    let out = tmp("never.obs");
    fails_with(
        &ppkat(&["convert", "--in", p(&f), "-o", p(&out)]),
        &["events_v304.rnx", "not a raw log"],
    );
    assert!(!out.exists());
    // Forced to UBX: no measurement epoch, said so.
    fails_with(
        &ppkat(&["convert", "--in", p(&f), "--format", "ubx", "-o", p(&out)]),
        &["events_v304.rnx", "RXM-RAWX"],
    );
    assert!(!out.exists());
}

#[test]
fn writes_the_ephemerides_of_the_navigation_subframes() {
    let Some(log) = shared("gnss/ubx-navsol-2025/16dBatt_no_interference_coldstart.ubx") else {
        return;
    };
    let (out, nav) = (tmp("cold.obs"), tmp("cold.nav"));
    let t = succeeds(&ppkat(&[
        "convert",
        "--in",
        p(&log),
        "-o",
        p(&out),
        "--nav",
        p(&nav),
    ]));
    assert!(
        t.contains("3843 navigation messages: 28 ephemerides"),
        "{t}"
    );
    assert!(t.contains("0 parity failures, 0 CRC failures"), "{t}");
    let text = std::fs::read_to_string(&nav).unwrap();
    assert!(text.starts_with("     3.04           N: GNSS NAV DATA    M: Mixed"));
    assert_eq!(text.lines().filter(|l| l.starts_with('G')).count(), 9);
    assert_eq!(text.lines().filter(|l| l.starts_with('E')).count(), 19);
    // A log without navigation subframes: --nav is refused and nothing is written.
    let Some(f9t) = shared("gnss/ubx-navsol-2025/F9T-L2-5min.ubx") else {
        return;
    };
    let (o2, n2) = (tmp("f9t-nonav.obs"), tmp("f9t.nav"));
    fails_with(
        &ppkat(&["convert", "--in", p(&f9t), "-o", p(&o2), "--nav", p(&n2)]),
        &["F9T-L2-5min.ubx", "no complete ephemeris", "RXM-SFRBX"],
    );
    assert!(!o2.exists() && !n2.exists());
}

#[test]
fn conversion_is_the_same_for_any_thread_count() {
    let Some(log) = shared("gnss/ubx-navsol-2025/16dBatt_no_interference_coldstart.ubx") else {
        return;
    };
    let outs: Vec<Vec<u8>> = ["1", "2", "5"]
        .iter()
        .map(|n| {
            let out = tmp(&format!("threads-{n}.obs"));
            succeeds(&ppkat(&[
                "--threads",
                n,
                "convert",
                "--in",
                p(&log),
                "-o",
                p(&out),
            ]));
            std::fs::read(&out).unwrap()
        })
        .collect();
    assert!(outs[0].len() > 100_000);
    assert!(outs.iter().all(|o| *o == outs[0]));
}
