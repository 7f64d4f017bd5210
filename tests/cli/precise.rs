//! `ppkat spp` on precise orbits (ONSA's day with the IGS final orbits of three days and no
//! navigation file) and `ppkat ppk` on them (a simulated flight with the simulator's SP3);
//! clock files that do not fit; bad usage.

use super::*;

const ONSA_OBS: &str = "gnss/onsa-2005-224/onsa2240.05o";
const ONSA_SP3: [&str; 3] = [
    "gnss/onsa-2005-224/igs13354.sp3",
    "gnss/onsa-2005-224/igs13355.sp3",
    "gnss/onsa-2005-224/igs13356.sp3",
];
/// ONSA's marker (ITRF2014 at the observation epoch), ECEF metres.
const ONSA_TRUTH: [f64; 3] = [3370658.5313, 711877.1456, 5349786.9559];

/// The ONSA observation file and its three SP3 files, or `None` (skipped).
fn onsa() -> Option<[PathBuf; 4]> {
    shared_all([ONSA_OBS, ONSA_SP3[0], ONSA_SP3[1], ONSA_SP3[2]])
}

/// `--sp3 FILE` for each of the three SP3 files.
fn sp3_flags(f: &[PathBuf; 4]) -> Vec<&str> {
    f[1..].iter().flat_map(|s| ["--sp3", p(s)]).collect()
}

/// ECEF positions of a `.pos` written with `--format xyz`, with their time columns.
fn xyz_rows(path: &Path) -> Vec<(String, [f64; 3])> {
    pos_rows(path)
        .into_iter()
        .map(|r| {
            let x = [2, 3, 4].map(|k| r[k].parse::<f64>().unwrap());
            (format!("{} {}", r[0], r[1]), x)
        })
        .collect()
}

#[test]
fn spp_on_three_sp3_files_without_navigation() {
    let Some(f) = onsa() else {
        return;
    };
    let out = tmp("onsa-spp.pos");
    let mut args = vec!["spp", "--obs", p(&f[0]), "--format", "xyz", "-o", p(&out)];
    args.extend(sp3_flags(&f));
    let t = succeeds(&ppkat(&args));
    assert!(
        t.contains("no navigation file: no Klobuchar ionosphere parameters"),
        "{t}"
    );
    let rows = xyz_rows(&out);
    // The day's last epochs need the next day's file (and the first ones the previous day's).
    assert_eq!(rows[0].0, "2005/08/12 00:00:00.000000");
    assert_eq!(rows[rows.len() - 1].0, "2005/08/12 23:59:30.000000");
    assert!(rows.len() >= 2800, "{} epochs solved: {t}", rows.len());
    let n = rows.len() as f64;
    let mean: [f64; 3] = [0, 1, 2].map(|k| rows.iter().map(|r| r.1[k]).sum::<f64>() / n);
    let d = |x: &[f64; 3]| {
        ((x[0] - ONSA_TRUTH[0]).powi(2)
            + (x[1] - ONSA_TRUTH[1]).powi(2)
            + (x[2] - ONSA_TRUTH[2]).powi(2))
        .sqrt()
    };
    let mut errs: Vec<f64> = rows.iter().map(|r| d(&r.1)).collect();
    errs.sort_by(f64::total_cmp);
    let median = errs[errs.len() / 2];
    eprintln!(
        "ONSA single point on IGS finals, no ionosphere model: {} epochs, mean position {:.2} m from the marker, per-epoch 3D median {:.2} m, 95 % {:.2} m",
        rows.len(),
        d(&mean),
        median,
        errs[errs.len() * 95 / 100]
    );
    assert!(d(&mean) < 5.0, "mean position {:.2} m off", d(&mean));
    assert!(median < 6.0, "median 3D error {median:.2} m");
}

