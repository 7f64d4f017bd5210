//! u-blox logs given where RINEX observations are taken: `info`, `spp` and `ppk` tell the
//! format from the content (or take --obs-format), and `spp` uses the log's own ephemerides
//! when no navigation file is given.

use super::*;

const COLD: &str = "gnss/ubx-navsol-2025/16dBatt_no_interference_coldstart.ubx";
const COLD_NAV: &str = "gnss/ubx-navsol-2025/16dBatt_no_interference_coldstart.nav.gz";

/// The data lines of a .pos file.
fn pos_lines(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('%'))
        .map(String::from)
        .collect()
}

#[test]
fn info_describes_a_ubx_log() {
    let Some(log) = shared(COLD) else {
        return;
    };
    let t = succeeds(&ppkat(&["info", p(&log)]));
    assert!(t.contains("562"), "{t}");
    assert!(
        t.contains("3843 navigation messages: 28 ephemerides"),
        "{t}"
    );
    // Forced to RINEX, the log is refused with the reader's reason.
    fails_with(
        &ppkat(&["info", p(&log), "--obs-format", "rinex"]),
        &["coldstart.ubx", "RINEX VERSION / TYPE"],
    );
}

#[test]
fn spp_on_a_ubx_log_equals_spp_on_its_conversion() {
    let Some([log, nav]) = shared_all([COLD, COLD_NAV]) else {
        return;
    };
    let (obs, a, b, c) = (
        tmp("raw-cold.obs"),
        tmp("raw-a.pos"),
        tmp("raw-b.pos"),
        tmp("raw-c.pos"),
    );
    succeeds(&ppkat(&["convert", "--in", p(&log), "-o", p(&obs)]));
    let t = succeeds(&ppkat(&[
        "spp",
        "--obs",
        p(&log),
        "--nav",
        p(&nav),
        "-o",
        p(&a),
    ]));
    assert!(t.contains("read as a u-blox UBX log: 562 epochs"), "{t}");
    succeeds(&ppkat(&[
        "spp",
        "--obs",
        p(&obs),
        "--obs-format",
        "rinex",
        "--nav",
        p(&nav),
        "-o",
        p(&b),
    ]));
    let (la, lb) = (pos_lines(&a), pos_lines(&b));
    assert_eq!(la.len(), 561);
    assert_eq!(la, lb, "the same positions to the last printed digit");
    // Without --nav: the log's own ephemerides.
    let t = succeeds(&ppkat(&["spp", "--obs", p(&log), "-o", p(&c)]));
    assert!(
        t.contains("using the 28 ephemerides decoded from the log"),
        "{t}"
    );
    assert!(t.contains("562 of 562 epochs solved"), "{t}");
}

#[test]
fn spp_without_orbits_says_what_to_give() {
    let Some(f9t) = shared("gnss/ubx-navsol-2025/F9T-L2-5min.ubx") else {
        return;
    };
    let out = tmp("raw-f9t.pos");
    fails_with(
        &ppkat(&["spp", "--obs", p(&f9t), "-o", p(&out)]),
        &["no orbits", "--nav", "--sp3"],
    );
    let junk = tmp("junk.bin");
    std::fs::write(&junk, b"neither RINEX nor UBX").unwrap();
    fails_with(
        &ppkat(&["spp", "--obs", p(&junk), "-o", p(&out)]),
        &[
            "junk.bin",
            "neither a RINEX observation file",
            "--obs-format",
        ],
    );
}

#[test]
fn bench_ingest_times_the_conversion_of_a_log() {
    let Some(log) = shared(COLD) else {
        return;
    };
    let t = succeeds(&ppkat(&["bench", "ingest", p(&log)]));
    assert!(
        t.contains("convert: 3.0 MB of u-blox UBX log (562 epochs, 28 ephemerides)"),
        "{t}"
    );
    assert!(
        t.contains("MB/s per CPU second") && t.contains("peak RSS"),
        "{t}"
    );
    assert!(t.contains("memory factor: peak RSS = "), "{t}");
}

/// A Hatanaka file: the memory factor over the file and over its RINEX text.
#[test]
fn bench_ingest_states_the_memory_factor() {
    let t = succeeds(&ppkat(&["bench", "ingest", p(&fixture("events_v211.crx"))]));
    let line = t
        .lines()
        .find(|l| l.starts_with("memory factor: peak RSS = "))
        .unwrap_or_else(|| panic!("{t}"));
    // The number before each ×: over the file, over the text.
    let parts: Vec<&str> = line.split('×').collect();
    let f: Vec<f64> = parts[..parts.len() - 1]
        .iter()
        .filter_map(|w| w.split_whitespace().last()?.parse().ok())
        .collect();
    assert!(f.len() == 2 && f.iter().all(|x| *x > 1.0), "{line}");
}

