//! `ppkat spp` and `ppkat ppk`: RTKLIB-compatible `.pos` files from real data, and clear
//! errors for inputs that do not fit together.

use super::*;

/// `ppkat ppk` of `rover` against `base` with the navigation files and `extra` flags into
/// `out`.
fn ppk(rover: &Path, base: &Path, nav: &[&Path], out: &Path, extra: &[&str]) -> Output {
    ppkat(&ppk_args(rover, base, nav, out, extra))
}

#[test]
fn observations_and_navigation_without_time_overlap() {
    let Some([obs, nav]) = shared_all([
        GEONET_ROVER,
        "gnss/esbc-2020-177/ESBC00DNK_R_20201770000_01D_MN.rnx.gz",
    ]) else {
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
    let Some([obs, nav]) = shared_all([GEONET_ROVER, GEONET_NAV]) else {
        return;
    };
    for (fmt, cols) in [("llh", "latitude(deg)"), ("xyz", "x-ecef(m)")] {
        let out = tmp(&format!("geonet-{fmt}.pos"));
        succeeds(&spp_to(&obs, &nav, fmt, &out));
        let pos = std::fs::read_to_string(&out).unwrap();
        assert!(pos.lines().any(|l| l.starts_with('%') && l.contains(cols)));
        let rows = pos_rows(&out);
        assert!(rows.len() >= 110);
        // yyyy/mm/dd hh:mm:ss.sss  a b c  Q ns sdn sde sdu sdne sdeu sdun age ratio
        let f = &rows[0];
        assert_eq!(f.len(), 15, "{f:?}");
        assert_eq!(f[0], "2005/04/02");
        assert_eq!(f[5], "5", "Q = 5 for single point");
        if fmt == "llh" {
            let lat: f64 = f[2].parse().unwrap();
            assert!((lat - 35.1608).abs() < 1e-3);
        }
    }
}

#[test]
fn ppk_geonet_writes_fixed_solutions_with_quality_columns() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let out = tmp("geonet-ppk.pos");
    let t = succeeds(&ppk(&rover, &base, &[&nav], &out, &[GEONET_BASE_POS]));
    assert!(t.contains("120 fixed (100.0 % of solved)"), "{t}");
    // At a 15° mask the last five epochs keep too few satellites for a code solution.
    let out15 = tmp("geonet-ppk-15.pos");
    let args = [GEONET_BASE_POS, "--elev-mask", "15"];
    let t15 = succeeds(&ppk(&rover, &base, &[&nav], &out15, &args));
    assert!(
        t15.contains("120 rover epochs, 115 solved")
            && t15.contains("5 epochs unsolved: no single-point solution: poor geometry"),
        "unsolved epochs say why: {t15}"
    );
    // Its last solved epoch has five satellites: the fix's 3D sigma (about 11 cm, and 7.5 cm
    // off the truth) says how weak the geometry is. Its integers continue arcs held since a
    // stronger geometry fixed them and the baseline is short, so the epoch stays fixed with
    // that sigma (float under the 8 cm limit before); a user's --max-fixed-sigma still
    // keeps such fixes out.
    assert!(t15.contains("115 fixed (100.0 % of solved)"), "{t15}");
    let last = pos_rows(&out15).pop().unwrap();
    let sd: Vec<f64> = (7..10).map(|i| last[i].parse().unwrap()).collect();
    let sigma3 = sd.iter().map(|s| s * s).sum::<f64>().sqrt();
    assert!((0.08..0.12).contains(&sigma3), "fixed 3D sigma {sigma3}");
    let f = |k: usize| last[k].parse::<f64>().unwrap();
    let e = ::gnss::frame::Geodetic::from_degrees(f(2), f(3), f(4)).to_ecef();
    let truth = ::gnss::frame::Ecef::new(-3976219.1869, 3382371.6036, 3652511.1410);
    assert!(
        (e.0 - truth.0).norm() <= sigma3,
        "the weak fix lies within its sigma"
    );
    let strict = tmp("geonet-ppk-15-strict.pos");
    let args = [
        GEONET_BASE_POS,
        "--elev-mask",
        "15",
        "--max-fixed-sigma",
        "0.08",
    ];
    let t = succeeds(&ppk(&rover, &base, &[&nav], &strict, &args));
    assert!(t.contains("114 fixed"), "{t}");
    assert!(t.contains("fixed σ limit 1"), "the refusal is named: {t}");
    assert_base_read_back(&out);
    let rows = pos_rows(&out);
    assert_eq!(rows.len(), 120);
    // Every fixed epoch against the rover's reference (the shared data's README).
    let truth = ::gnss::frame::Ecef::new(-3976219.1869, 3382371.6036, 3652511.1410);
    let mut worst = 0.0f64;
    for r in &rows {
        assert_eq!(r[5], "1", "Q = 1 fixed");
        let sdu: f64 = r[9].parse().unwrap();
        assert!(sdu > 0.001 && sdu < 0.1, "a real vertical sigma: {sdu}");
        let ratio: f64 = r[14].parse().unwrap();
        assert!(ratio >= 3.0);
        let f = |k: usize| r[k].parse::<f64>().unwrap();
        let e = ::gnss::frame::Geodetic::from_degrees(f(2), f(3), f(4)).to_ecef();
        worst = worst.max((e.0 - truth.0).norm());
    }
    eprintln!("GEONET kinematic: worst fixed epoch {worst:.4} m from the reference");
    assert!(
        worst <= GEONET_KINEMATIC_WORST,
        "worst fixed epoch {worst:.4} m off"
    );
}

