//! `ppkat batch`: a folder of flights — a simulated one with events, GEONET with a
//! `ppk.toml`, a broken one — gives each flight the outputs of `ppk` and `exposures` run alone,
//! a summary table, and exit code 3 naming the flight that failed; `--jobs` changes no byte.

use super::*;

/// The rows of a CSV (header left out), split at commas outside quotes is not needed: the
/// columns asserted come before the quoted message.
fn rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// A folder of three flights: `sim` (simulated, events in the rover RINEX), `geonet` (real
/// data linked in, base position in ppk.toml) and `broken` (no base file).
fn flights(root: &Path, rover: &Path, base: &Path, nav: &Path) -> PathBuf {
    let _ = std::fs::remove_dir_all(root);
    let input = root.join("in");
    let sim = input.join("sim");
    succeeds(&ppkat(&[
        "simulate",
        "--scenario",
        p(&fixture("scenario_small.toml")),
        "-o",
        p(&sim),
    ]));
    for extra in ["ground_points.csv", "image_observations.csv", "camera.toml"] {
        let _ = std::fs::remove_file(sim.join(extra));
    }
    let g = input.join("geonet");
    std::fs::create_dir_all(&g).unwrap();
    for (from, to) in [(rover, "rover.05o"), (base, "base.05o"), (nav, "brdc.05n")] {
        std::fs::copy(from, g.join(to)).unwrap();
    }
    std::fs::write(
        g.join("ppk.toml"),
        "base-pos = [-3978241.958, 3382840.234, 3649900.853]\n",
    )
    .unwrap();
    let b = input.join("broken");
    std::fs::create_dir_all(&b).unwrap();
    std::fs::copy(sim.join("rover.obs"), b.join("rover.obs")).unwrap();
    input
}

#[test]
fn a_folder_of_flights_gives_each_flights_outputs_and_a_summary() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let root = tmp("batch");
    let input = flights(&root, &rover, &base, &nav);
    let out = root.join("out");
    let o = ppkat(&["batch", p(&input), "-o", p(&out), "--jobs", "2"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(3), "a failed flight is named: {t}");
    assert!(
        t.contains("flight broken: FAILED") && t.contains("no base observations"),
        "{t}"
    );
    let r = rows(&out.join("summary.csv"));
    assert_eq!(r.len(), 3, "{r:?}");
    assert_eq!(r[0][..2], ["broken", "FAILED"]);
    let left: Vec<_> = std::fs::read_dir(out.join("broken"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        left,
        ["result.json"],
        "a flight that never ran has only its result (the error, for --merge and --status)"
    );
    // GEONET: all 120 epochs fixed, as `ppkat ppk` alone fixes them.
    assert_eq!(r[1][..6], ["geonet", "done", "120", "120", "120", "100.0"]);
    let sigma: f64 = r[1][6].parse().unwrap();
    assert!(sigma > 0.002 && sigma < 0.05, "a real σ: {sigma}");
    // The simulated flight: every exposure of the truth became a camera station, at the
    // true antenna (no lever arm given) within 3 cm.
    let truth = truth_antennas(&input.join("sim/truth_exposures.csv"));
    assert_eq!(r[2][..2], ["sim", "done"]);
    assert_eq!(r[2][7], truth.len().to_string(), "{r:?}");
    assert!(r[2][5].parse::<f64>().unwrap() > 99.0);
    let got = std::fs::read_to_string(out.join("sim/exposures.csv")).unwrap();
    let stations: Vec<[f64; 3]> = got
        .lines()
        .filter(|l| l.starts_with('E'))
        .map(|l| {
            let c: Vec<f64> = l
                .split(',')
                .skip(3)
                .take(3)
                .map(|v| v.parse().unwrap())
                .collect();
            ::gnss::frame::Geodetic::from_degrees(c[0], c[1], c[2])
                .to_ecef()
                .0
                .into()
        })
        .collect();
    assert_eq!(stations.len(), truth.len());
    for (s, t) in stations.iter().zip(&truth) {
        let d = (0..3).map(|i| (s[i] - t[i]).powi(2)).sum::<f64>().sqrt();
        assert!(d < 0.03, "station {d:.3} m from the true antenna");
    }

    // The same .pos as `ppkat ppk` run alone with the flags the flight's files stand for.
    let alone = root.join("alone.pos");
    let g = input.join("geonet");
    succeeds(&ppkat(&[
        "ppk",
        "--rover",
        p(&g.join("rover.05o")),
        "--base",
        p(&g.join("base.05o")),
        "--nav",
        p(&g.join("brdc.05n")),
        GEONET_BASE_POS,
        "-o",
        p(&alone),
    ]));
    let by_batch = std::fs::read(out.join("geonet/geonet.pos")).unwrap();
    assert_eq!(std::fs::read(&alone).unwrap(), by_batch);
    assert!(out.join("geonet/geonet.html").exists());
    assert!(out.join("sim/exposures.csv").exists());

    // One flight at a time: the same bytes.
    let out1 = root.join("out1");
    let o = ppkat(&["batch", p(&input), "-o", p(&out1), "--jobs", "1"]);
    assert_eq!(o.status.code(), Some(3));
    for f in [
        "summary.csv",
        "geonet/geonet.pos",
        "sim/sim.pos",
        "sim/exposures.csv",
    ] {
        assert_eq!(
            std::fs::read(out.join(f)).unwrap(),
            std::fs::read(out1.join(f)).unwrap(),
            "{f} differs between --jobs 2 and 1"
        );
    }
}

/// The true antenna positions (ECEF) of a simulator's truth_exposures.csv.
fn truth_antennas(path: &Path) -> Vec<[f64; 3]> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
        .map(|l| {
            let c: Vec<f64> = l
                .split(',')
                .skip(7)
                .take(3)
                .map(|v| v.parse().unwrap())
                .collect();
            [c[0], c[1], c[2]]
        })
        .collect()
}