/// `ppk` of the simulated flight (3.8 km from its base) on the simulator's own precise orbits
/// (`simulate --sp3`) without a navigation file, against the exact antenna trajectory. The
/// simulation switches broadcast records halfway between their reference times, which is
/// where the flight starts: the clocks then jump by up to 11 cm, which the SP3's 5-minute
/// samples smooth over. The base (every 10 s) straddles that jump until its second epoch,
/// so the comparison starts there; from then on the run on SP3 matches the run on the
/// navigation file to 0.2 mm (every epoch fixed, the worst 2.5 cm from the truth).
#[test]
fn ppk_on_sp3_without_navigation() {
    let dir = tmp("sp3-flight");
    let _ = std::fs::remove_dir_all(&dir);
    let t = succeeds(&ppkat(&[
        "simulate",
        "--builtin",
        "demo",
        "--sp3",
        "-o",
        p(&dir),
    ]));
    assert!(t.contains("orbits.sp3 (SP3-c, 5 min)"), "{t}");
    let out = dir.join("sp3.pos");
    let base_flag = format!("--base-pos={}", simulated_base_xyz(&t));
    let t = succeeds(&ppkat(&[
        "ppk",
        "--rover",
        p(&dir.join("rover.obs")),
        "--base",
        p(&dir.join("base.obs")),
        "--sp3",
        p(&dir.join("orbits.sp3")),
        &base_flag,
        "--format",
        "xyz",
        "-o",
        p(&out),
    ]));
    assert!(t.contains("no navigation file"), "{t}");
    let rows = pos_rows(&out);
    assert_eq!(rows.len(), 2379, "{t}");
    // From the base's second epoch on: see above.
    let (compared, fixed, worst) = against_sim_truth(&dir, &rows, 9.0 * 3600.0 + 9.9);
    assert!(compared > 2270, "{compared}");
    assert_eq!(
        fixed, compared,
        "every epoch fixed, as on the navigation file"
    );
    assert!(
        worst < 0.04,
        "worst fixed epoch {worst:.4} m off (0.025 measured)"
    );
}

#[test]
fn clock_files_that_do_not_fit() {
    let Some(f) = onsa() else {
        return;
    };
    let out = tmp("onsa-clk.pos");
    // A clock file of another day.
    let clk = fixture("clock_v200.clk");
    let mut args = vec!["spp", "--obs", p(&f[0]), "-o", p(&out), "--clk", p(&clk)];
    args.extend(sp3_flags(&f));
    fails_with(
        &ppkat(&args),
        &[
            "onsa2240.05o",
            "do not overlap the clocks",
            "clock_v200.clk",
        ],
    );
    assert!(!out.exists(), "no output on failure");
    // A broken clock file: the message names the file and the line.
    let text = std::fs::read_to_string(&clk).unwrap();
    let broken = tmp("broken.clk");
    std::fs::write(
        &broken,
        text.replacen("1.000300000000E-04", "1.0003OOOOOOOE-04", 1),
    )
    .unwrap();
    let mut args = vec!["spp", "--obs", p(&f[0]), "-o", p(&out), "--clk", p(&broken)];
    args.extend(sp3_flags(&f));
    fails_with(&ppkat(&args), &["broken.clk:20:", "clock bias"]);
}

