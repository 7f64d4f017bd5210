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
    assert!(
        !out.join("broken").exists(),
        "no folder for a flight that never ran"
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