#[test]
fn simulate_writes_the_rover_and_base_also_as_ubx() {
    let dir = tmp("sim-raw");
    let scen = fixture("scenario_small.toml");
    let t = succeeds(&ppkat(&[
        "simulate",
        "--scenario",
        p(&scen),
        "--out",
        p(&dir),
        "--raw",
        "ubx",
    ]));
    assert!(t.contains("0 measurements UBX cannot carry"), "{t}");
    let i = succeeds(&ppkat(&["info", p(&dir.join("rover.ubx"))]));
    assert!(i.starts_with("u-blox UBX log"), "{i}");
    assert!(i.contains("26 external events"), "{i}");
    assert!(i.contains("signals C1C L1C D1C S1C C2X L2X D2X S2X"), "{i}");
    fails_with(
        &ppkat(&[
            "simulate",
            "--builtin",
            "close-range",
            "--out",
            p(&dir),
            "--raw",
            "ubx",
        ]),
        &["--raw applies to flights"],
    );
    // PPK on the logs against PPK on the RINEX files, the base position given to both (a log
    // has no header position): the same fix state everywhere, positions within 1 mm (they
    // differ by the 0.1 mm the .pos prints at most).
    let xyz = simulated_base_xyz(&t);
    let base_pos = format!("--base-pos={xyz}");
    let nav = dir.join("nav.rnx");
    let run = |rover: &str, base: &str, out: &Path| {
        succeeds(&ppkat(&[
            "ppk",
            "--rover",
            p(&dir.join(rover)),
            "--base",
            p(&dir.join(base)),
            "--nav",
            p(&nav),
            &base_pos,
            "-o",
            p(out),
        ]))
    };
    let (u, r) = (tmp("sim-ubx.pos"), tmp("sim-rnx.pos"));
    run("rover.ubx", "base.ubx", &u);
    run("rover.obs", "base.obs", &r);
    same_solutions(&pos_lines(&u), &pos_lines(&r), 1175, 1e-3);
}

/// How close PPK on the RTCM logs comes to PPK on the RINEX files, metres per axis: within a
/// millimetre epoch by epoch, until the position held over the flight's static start (the
/// rover stood still) carried the MSMs' rounding through sixty seconds of it (1.8 mm once).
const RTCM_TOL: f64 = 3e-3;

/// Two `.pos` bodies (llh) of the same epochs: equally many (`epochs`), the same times and Q
/// line by line, positions within `tol` metres on each axis.
fn same_solutions(a: &[String], b: &[String], epochs: usize, tol: f64) {
    assert_eq!((a.len(), b.len()), (epochs, epochs), "epochs solved");
    for (a, b) in a.iter().zip(b) {
        let fa: Vec<&str> = a.split_whitespace().collect();
        let fb: Vec<&str> = b.split_whitespace().collect();
        assert_eq!((fa[0], fa[1], fa[5]), (fb[0], fb[1], fb[5]), "time and Q");
        for k in 2..5 {
            let d = fa[k].parse::<f64>().unwrap() - fb[k].parse::<f64>().unwrap();
            let metres = if k < 4 { d * 111_320.0 } else { d };
            assert!(metres.abs() <= tol, "{a}\n{b}");
        }
    }
}

