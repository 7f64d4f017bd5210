//! `ppkat demo`, `ppkat simulate` and `ppkat adjust`: the whole chain against truth, a
//! simulated block end to end, and the same bits whatever `--threads`.

use super::*;

/// Simulate the built-in adjustment project `name` into `dir`.
fn simulate_project(name: &str, dir: &Path) -> String {
    succeeds(&ppkat(&["simulate", "--builtin", name, "-o", p(dir)]))
}

/// The numbers of a report line, parentheses and commas ignored.
pub(super) fn numbers(line: &str) -> Vec<f64> {
    line.replace(['(', ')', ','], " ")
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect()
}

#[test]
fn demo_runs_the_chain_and_reports_accuracy() {
    let out = tmp("demo");
    let t = succeeds(&ppkat(&["demo", "--out", p(&out)]));
    // "carrier phase: N epochs, M fixed (P %), fixed 3D RMS X mm, worst Y mm vs truth"
    let line = t
        .lines()
        .find(|l| l.starts_with("carrier phase:"))
        .expect("a carrier-phase line");
    let pct = number_after(line, "(");
    let rms = number_after(line, "3D RMS ");
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
    let nums = numbers(line);
    assert_eq!(nums.len(), 7, "{line}");
    for a in 0..3 {
        assert!(nums[1 + a] < 2.0 * nums[4 + a] + 0.01, "{line}");
    }
    // The GNSS datum is kept: fixed segments get no drift, so the adjusted centres stay as
    // close to truth as the GNSS centres (a free drift per segment once left them
    // 4.2/−2.3/−5.3 cm off on average; measured now 0.1/−0.3/−0.2 cm).
    let line = t
        .lines()
        .find(|l| l.starts_with("adjusted centres:"))
        .expect("an adjusted-centres line");
    let nums = numbers(line);
    assert!(nums[..3].iter().all(|m| m.abs() <= 0.01), "{line}");
    assert!(nums[3] <= 0.015, "{line}");
}

/// A simulated project through `ppkat adjust`: outputs, summary, and a broken project.
#[test]
fn adjust_a_simulated_block_end_to_end() {
    let dir = tmp("adjust-classic");
    let t = simulate_project("classic-block", &dir);
    assert!(t.contains("29 images"), "{t}");
    let out = dir.join("out");
    let project = dir.join("project.toml");
    let t = succeeds(&ppkat(&["adjust", "--project", p(&project), "-o", p(&out)]));
    assert!(
        t.contains("29 images") && t.contains("lever arm (cam)") && t.contains("check points:"),
        "{t}"
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 5, "five plots");
    let json = std::fs::read_to_string(out.join("report.json")).unwrap();
    assert!(json.contains("\"checks\"") && json.contains("\"removed\""));
    // Residuals: the pattern over the format, and the images as small multiples, the one
    // with the largest RMS first, captioned with the RMS the images table gives.
    assert!(html.contains("Image residuals: systematic pattern over the format"));
    assert!(html.contains("the 24 of 29 images with the largest RMS"));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let worst = v["images"]
        .as_array()
        .unwrap()
        .iter()
        .max_by(|a, b| {
            a["rms_px"]
                .as_f64()
                .unwrap()
                .total_cmp(&b["rms_px"].as_f64().unwrap())
        })
        .unwrap();
    let caption = format!(
        "{}: {:.2} px, {} pts",
        worst["id"].as_str().unwrap(),
        worst["rms_px"].as_f64().unwrap(),
        worst["points"]
    );
    let at = html
        .find(&caption)
        .expect("a panel captioned as the images table says");
    assert_eq!(
        html.find(" pts"),
        Some(at + caption.len() - 4),
        "the worst image first"
    );
    let orient = std::fs::read_to_string(out.join("orientations.csv")).unwrap();
    assert_eq!(orient.lines().filter(|l| !l.starts_with('#')).count(), 30);
    // A project naming a missing table: the file is named, no outputs.
    let bad = dir.join("bad.toml");
    let src = std::fs::read_to_string(&project).unwrap();
    std::fs::write(&bad, src.replace("antennas.csv", "nosuch.csv")).unwrap();
    let o = ppkat(&["adjust", "--project", p(&bad), "-o", p(&dir.join("out2"))]);
    fails_with(&o, &["nosuch.csv", "cannot read"]);
    assert!(!dir.join("out2/report.json").exists());
}