#[test]
fn a_folder_without_flights_fails() {
    let d = tmp("batch-empty");
    std::fs::create_dir_all(d.join("notes")).unwrap();
    let o = ppkat(&["batch", p(&d), "-o", p(&tmp("batch-empty-out"))]);
    fails_with(&o, &["batch-empty", "no flight subfolders"]);
}

/// `--plan`, `--only-index`/`--only`, `--status` and `--merge` on a run where one flight is
/// done, one failed, one is running (its status file names a live process) and one never
/// started: each is said as it is, the merge names the ones without a result (exit 3) and
/// gives the same summary however often it runs.
#[test]
fn status_and_merge_name_failed_running_and_missing_tasks() {
    let root = tmp("batch-plan");
    let _ = std::fs::remove_dir_all(&root);
    let input = root.join("in");
    let a = input.join("a");
    succeeds(&ppkat(&[
        "simulate",
        "--scenario",
        p(&fixture("scenario_small.toml")),
        "-o",
        p(&a),
    ]));
    for extra in ["ground_points.csv", "image_observations.csv", "camera.toml"] {
        let _ = std::fs::remove_file(a.join(extra));
    }
    for (dir, files) in [
        ("b", &["rover.obs", "base.obs", "nav.rnx"][..]),
        ("c", &["rover.obs", "base.obs", "nav.rnx"]),
        ("broken", &["rover.obs"]),
    ] {
        std::fs::create_dir_all(input.join(dir)).unwrap();
        for f in files {
            std::fs::copy(a.join(f), input.join(dir).join(f)).unwrap();
        }
    }
    let out = root.join("out");
    let batch = |extra: &[&str]| {
        let mut args = vec!["batch", p(&input), "-o", p(&out)];
        args.extend_from_slice(extra);
        ppkat(&args)
    };
    let o = batch(&["--plan"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(3), "{t}");
    assert!(
        t.contains("4 flights, 3 can run, 1 cannot") && t.contains("flight broken"),
        "{t}"
    );
    let plan = std::fs::read_to_string(out.join("plan.tsv")).unwrap();
    let names: Vec<&str> = plan
        .lines()
        .skip(2)
        .map(|l| l.split('\t').nth(1).unwrap())
        .collect();
    assert_eq!(names, ["a", "b", "broken", "c"]);
    assert!(plan.contains("--only-index 3\t"), "{plan}");

    succeeds(&batch(&["--only-index", "0"]));
    fails_with(&batch(&["--only", "broken"]), &["flight broken", "no base"]);
    fails_with(
        &batch(&["--only-index", "9"]),
        &["the plan has flights 0 to 3"],
    );
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap();
    std::fs::write(
        out.join("status/b.json"),
        format!(
            "{{\"flight\":\"b\",\"index\":1,\"host\":\"{}\",\"pid\":{},\"started_unix_s\":1.0,\"finished_unix_s\":null,\"exit_code\":null,\"wall_s\":null,\"peak_rss_kib\":null}}",
            host.trim(),
            std::process::id()
        ),
    )
    .unwrap();
    let st = succeeds(&batch(&["--status"]));
    assert!(
        st.contains("4 flights: 1 done, 1 failed, 1 not started, 1 running"),
        "{st}"
    );
    assert!(
        st.contains("broken") && st.contains("no base"),
        "the failure's error: {st}"
    );

    let m = batch(&["--merge"]);
    let t = text(&m);
    assert_eq!(m.status.code(), Some(3), "{t}");
    for needle in [
        "flight b: NOT RUN",
        "flight c: NOT RUN: never ran",
        "flight broken: FAILED",
    ] {
        assert!(t.contains(needle), "{needle}: {t}");
    }
    let first = std::fs::read(out.join("summary.csv")).unwrap();
    let m2 = batch(&["--merge"]);
    assert_eq!(m2.status.code(), Some(3));
    assert_eq!(
        first,
        std::fs::read(out.join("summary.csv")).unwrap(),
        "merged twice alike"
    );
    let r = rows(&out.join("summary.csv"));
    assert_eq!(r.len(), 4, "a row per flight, none twice");
    assert_eq!((r[0][1].as_str(), r[3][1].as_str()), ("done", "NOT RUN"));

    // The missing task run, the merge again: only the broken flight is left.
    succeeds(&batch(&["--only-index", "3"]));
    let t = text(&batch(&["--merge"]));
    assert!(
        t.contains("flight c") && !t.contains("flight c: NOT RUN"),
        "{t}"
    );
    assert_eq!(rows(&out.join("summary.csv"))[3][1], "done");
}