/// `simulate --raw rtcm3` logs carry their ephemerides and the base station: `info` shows the
/// station and where the week came from, `convert --nav` writes the ephemerides, and `ppk`
/// runs on the logs alone (no --nav, no base position), saying on standard error what it took
/// from them and naming the base's origin in the `.pos` header.
#[test]
fn rtcm_logs_carry_their_orbits_and_base_station() {
    let dir = tmp("sim-rtcm");
    let scen = fixture("scenario_small.toml");
    let sim = succeeds(&ppkat(&[
        "simulate",
        "--scenario",
        p(&scen),
        "--out",
        p(&dir),
        "--raw",
        "rtcm3",
    ]));
    let base = dir.join("base.rtcm3");
    let i = succeeds(&ppkat(&["info", p(&base)]));
    assert!(i.contains("station ARP (RTCM 1005/1006)"), "{i}");
    assert!(i.contains("GPS week: "), "{i}");
    let nav = dir.join("rtcm.nav");
    let c = succeeds(&ppkat(&[
        "convert",
        "--in",
        p(&base),
        "-o",
        p(&dir.join("base-rtcm.obs")),
        "--nav",
        p(&nav),
        "--year-hint",
        "2024",
    ]));
    assert!(c.contains("ephemerides"), "{c}");
    let n = std::fs::read_to_string(&nav).unwrap();
    assert!(n.contains("N: GNSS NAV DATA") && n.contains("\nG01 ") && n.contains("\nE01 "));
    let o = dir.join("rtcm.pos");
    let out = ppkat(&[
        "ppk",
        "--rover",
        p(&dir.join("rover.rtcm3")),
        "--base",
        p(&base),
        "-o",
        p(&o),
    ]);
    let t = succeeds(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no --nav given: using the"), "{err}");
    assert!(
        err.contains("no --base-pos/--base-llh given: the base is the station position"),
        "{err}"
    );
    let pos = std::fs::read_to_string(&o).unwrap();
    assert!(pos.contains("base from : the station position of"), "{t}");
    // The same solutions as on the simulator's RINEX files with its navigation file and base
    // position, to RTCM's resolution.
    let r = dir.join("rinex.pos");
    let xyz = simulated_base_xyz(&sim);
    succeeds(&ppkat(&[
        "ppk",
        "--rover",
        p(&dir.join("rover.obs")),
        "--base",
        p(&dir.join("base.obs")),
        "--nav",
        p(&dir.join("nav.rnx")),
        &format!("--base-pos={xyz}"),
        "-o",
        p(&r),
    ]));
    same_solutions(&pos_lines(&o), &pos_lines(&r), 1175, RTCM_TOL);
    fails_with(
        &ppkat(&["info", p(&base), "--date-hint", "2001-01-01"]),
        &["contradicts the log"],
    );
    // ppp reads the log with the hint it is given, too (the SP3 is never reached).
    let o = ppkat(&[
        "ppp",
        "--obs",
        p(&base),
        "--sp3",
        p(&dir.join("none.sp3")),
        "--date-hint",
        "2001-01-01",
        "-o",
        p(&dir.join("ppp.pos")),
    ]);
    fails_with(&o, &["contradicts the log"]);
}

/// `simulate --raw sbf` logs carry their ephemerides, ionosphere and exposures: `info` reads
/// them by content (and with `--obs-format sbf`), `convert` writes the observations, the
/// navigation file and the events, and `ppk` runs on the logs alone (no --nav), fixing as on
/// the RINEX files.
#[test]
fn sbf_logs_carry_their_orbits_and_events() {
    let dir = tmp("sim-sbf");
    let t = succeeds(&ppkat(&[
        "simulate",
        "--scenario",
        p(&fixture("scenario_small.toml")),
        "--out",
        p(&dir),
        "--raw",
        "sbf",
    ]));
    assert!(t.contains("0 measurements SBF cannot carry"), "{t}");
    let rover = dir.join("rover.sbf");
    for extra in [None, Some("sbf")] {
        let mut args = vec!["info", p(&rover)];
        if let Some(f) = extra {
            args.extend(["--obs-format", f]);
        }
        let i = succeeds(&ppkat(&args));
        assert!(i.starts_with("Septentrio SBF log"), "{i}");
        assert!(i.contains("26 external events"), "{i}");
        assert!(i.contains("signals C1C L1C D1C S1C C2W L2W D2W S2W"), "{i}");
        assert!(i.contains("0 checksum failures"), "{i}");
    }
    let b = succeeds(&ppkat(&["bench", "ingest", p(&rover)]));
    assert!(
        b.contains("MB of Septentrio SBF log (1175 epochs, 144 ephemerides)"),
        "{b}"
    );
    let (obs, nav, ev) = (
        dir.join("sbf.obs"),
        dir.join("sbf.nav"),
        dir.join("sbf.csv"),
    );
    let c = succeeds(&ppkat(&[
        "convert",
        "--in",
        p(&rover),
        "--format",
        "sbf",
        "-o",
        p(&obs),
        "--nav",
        p(&nav),
        "--events",
        p(&ev),
    ]));
    assert!(c.contains("1175 observation epochs, 26 events"), "{c}");
    let n = std::fs::read_to_string(&nav).unwrap();
    assert!(n.contains("GPSA") && n.contains("IONOSPHERIC CORR") && n.contains("\nE01 "));
    let csv = std::fs::read_to_string(&ev).unwrap();
    assert_eq!(csv.lines().count(), 27, "{csv}");
    assert!(
        csv.lines().nth(1).unwrap().contains(",falling,1,true"),
        "{csv}"
    );
    let xyz = simulated_base_xyz(&t);
    let (s, r) = (tmp("sim-sbf.pos"), tmp("sim-sbf-rnx.pos"));
    for (rov, base, out, nav) in [
        ("rover.sbf", "base.sbf", &s, None),
        ("rover.obs", "base.obs", &r, Some(dir.join("nav.rnx"))),
    ] {
        let mut args = vec![
            "ppk".to_string(),
            "--rover".into(),
            p(&dir.join(rov)).into(),
            "--base".into(),
            p(&dir.join(base)).into(),
            format!("--base-pos={xyz}"),
            "-o".into(),
            p(out).into(),
        ];
        if let Some(n) = nav {
            args.extend(["--nav".into(), p(&n).into()]);
        }
        succeeds(&ppkat(&args.iter().map(String::as_str).collect::<Vec<_>>()));
    }
    // The same solutions as on the RINEX files, to 1 mm.
    same_solutions(&pos_lines(&s), &pos_lines(&r), 1175, 1e-3);
}