/// The textured block (reduced: 2 × 4 rendered photos of 400 × 300 px) adjusts with its
/// exact image measurements: every image and point in, nothing removed, check points given.
#[test]
fn adjust_the_textured_block_with_exact_points() {
    use integration::simulate::textured::{textured_block, TexturedSpec};
    let dir = tmp("textured");
    let rep = textured_block(&TexturedSpec::reduced(), &dir).unwrap();
    assert_eq!(rep.images, 8);
    let project = dir.join("project.toml");
    let t = succeeds(&ppkat(&[
        "adjust",
        "--project",
        p(&project),
        "-o",
        p(&dir.join("out")),
    ]));
    assert!(
        t.contains(&format!("8 images, {} points", rep.points))
            && t.contains("removed by data snooping: 0")
            && t.contains("check points: 4"),
        "{t}"
    );
}

/// `--threads` changes the speed, never the results: the classic block adjusted on one and
/// on two threads gives the same bytes in every output (the flag is global: before or after
/// the subcommand).
#[test]
fn adjust_gives_the_same_bytes_on_one_and_two_threads() {
    let dir = tmp("adjust-threads");
    simulate_project("classic-block", &dir);
    let project = dir.join("project.toml");
    let (one, two) = (dir.join("out-1"), dir.join("out-2"));
    succeeds(&ppkat(&[
        "--threads",
        "1",
        "adjust",
        "--project",
        p(&project),
        "-o",
        p(&one),
    ]));
    succeeds(&ppkat(&[
        "adjust",
        "--project",
        p(&project),
        "-o",
        p(&two),
        "--threads",
        "2",
    ]));
    for f in [
        "orientations.csv",
        "points.csv",
        "image_residuals.csv",
        "gnss_residuals.csv",
        "report.json",
    ] {
        assert_eq!(
            std::fs::read(one.join(f)).unwrap(),
            std::fs::read(two.join(f)).unwrap(),
            "{f} differs between 1 and 2 threads"
        );
    }
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

/// A block whose observations do not determine every image (`sparse-control`, and two of its
/// images that share one unknown point besides one control point each: each has 7
/// equations, together they are singular): the run finishes, names what it left out and
/// exits with 3; it used to abort "singular at the orientation of image 102".
#[test]
fn adjust_leaves_out_what_it_cannot_determine_and_exits_3() {
    let dir = tmp("adjust-sparse");
    let t = simulate_project("sparse-control", &dir);
    assert!(t.contains("290 images"), "{t}");
    let obs = dir.join("image_observations.csv");
    let mut text = std::fs::read_to_string(&obs).unwrap();
    text.push_str("101,T1,2700.0,4000.0,1\n102,T1,2600.0,3900.0,1\n");
    std::fs::write(&obs, text).unwrap();
    let project = dir.join("project.toml");
    let o = ppkat(&[
        "adjust",
        "--project",
        p(&project),
        "-o",
        p(&dir.join("out")),
    ]);
    let t = skips(
        &o,
        &[
            "209 input(s) skipped",
            "image 103: its observations give 5 equations",
        ],
    );
    for needle in [
        "image 102 is left out of the adjustment: its observations do not fix its unknowns together with the rest",
        "image 101 is left out of the adjustment: its observations give 5 equations",
        "point T1 is left out",
    ] {
        assert!(t.contains(needle), "{needle}: {t}");
    }
    assert!(t.contains("82 images"), "{t}");
}