#[test]
fn orbit_flags_that_do_not_go_together() {
    let obs = fixture("events_v304.rnx");
    let clk = fixture("clock_v200.clk");
    let out = tmp("usage.pos");
    for args in [
        // Clock files without SP3.
        &[
            "spp",
            "--obs",
            p(&obs),
            "--nav",
            "x.nav",
            "--clk",
            p(&clk),
            "-o",
            p(&out),
        ],
        &[
            "ppk", "--rover", "r", "--base", "b", "--nav", "n", "--clk", "c", "-o", "o",
        ][..],
    ] {
        let o = ppkat(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
    }
    // No orbits at all: only known once the observations are read (a raw log may carry its
    // own ephemerides), so a run error that says what to give.
    for args in [
        &["spp", "--obs", p(&obs), "-o", p(&out)][..],
        &["ppk", "--rover", p(&obs), "--base", p(&obs), "-o", p(&out)],
    ] {
        fails_with(&ppkat(args), &["no orbits", "--nav", "--sp3"]);
    }
}

/// `ppkat ppp` on ONSA's day writes the coordinate within centimetres of the truth and says
/// so in OUT.pos.json; `ppk --base-from-ppp` on a zero baseline (ONSA against itself) puts
/// the base, and so the rover, there too and states it in the header.
#[test]
fn ppp_static_and_ppk_base_from_ppp() {
    let Some(f) = onsa() else {
        return;
    };
    let Some([atx01, atx05]) = shared_all([
        "gnss/onsa-2005-224/igs_01.atx",
        "gnss/bell-ebre-2002-030/igs05.atx",
    ]) else {
        return;
    };
    let out = tmp("onsa_ppp.pos");
    let mut args = vec!["ppp", "--obs", p(&f[0]), "-o", p(&out)];
    args.extend(sp3_flags(&f));
    args.extend(["--antex", p(&atx01), "--antex", p(&atx05)]);
    let text = succeeds(&ppkat(&args));
    assert!(text.contains("static marker"), "{text}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{}.json", out.display())).unwrap())
            .unwrap();
    let ecef: Vec<f64> = json["position"]["ecef_m"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let err = (0..3)
        .map(|k| (ecef[k] - ONSA_TRUTH[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(err < 0.03, "PPP 3D error {err} m");
    assert_eq!(json["frame"], "IGb00");
    let epoch = json["epoch_decimal_year"].as_f64().unwrap();
    assert!((epoch - 2005.6123).abs() < 0.0005, "{epoch}");
    let ztd = std::fs::read_to_string(format!("{}.ztd.csv", out.display())).unwrap();
    assert_eq!(ztd.lines().count(), 2881, "a header and a line per epoch");
    let last_ztd: f64 = ztd
        .lines()
        .last()
        .unwrap()
        .split(',')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        (2.3..2.6).contains(&last_ztd),
        "ZTD at Onsala near sea level: {last_ztd} m"
    );
    let page = std::fs::read_to_string(format!("{}.html", out.display())).unwrap();
    assert!(
        page.contains("Convergence") && page.matches("<svg").count() == 3,
        "three plots"
    );
    assert!(
        !text.contains("Klobuchar"),
        "no broadcast ionosphere is needed: {text}"
    );
    let last = xyz_rows(&out).pop().unwrap().1;
    assert!(
        (0..3).all(|k| (last[k] - ecef[k]).abs() < 1e-3),
        "the last line is the final one"
    );

    // Orthometric: the llh .pos in EGM96 heights, the summary with both heights.
    let ortho = tmp("onsa_ppp_egm96.pos");
    let mut args = vec![
        "ppp",
        "--obs",
        p(&f[0]),
        "--format",
        "llh",
        "--height",
        "egm96",
    ];
    args.extend(["-o", p(&ortho)]);
    args.extend(sp3_flags(&f));
    args.extend(["--antex", p(&atx01), "--antex", p(&atx05)]);
    succeeds(&ppkat(&args));
    let pos = std::fs::read_to_string(&ortho).unwrap();
    assert!(pos.contains("height=WGS84/geodetic(EGM96)"), "{pos}");
    let sum: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{}.json", ortho.display())).unwrap(),
    )
    .unwrap();
    assert_orthometric(&sum["position"]);
    // ONSA's marker lies about 9 m above sea level (36.5 m of EGM96 undulation).
    let big_h = sum["position"]["orthometric_height_m"].as_f64().unwrap();
    assert!((big_h - 9.03).abs() < 0.05, "{big_h}");

    // Kinematic PPP as GeoJSON: a point per epoch besides the track.
    let gj = tmp("onsa_ppp_kin.geojson");
    let mut args = vec![
        "ppp",
        "--obs",
        p(&f[0]),
        "--mode",
        "kinematic",
        "--format",
        "geojson",
        "-o",
        p(&gj),
    ];
    args.extend(sp3_flags(&f));
    args.extend(["--antex", p(&atx01), "--antex", p(&atx05)]);
    succeeds(&ppkat(&args));
    let g: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&gj).unwrap()).unwrap();
    let points = g["features"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["geometry"]["type"] == "Point")
        .count();
    assert_eq!(points, 2880);

    let zb = tmp("onsa_zero_baseline.pos");
    let mut args = vec![
        "ppk",
        "--rover",
        p(&f[0]),
        "--base",
        p(&f[0]),
        "--base-from-ppp",
        "--mode",
        "static",
        "--refer",
        "marker",
        "--format",
        "xyz",
        "--antex",
        p(&atx01),
        "-o",
        p(&zb),
    ];
    args.extend(sp3_flags(&f));
    let text = succeeds(&ppkat(&args));
    let header = std::fs::read_to_string(&zb).unwrap();
    assert!(
        header.contains("% base from : static PPP on the base file"),
        "{header}"
    );
    assert!(
        text.contains("base PPP:"),
        "the PPP's warnings are passed on: {text}"
    );
    let rover = xyz_rows(&zb).pop().unwrap().1;
    let err = (0..3)
        .map(|k| (rover[k] - ONSA_TRUTH[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        err < 0.05,
        "zero-baseline rover from the PPP base: 3D error {err} m"
    );
}

/// A summary position with `--height egm96`: the ellipsoidal height kept, the EGM96 geoid
/// undulation at the point beside it, and H = h − N.
pub(crate) fn assert_orthometric(pos: &serde_json::Value) {
    let num = |k: &str| pos[k].as_f64().unwrap_or_else(|| panic!("no {k}: {pos}"));
    let (lat, lon, h) = (
        num("latitude_deg"),
        num("longitude_deg"),
        num("ellipsoidal_height_m"),
    );
    let g = ::gnss::frame::Geodetic::from_degrees(lat, lon, h);
    let n = ::integration::height::Heights::Egm96
        .undulation(&g)
        .unwrap();
    assert_eq!(pos["height_model"], "EGM96");
    assert!((num("geoid_undulation_m") - n).abs() < 1e-6, "{pos}");
    assert!(
        (num("orthometric_height_m") - (h - n)).abs() < 1e-6,
        "{pos}"
    );
    assert!(n.abs() > 1.0, "a real undulation: {n}");
}
