//! Outputs people and other tools read: the PPK quality report (HTML).

use super::*;

/// `ppk --report`: a self-contained page with its plots and the fix-rate table of the run.
#[test]
fn ppk_report_is_written_with_its_plots() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let (out, html) = (tmp("report-ppk.pos"), tmp("report-ppk.html"));
    let t = succeeds(&ppkat(&[
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
        "--report",
        p(&html),
    ]));
    assert!(
        t.contains("report → ") && t.contains("report-ppk.html"),
        "{t}"
    );
    let page = std::fs::read_to_string(&html).unwrap();
    // Ground track, satellites, ratio, σ E/N/U, age.
    assert_eq!(page.matches("<svg").count(), 5, "five plots");
    for needle in [
        "Ground track",
        "Satellites used",
        "Ambiguity ratio test",
        "Standard deviations",
        "Age of the base observations",
        "Ambiguity segments",
        "<td class=\"l\">fixed (Q=1)</td><td>120</td><td>100.0</td>",
        "<th class=\"l\">rover epochs</th><th>120</th>",
        "<th class=\"l\">elev mask</th><td class=\"l\">10.0 deg</td>",
    ] {
        assert!(page.contains(needle), "report lacks {needle}");
    }
    // Self-contained: nothing is fetched.
    assert!(!page.contains("<script") && !page.contains("src=\"http") && !page.contains("<link"));
}