/// The GEONET rover's kinematic fixed epochs: the farthest from its reference, metres
/// (measured 3.2 cm; a wrong integer moves an epoch by decimetres).
const GEONET_KINEMATIC_WORST: f64 = 0.045;

/// RTKLIB's solution reader gets the `--base-pos` we gave back from the `.pos` (llh or xyz).
fn assert_base_read_back(out: &Path) {
    let text = std::fs::read_to_string(out).unwrap();
    let b = ::gnss::solution::rtklib_ref_pos(&text).expect("a ref pos line RTKLIB reads");
    let given = [-3978241.958, 3382840.234, 3649900.853];
    let err = (0..3)
        .map(|i| (b.0[i] - given[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(err < 1e-4, "base read back {err} m off: {b:?}");
}

/// `--mode static`: one position accumulated over the hour, the last .pos line being the
/// final one, and OUT.pos.json with its σ, epochs, fix state and residuals.
#[test]
fn ppk_static_writes_the_accumulated_position_and_a_summary() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let out = tmp("geonet-static.pos");
    let args = [GEONET_BASE_POS, "--mode", "static", "--format", "xyz"];
    let t = succeeds(&ppk(&rover, &base, &[&nav], &out, &args));
    assert!(
        t.contains("static arp: X") && t.contains("fixed (ratio"),
        "{t}"
    );
    assert_base_read_back(&out);
    let pos = std::fs::read_to_string(&out).unwrap();
    assert!(
        pos.contains("% pos mode  : static, filter Forward"),
        "{pos}"
    );
    assert!(pos.contains("% positions : rover antenna reference point (ARP)"));
    let json = std::fs::read_to_string(out.with_extension("pos.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let xyz: Vec<f64> = (0..3)
        .map(|i| v["position"]["ecef_m"][i].as_f64().unwrap())
        .collect();
    // The truth of the GEONET rover (its ARP is its marker): within 1 cm (measured 2.7 mm).
    let truth = [-3976219.1869, 3382371.6036, 3652511.1410];
    let err = (0..3)
        .map(|i| (xyz[i] - truth[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(err < 0.01, "static error {err}");
    assert_eq!(v["quality"], "fixed");
    assert_eq!(v["epochs"], 120);
    assert_eq!(v["refers_to"], "arp");
    assert!(
        v["position"]["orthometric_height_m"].is_null(),
        "ellipsoidal only"
    );
    let se = v["sigma_m"]["east"].as_f64().unwrap();
    assert!((0.002..0.01).contains(&se), "σ east {se}");
    assert!(v["residuals"]["phase"]["rms_m"].as_f64().unwrap() < 0.01);
    // The last .pos line is the summary's position.
    let last = pos_rows(&out).pop().unwrap();
    let x: f64 = last[2].parse().unwrap();
    assert!((x - xyz[0]).abs() < 1e-3, "{x} vs {}", xyz[0]);
    // With --height egm96 (llh) the summary adds the orthometric height.
    let ortho = tmp("geonet-static-egm96.pos");
    let args = [GEONET_BASE_POS, "--mode", "static", "--height", "egm96"];
    succeeds(&ppk(&rover, &base, &[&nav], &ortho, &args));
    let json = std::fs::read_to_string(ortho.with_extension("pos.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    super::precise::assert_orthometric(&v["position"]);
}

/// `bench ppk` runs the job and reports the engine's time per epoch.
#[test]
fn bench_ppk_reports_milliseconds_per_epoch() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let out = tmp("geonet-bench.pos");
    let mut args = vec!["bench", "ppk", "--rover", p(&rover), "--base", p(&base)];
    args.extend(["--nav", p(&nav), GEONET_BASE_POS, "-o", p(&out)]);
    let t = succeeds(&ppkat(&args));
    assert!(t.contains("120 fixed"), "{t}");
    assert!(
        t.contains("bench ppk: 120 rover epochs, 2 pass(es)") && t.contains("ms per rover epoch"),
        "{t}"
    );
    assert_eq!(pos_rows(&out).len(), 120);
}

#[test]
fn ppk_without_common_epochs() {
    let Some([rover, base, nav]) = shared_all([
        GEONET_ROVER,
        "gnss/spirent-rose-2023/Base-static_MO_Spirent.obs",
        GEONET_NAV,
    ]) else {
        return;
    };
    let out = tmp("nocommon.pos");
    fails_with(
        &ppk(&rover, &base, &[&nav], &out, &[GEONET_BASE_POS]),
        &[
            "07590920.05o",
            "Base-static_MO_Spirent.obs",
            "no rover epoch has a base epoch",
        ],
    );
}

#[test]
fn ppk_rover_without_phase() {
    let src = std::fs::read_to_string(fixture("events_v304.rnx")).unwrap();
    let f = tmp("codeonly.obs");
    std::fs::write(
        &f,
        src.replace("G    4 C1C L1C C2W L2W", "G    4 C1C D1C C2W D2W")
            .replace("E    2 C1C L1C", "E    2 C1C D1C"),
    )
    .unwrap();
    let base = fixture("events_v304.rnx");
    let out = tmp("codeonly.pos");
    fails_with(
        &ppk(&f, &base, &[&base], &out, &[]),
        &["codeonly.obs", "no carrier-phase"],
    );
}

#[test]
fn ppk_without_any_base_position() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let src = std::fs::read_to_string(&base).unwrap();
    let nopos: String = src
        .lines()
        .filter(|l| !l.contains("APPROX POSITION XYZ"))
        .map(|l| format!("{l}\n"))
        .collect();
    let f = tmp("base-nopos.05o");
    std::fs::write(&f, nopos).unwrap();
    let out = tmp("nopos.pos");
    fails_with(
        &ppk(&rover, &f, &[&nav], &out, &[]),
        &["base-nopos.05o", "--base-pos", "--base-llh"],
    );
    // With the header position only: solved, with a loud warning.
    let t = succeeds(&ppk(&rover, &base, &[&nav], &out, &[]));
    assert!(t.contains("BASE POSITION TAKEN FROM THE HEADER"), "{t}");
}

#[test]
fn ppk_navigation_not_covering_the_span() {
    let Some([rover, base, nav]) = shared_all([
        GEONET_ROVER,
        GEONET_BASE,
        "gnss/cssrlib-2021-265/SEPT2650.21P",
    ]) else {
        return;
    };
    let out = tmp("navspan.pos");
    fails_with(
        &ppk(&rover, &base, &[&nav], &out, &[GEONET_BASE_POS]),
        &["07590920.05o", "do not overlap", "SEPT2650.21P"],
    );
}

/// A 1 Hz rover against a 30 s base (the base file decimated): every rover epoch is solved
/// against the nearest base epoch within 30 s, and the age of that base epoch is reported.
#[test]
fn ppk_high_rate_rover_against_a_30_s_base() {
    let Some([rover, base, gn, en]) = shared_all([
        "gnss/spirent-rose-2023/Rover-static-2km-east_MO_Spirent.obs",
        "gnss/spirent-rose-2023/Base-static_MO_Spirent.obs",
        "gnss/spirent-rose-2023/RINEX_GN_Spirent.23N",
        "gnss/spirent-rose-2023/RINEX_EN_Spirent.23L",
    ]) else {
        return;
    };
    let src = std::fs::read_to_string(&base).unwrap();
    let mut keep = true;
    let mut dec = String::new();
    for l in src.lines() {
        if l.starts_with('>') {
            let sec: f64 = l[18..29].trim().parse().unwrap();
            keep = sec == 0.0 || sec == 30.0;
        }
        if keep {
            dec.push_str(l);
            dec.push('\n');
        }
    }
    let b30 = tmp("base-30s.obs");
    std::fs::write(&b30, dec).unwrap();
    let out = tmp("rate.pos");
    let t = succeeds(&ppk(
        &rover,
        &b30,
        &[&gn, &en],
        &out,
        &[
            "--base-pos=4157177.06580187,671230.476590636,4774767.03105544",
            "--format",
            "xyz",
        ],
    ));
    // x y z Q ns sdx sdy sdz sdxy sdyz sdzx age ratio (after date and time)
    let rows: Vec<Vec<f64>> = pos_rows(&out)
        .iter()
        .map(|r| r[2..].iter().map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 601, "{t}");
    let max_age = rows.iter().map(|r| r[11].abs()).fold(0.0, f64::max);
    assert!(
        (14.0..=15.0).contains(&max_age),
        "age of the base epoch reported: {max_age}"
    );
    let truth = [4156857.1195929, 673209.028774142, 4774767.03105544];
    let fixed: Vec<&Vec<f64>> = rows.iter().filter(|r| r[3] == 1.0).collect();
    assert!(
        fixed.len() as f64 >= 0.95 * rows.len() as f64,
        "{} fixed",
        fixed.len()
    );
    let worst = fixed
        .iter()
        .map(|r| {
            ((r[0] - truth[0]).powi(2) + (r[1] - truth[1]).powi(2) + (r[2] - truth[2]).powi(2))
                .sqrt()
        })
        .fold(0.0, f64::max);
    assert!(worst < 0.02, "worst fixed error with a 30 s base: {worst}");
}

/// With an ANTEX calibration putting the rover's phase centre 10 cm above its reference point,
/// the reported rover (reference point) is 10 cm lower than without it.
#[test]
fn ppk_applies_antex_phase_centre_offsets() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let src = std::fs::read_to_string(&rover).unwrap();
    let renamed = src.replacen("TRM29659.00         ", "PPKATTEST           ", 1);
    assert_ne!(src, renamed);
    let r2 = tmp("rover-testant.05o");
    std::fs::write(&r2, renamed).unwrap();
    let heights = |extra: &[&str]| -> Vec<f64> {
        let out = tmp(&format!("antex-{}.pos", extra.len()));
        let mut flags = vec![GEONET_BASE_POS];
        flags.extend_from_slice(extra);
        succeeds(&ppk(&r2, &base, &[&nav], &out, &flags));
        pos_rows(&out)
            .iter()
            .map(|r| r[4].parse().unwrap())
            .collect()
    };
    let atx = fixture("test.atx");
    let without = heights(&[]);
    let with = heights(&["--antex", p(&atx)]);
    assert_eq!(without.len(), with.len());
    for (a, b) in without.iter().zip(&with) {
        assert!((a - b - 0.10).abs() < 0.003, "height change {}", a - b);
    }
}

/// An output in a folder that does not exist: exit 1, the file named, "cannot write".
#[test]
fn output_into_a_missing_folder() {
    let Some([obs, nav]) = shared_all([GEONET_ROVER, GEONET_NAV]) else {
        return;
    };
    let out = tmp("no-such-folder").join("x.pos");
    let o = ppkat(&["spp", "--obs", p(&obs), "--nav", p(&nav), "-o", p(&out)]);
    fails_with(&o, &["no-such-folder", "cannot write"]);
}

/// Base and rover given the wrong way round: the simulated flight's rover file as `--base`
/// moves, so `ppk` fails (exit code 1) saying so and writes nothing; the right order works.
#[test]
fn ppk_refuses_swapped_base_and_rover() {
    let d = demo_dir();
    let (rover, base, nav) = (d.join("rover.obs"), d.join("base.obs"), d.join("nav.rnx"));
    let out = tmp("swapped.pos");
    let o = ppkat(&ppk_args(&base, &rover, &[&nav], &out, &[]));
    fails_with(
        &o,
        &[
            "rover.obs",
            "the base moves",
            "were --rover and --base swapped?",
        ],
    );
    assert!(!out.exists(), "nothing written");
    let out = tmp("right-order.pos");
    succeeds(&ppkat(&ppk_args(&rover, &base, &[&nav], &out, &[])));
    assert!(out.exists());
}

/// `--quiet` (before or after the command): a clean PPK run prints nothing on standard error,
/// and the `.pos` is byte for byte the one written without it (progress never changes
/// outputs).
#[test]
fn quiet_ppk_prints_nothing_and_changes_nothing() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let (loud, quiet) = (tmp("quiet-loud.pos"), tmp("quiet-quiet.pos"));
    let o = ppkat(&ppk_args(&rover, &base, &[&nav], &loud, &[GEONET_BASE_POS]));
    succeeds(&o);
    for (k, at_end) in [false, true].into_iter().enumerate() {
        let mut args = ppk_args(&rover, &base, &[&nav], &quiet, &[GEONET_BASE_POS]);
        if at_end {
            args.push("--quiet");
        } else {
            args.insert(0, "-q");
        }
        let o = ppkat(&args);
        succeeds(&o);
        assert!(
            o.stderr.is_empty(),
            "{k}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(
            std::fs::read(&loud).unwrap(),
            std::fs::read(&quiet).unwrap()
        );
    }
}

/// `simulate --builtin long-baseline` (issue 49's bench): a 250 km pair over 24 h at 30 s
/// with its truth, processed by its own `ppk.toml`; the PPK names the baseline it saw and
/// solves every epoch. Against the exact rover position: GPS alone (31 satellites, 10 in
/// view) fixes 82.6 % of its epochs, 3D RMS 4.3 cm, the worst fixed 11.2 cm off; with
/// Galileo E1/E5a beside GPS (18 in view) 98.6 %, 3D RMS 3.0 cm, the worst fixed 10.8 cm
/// (issue 49 asks for none beyond 10 cm: not yet). The navigation file also holds 112 sets
/// of an older upload 8 m off, which the PPK passes over and says so (taken by toe alone
/// they gave 57.8 % fixed, 161 fixed epochs beyond 10 cm, NEES 1.75), and G05's sets are all
/// stale (8 m off, nothing fresher): leaving one satellite float where the whole set will
/// not fix keeps GPS at 82.6 % (3D RMS 4.4 cm, worst fixed 11.2 cm) and GPS + Galileo at
/// 98.6 % (77.8 % and 92.4 % without).
#[test]
fn the_long_baseline_bench_runs_end_to_end() {
    let dir = tmp("long-baseline");
    let _ = std::fs::remove_dir_all(&dir);
    let t = succeeds(&ppkat(&[
        "simulate",
        "--builtin",
        "long-baseline",
        "-o",
        p(&dir),
    ]));
    assert!(
        t.contains("long-baseline: 250.") && t.contains("2881 epochs"),
        "{t}"
    );
    for d in [dir.clone(), dir.join("gps-galileo")] {
        for f in [
            "rover.obs",
            "base.obs",
            "nav.rnx",
            "truth.toml",
            "truth_trajectory.csv",
            "README.txt",
        ] {
            assert!(d.join(f).exists(), "{}", d.join(f).display());
        }
    }
    let t = succeeds(&ppkat(&["ppk", "--config", p(&dir.join("ppk.toml"))]));
    assert!(t.contains("longest baseline 250."), "{t}");
    // The C/A base against the P(Y) rover: the satellites' code biases are estimated.
    assert!(t.contains("code biases per satellite (Gps signal 1"), "{t}");
    assert!(
        t.contains("112 ephemerides of older uploads passed over"),
        "{t}"
    );
    let gps = against_truth(&dir);
    // What ran, said: the narrow-lane rate is the fix rate; the wide lanes come first.
    let rate = |name: &str| -> f64 {
        let tail = &t[t.find(name).unwrap_or_else(|| panic!("{name} in {t}")) + name.len()..];
        tail.split_whitespace().next().unwrap().parse().unwrap()
    };
    let (wide, narrow) = (rate("wide lanes fixed at"), rate("narrow lanes at"));
    assert!(
        (narrow - 100.0 * gps.fixed_share).abs() < 0.06 && wide >= narrow,
        "{wide} {narrow} {gps:?}"
    );
    assert!(gps.solved == 2881, "{gps:?}");
    assert!(
        gps.fixed_share > 0.80 && gps.rms_3d < 0.05 && gps.worst_fixed < 0.13,
        "{gps:?}"
    );
    // Honest σ (measured 0.38 fixed, 0.44 float).
    assert!(
        (0.3..=3.0).contains(&gps.nees.0) && (0.3..=3.0).contains(&gps.nees.1),
        "{gps:?}"
    );
    let galileo = dir.join("gps-galileo");
    let t = succeeds(&ppkat(&["ppk", "--config", p(&galileo.join("ppk.toml"))]));
    assert!(t.contains("longest baseline 250."), "{t}");
    let both = against_truth(&galileo);
    assert!(both.solved == 2881, "{both:?}");
    assert!(
        both.fixed_share > 0.96 && both.rms_3d < 0.04 && both.worst_fixed < 0.13,
        "{both:?}"
    );
}

/// The long-baseline pair's `faults/` copy (issue 67): three unflagged (1, 1)-cycle slips of
/// the rover's strongest satellite and G12's 10:00 set 30 m along track. No epoch may lie
/// more than 1 m off with a 3D σ under 10 cm. No epoch's own residuals betray the bad orbit
/// (its error drifts slowly and the ambiguity takes it up) nor the 08:00 slip, but the
/// smoother's halves — the forward filter alone and the backward pass — contradict their σ
/// around them for hours: the float σ are scaled by that contradiction and fixes where it
/// passes 8 are not reported. Measured: 53.7 % fixed (82.6 % without the faults), worst
/// epoch 0.45 m off, worst fixed 12.4 cm, 31 fixed epochs beyond 10 cm and none beyond
/// 15 cm, NEES 0.47 fixed and 0.38 float; before the halves' check 66.1 % fixed, 116 fixed
/// epochs beyond 10 cm (worst 0.28 m), float NEES 6.1.
#[test]
fn the_long_baseline_faults_never_come_with_centimetre_sigmas() {
    let dir = tmp("long-baseline-faults");
    let _ = std::fs::remove_dir_all(&dir);
    succeeds(&ppkat(&[
        "simulate",
        "--builtin",
        "long-baseline",
        "-o",
        p(&dir),
    ]));
    let faults = dir.join("faults");
    let readme = std::fs::read_to_string(faults.join("README.txt")).unwrap();
    assert!(readme.contains("slips by one cycle"), "{readme}");
    let t = succeeds(&ppkat(&["ppk", "--config", p(&faults.join("ppk.toml"))]));
    assert!(t.contains("post-fit outliers"), "{t}");
    let f = against_truth(&faults);
    eprintln!("long baseline with faults: {f:?}");
    assert!(f.solved == 2881, "{f:?}");
    assert!(f.confident_and_wrong.is_empty(), "{f:?}");
    // What the faults cost, against the clean pair's 82.6 %: the hours around them.
    assert!(f.fixed_share > 0.5 && f.rms_3d < 0.2, "{f:?}");
    let fixed = f.fixed_share * f.solved as f64;
    assert!(f.fixed_beyond_15_cm as f64 <= 0.01 * fixed, "{f:?}");
    assert!((0.3..=3.0).contains(&f.nees.0), "NEES fixed {f:?}");
    assert!((0.3..=3.0).contains(&f.nees.1), "NEES float {f:?}");
}

/// A long-baseline folder's `ppk.pos` against the rover of its `truth.toml`.
#[derive(Debug)]
struct BenchFigures {
    solved: usize,
    fixed_share: f64,
    rms_3d: f64,
    worst_fixed: f64,
    /// Epochs more than 1 m off with a 3D σ under 10 cm (time, error, σ).
    confident_and_wrong: Vec<String>,
    /// Fixed epochs more than 15 cm off.
    fixed_beyond_15_cm: usize,
    /// Mean of eᵀC⁻¹e / 3 over the fixed and over the float epochs (full ENU covariance).
    nees: (f64, f64),
}

fn against_truth(dir: &Path) -> BenchFigures {
    let truth = std::fs::read_to_string(dir.join("truth.toml")).unwrap();
    let rover: Vec<f64> = truth
        .lines()
        .find_map(|l| l.strip_prefix("rover = ["))
        .expect("a rover line")
        .trim_end_matches(']')
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    let rows = pos_rows(&dir.join("ppk.pos"));
    let (mut fixed, mut sum2, mut worst) = (0, 0.0, 0.0f64);
    let mut confident_and_wrong = Vec::new();
    let (mut beyond, mut nees) = (0, [(0.0, 0usize); 2]);
    let truth = ::gnss::frame::Ecef::new(rover[0], rover[1], rover[2]);
    for r in &rows {
        let f = |k: usize| r[k].parse::<f64>().unwrap();
        let pos = ::gnss::frame::Geodetic::from_degrees(f(2), f(3), f(4)).to_ecef();
        let d = (pos.0 - truth.0).norm();
        sum2 += d * d;
        if r[5] == "1" {
            fixed += 1;
            worst = worst.max(d);
            beyond += usize::from(d > 0.15);
        }
        let n = &mut nees[usize::from(r[5] != "1")];
        n.0 += pos_row_nees(r, &pos, &truth);
        n.1 += 1;
        let sigma = (f(7).powi(2) + f(8).powi(2) + f(9).powi(2)).sqrt();
        if d > 1.0 && sigma < 0.1 {
            confident_and_wrong.push(format!("{} {}: {d:.2} m, σ {sigma:.3}", r[0], r[1]));
        }
    }
    BenchFigures {
        solved: rows.len(),
        fixed_share: fixed as f64 / rows.len() as f64,
        rms_3d: (sum2 / rows.len() as f64).sqrt(),
        worst_fixed: worst,
        confident_and_wrong,
        fixed_beyond_15_cm: beyond,
        nees: (
            nees[0].0 / nees[0].1.max(1) as f64,
            nees[1].0 / nees[1].1.max(1) as f64,
        ),
    }
}

/// eᵀC⁻¹e / 3 of one `.pos` row at `pos` (its llh as ECEF; the row holds RTKLIB's signed
/// square roots of the ENU covariance) against `truth`.
fn pos_row_nees(r: &[String], pos: &::gnss::frame::Ecef, truth: &::gnss::frame::Ecef) -> f64 {
    let f = |k: usize| r[k].parse::<f64>().unwrap();
    let e = pos.enu_from(truth).0;
    let v = |k: usize| f(k).signum() * f(k) * f(k);
    // sdn sde sdu sdne sdeu sdun, in E, N, U order
    let c = nalgebra::Matrix3::new(v(8), v(10), v(11), v(10), v(7), v(12), v(11), v(12), v(9));
    let i = c.try_inverse().expect("a covariance");
    (e.transpose() * i * e)[0] / 3.0
}
