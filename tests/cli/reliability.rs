//! Issue 19's findings, replayed end to end: hostile photos, non-finite numbers, runs that
//! solve nothing, skipped inputs and the exit code 3, error texts.

use super::*;

/// The hostile photo `name` of `tests/fixtures/exif`.
fn hostile(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/exif")
        .join(name)
}

/// A file of this test run's temporary folder with `text`.
fn file(name: &str, text: &[u8]) -> PathBuf {
    let f = tmp(name);
    std::fs::write(&f, text).unwrap();
    f
}

/// `ppkat exposures` on the demo's trajectory with `extra` arguments, output into `out`.
fn exposures(out: &Path, extra: &[&str]) -> Output {
    let traj = demo_dir().join("rover_ppk.pos");
    let mut args = vec!["exposures", "--trajectory", p(&traj), "-o", p(out)];
    args.extend_from_slice(extra);
    ppkat(&args)
}

/// Three exposures 3 s apart inside the demo's flight (GPS week 2318).
const TIMES: &str = "id,week,tow\nA,2318,291700\nB,2318,291703\nC,2318,291706\n";

#[test]
fn exposures_outside_the_trajectory_are_named_with_exit_code_3() {
    let times = file(
        "times-outside.csv",
        format!("{TIMES}D,2318,100\n").as_bytes(),
    );
    let out = tmp("outside.csv");
    let o = exposures(&out, &["--times", p(&times)]);
    skips(
        &o,
        &["1 input(s) skipped", "exposure D", "outside the trajectory"],
    );
    // The three inside are placed, each once, and D is not.
    let body = std::fs::read_to_string(&out).unwrap();
    let ids: Vec<&str> = body
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(ids, ["A", "B", "C"], "{body}");
}

#[test]
fn hostile_photos_cost_one_message_each_and_the_rest_are_geotagged() {
    let photos = tmp("hostile-photos");
    std::fs::create_dir_all(&photos).unwrap();
    std::fs::copy(fixture("photo_16x16.jpg"), photos.join("a_good.jpg")).unwrap();
    for n in ["self_loop.jpg", "renamed_png.jpg"] {
        std::fs::copy(hostile(n), photos.join(n)).unwrap();
    }
    let times = file("times-photos.csv", TIMES.as_bytes());
    let (out, tagged) = (tmp("photos.csv"), tmp("tagged"));
    // Matching alone: the photo whose EXIF loops is named, the rest used.
    let o = exposures(&out, &["--times", p(&times), "--photos", p(&photos)]);
    skips(&o, &["self_loop.jpg", "EXIF cannot be read"]);
    let o = exposures(
        &out,
        &[
            "--times",
            p(&times),
            "--photos",
            p(&photos),
            "--geotag",
            p(&tagged),
        ],
    );
    let png = photos.join("renamed_png.jpg");
    skips(
        &o,
        &["2 input(s) skipped", p(&png), "not a JPEG", "self_loop.jpg"],
    );
    let mut written: Vec<String> = std::fs::read_dir(&tagged)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    written.sort();
    assert_eq!(written, ["a_good.jpg"], "no untagged copy, no temporary");
}

#[test]
fn non_finite_numbers_are_refused_at_the_line_and_column() {
    let out = tmp("nan.csv");
    for (name, text, needles) in [
        (
            "tow-nan.csv",
            "id,week,tow\nA,2318,NaN\n",
            &["tow-nan.csv:2", "seconds of week NaN"][..],
        ),
        (
            "tow-inf.csv",
            "id,week,tow\nA,2318,inf\n",
            &["tow-inf.csv:2", "seconds of week inf"][..],
        ),
    ] {
        let f = file(name, text.as_bytes());
        fails_with(&exposures(&out, &["--times", p(&f)]), needles);
    }
    let mrk = file(
        "nan.MRK",
        b"1\tNaN\t[2318]\t1,N\t2,E\t3,V\t47.3,Lat\t8.5,Lon\t830,Ellh\t0.01, 0.01, 0.02\t50,Q\n",
    );
    fails_with(
        &exposures(&out, &["--mrk", p(&mrk)]),
        &["nan.MRK:1", "column", "seconds of week"],
    );
    let times = file("times-att.csv", TIMES.as_bytes());
    for (k, angle) in ["inf", "1e308", "1e20", "NaN"].into_iter().enumerate() {
        let att = file(
            &format!("att-{k}.csv"),
            format!("week,tow,yaw,pitch,roll\n2318,291600,0,0,0\n2318,291800,{angle},0,0\n")
                .as_bytes(),
        );
        fails_with(
            &exposures(&out, &["--times", p(&times), "--attitude", p(&att)]),
            &[&format!("att-{k}.csv:3"), "column 3", "degrees"],
        );
    }
    let att = file(
        "att-tow.csv",
        b"week,tow,yaw,pitch,roll\n2318,291600,0,0,0\n2318,NaN,0,0,0\n",
    );
    fails_with(
        &exposures(&out, &["--times", p(&times), "--attitude", p(&att)]),
        &["att-tow.csv:3", "seconds of week"],
    );
    let o = ppkat(&[
        "leverarm", "--tapes", "1,1,1,1", "--ruler", "1", "--sigma", "NaN",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let o = exposures(&out, &["--times", p(&times), "--delay-ms", "inf"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

#[test]
fn runs_that_solve_nothing_fail_and_say_why() {
    let d = demo_dir();
    let (rover, base, nav) = (d.join("rover.obs"), d.join("base.obs"), d.join("nav.rnx"));
    for (name, extra, ppk_says) in [
        (
            "mask",
            ["--elev-mask", "89"],
            &[
                "rover.obs",
                "none of the 2379 epochs could be solved",
                "too few satellites",
                "--elev-mask",
            ][..],
        ),
        (
            "systems",
            ["--systems", "C"],
            &[
                "base.obs",
                "no epoch holds phase of the processed systems (C)",
                "--systems",
            ][..],
        ),
    ] {
        let out = tmp(&format!("nothing-{name}.pos"));
        let o = ppkat(
            &[
                &["spp", "--obs", p(&rover), "--nav", p(&nav), "-o", p(&out)][..],
                &extra,
            ]
            .concat(),
        );
        fails_with(
            &o,
            &["none of the", "epochs could be solved", "--elev-mask"],
        );
        assert!(!out.exists(), "no header-only .pos");
        let o = ppkat(&ppk_args(&rover, &base, &[&nav], &out, &extra));
        fails_with(&o, ppk_says);
        assert!(!out.exists(), "no header-only .pos");
    }
}

#[test]
fn error_texts_say_what_is_wrong_once() {
    let bin = file("binary.csv", &[0x66, 0x6f, 0xff, 0xfe, 0x0a, 0x80]);
    let o = exposures(&tmp("x.csv"), &["--times", p(&bin)]);
    fails_with(&o, &["binary.csv", "not text"]);
    let t = text(&o);
    assert!(!t.contains("check that the path exists"), "{t}");
    assert_eq!(t.matches("UTF-8").count(), 1, "said once: {t}");
    let bal = file("bad.bal", b"1 1 1\n0 0 1.0 2.0\n1 2 3 4 5 6 7 8 x\n");
    fails_with(&ppkat(&["bal", p(&bal)]), &["bad.bal:3", "'x'"]);
    let bal = file("huge.bal", b"1 1 1e11\n0 0 1.0 2.0\n");
    fails_with(&ppkat(&["bal", p(&bal)]), &["huge.bal:2", "ends before"]);
}

/// Output folders are replaced whole, so one holding files the command does not write is
/// refused and left as it was (import, geotag); geotagging into the photos' own folder too.
#[test]
fn output_folders_holding_other_files_are_refused_untouched() {
    let im = file("refuse.im", b"1\nT1 0.1 0.2\nT2 0.3 0.4\n-99\n");
    let out = tmp("refuse-import");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let import = [
        "import",
        "patb",
        "--images",
        p(&im),
        "--focal-mm",
        "35",
        "--pixel-um",
        "10",
        "--width-px",
        "1000",
        "--height-px",
        "800",
        "-o",
        p(&out),
    ];
    fails_with(&ppkat(&import), &["refuse-import", "holds `notes.txt`"]);
    std::fs::remove_file(out.join("notes.txt")).unwrap();
    succeeds(&ppkat(&import));
    succeeds(&ppkat(&import));
    let photos = tmp("refuse-photos");
    std::fs::create_dir_all(&photos).unwrap();
    std::fs::copy(fixture("photo_16x16.jpg"), photos.join("a.jpg")).unwrap();
    let original = std::fs::read(photos.join("a.jpg")).unwrap();
    let times = file("refuse-times.csv", b"id,week,tow\nA,2318,291700\n");
    let tagged = tmp("refuse-tagged");
    std::fs::create_dir_all(&tagged).unwrap();
    std::fs::write(tagged.join("notes.txt"), "mine").unwrap();
    let csv = tmp("refuse.csv");
    let geotag = |dir: &Path| {
        exposures(
            &csv,
            &[
                "--times",
                p(&times),
                "--photos",
                p(&photos),
                "--geotag",
                p(dir),
            ],
        )
    };
    fails_with(&geotag(&tagged), &["refuse-tagged", "holds `notes.txt`"]);
    assert_eq!(std::fs::read(tagged.join("notes.txt")).unwrap(), b"mine");
    fails_with(&geotag(&photos), &["overwrite an original"]);
    assert_eq!(std::fs::read(photos.join("a.jpg")).unwrap(), original);
    std::fs::remove_file(tagged.join("notes.txt")).unwrap();
    succeeds(&geotag(&tagged));
    assert!(tagged.join("a.jpg").exists());
}

/// A `.pos` the `pos` fuzz target mutated: an infinite second (`00.09e9800`) in line 6
/// panicked inside the time library; now it is refused at its line.
#[test]
fn a_fuzzed_pos_with_an_infinite_second_is_refused_at_its_line() {
    let pos = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/fuzz/pos-infinite-second.pos");
    let times = file("times-fuzzed-pos.csv", TIMES.as_bytes());
    let out = tmp("fuzzed-pos.csv");
    fails_with(
        &ppkat(&[
            "exposures",
            "--trajectory",
            p(&pos),
            "--times",
            p(&times),
            "-o",
            p(&out),
        ]),
        &["pos-infinite-second.pos:6", "unreadable date/time"],
    );
}

#[test]
fn project_tables_refuse_a_zero_sigma_and_a_week_beyond_any_log() {
    let dir = tmp("rel-tables");
    succeeds(&ppkat(&[
        "simulate",
        "--builtin",
        "classic-block",
        "-o",
        p(&dir),
    ]));
    let project = dir.join("project.toml");
    let edit = |name: &str, from: &str, to: &str| {
        let f = dir.join(name);
        let text = std::fs::read_to_string(&f).unwrap();
        assert!(text.contains(from), "{name}: {from}");
        std::fs::write(&f, text.replacen(from, to, 1)).unwrap();
        text
    };
    // A σ of 0 px weighted its observation infinitely (a division by zero in the solver).
    let kept = edit("image_observations.csv", ",0.5\n", ",0\n");
    let o = ppkat(&["adjust", "--project", p(&project), "-o", p(&dir.join("o1"))]);
    fails_with(
        &o,
        &["image_observations.csv, line 2", "σ must be positive"],
    );
    std::fs::write(dir.join("image_observations.csv"), kept).unwrap();
    // A week of 10⁹ saturated to 4294967295 and placed the antenna in year 82 million.
    let kept = edit("antennas.csv", "\n101,2314,", "\n101,1000000000,");
    let o = ppkat(&["adjust", "--project", p(&project), "-o", p(&dir.join("o2"))]);
    fails_with(&o, &["antennas.csv, line 3", "week"]);
    // A segment of -1 became 0 (`as u32`), joining the trajectory's first segment.
    std::fs::write(dir.join("antennas.csv"), kept).unwrap();
    edit("antennas.csv", ",1,0\n", ",1,-1\n");
    let o = ppkat(&["adjust", "--project", p(&project), "-o", p(&dir.join("o3"))]);
    fails_with(&o, &["antennas.csv, line 3", "-1 in column segment"]);
    assert!(!dir.join("o1").exists() && !dir.join("o2").exists() && !dir.join("o3").exists());
}

/// A fuzzed times CSV (the fuzzer's timeout): a year of 5,262,210 walked hifitime's calendar
/// year by year, 20 ms a line (10 s under the fuzzer's instrumentation); a file of such lines
/// ran for hours. Years outside 1980–2200 are now an unreadable time at their line, as are
/// huge years in a `.pos`.
#[test]
fn a_year_of_millions_is_an_unreadable_time_not_hours_of_calendar() {
    let times = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/fuzz/times-year-5262210.csv");
    let o = exposures(&tmp("year-csv.csv"), &["--times", p(&times)]);
    fails_with(&o, &["times-year-5262210.csv:2", "unreadable time"]);
    let pos = demo_dir().join("rover_ppk.pos");
    let text = std::fs::read_to_string(&pos).unwrap();
    let first = text.lines().find(|l| !l.starts_with('%')).unwrap();
    let year = first.split('/').next().unwrap();
    let bad = file(
        "year-pos.pos",
        text.replacen(first, &first.replacen(year, "52622100", 1), 1)
            .as_bytes(),
    );
    let times = file("year-times.csv", TIMES.as_bytes());
    let o = ppkat(&[
        "exposures",
        "--trajectory",
        p(&bad),
        "--times",
        p(&times),
        "-o",
        p(&tmp("year-pos.csv")),
    ]);
    fails_with(&o, &["year-pos.pos", "unreadable date/time"]);
}

/// A fuzzed geoid grid (the `geoid` target's timeout): a PGM of 0 columns and 4.4·10¹² rows
/// needs no sample bytes, so it passed the size check and its rows were walked one by one
/// (the release binary still ran after 60 s).
/// Now it is refused before a single exposure is written.
#[test]
fn a_geoid_pgm_of_zero_columns_is_refused_not_walked_for_hours() {
    let grid = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/fuzz/geoid-pgm-zero-columns.pgm");
    let times = file("times-geoid.csv", TIMES.as_bytes());
    let spec = format!("geoid:{}", p(&grid));
    let out = tmp("geoid-zero.csv");
    let o = exposures(&out, &["--times", p(&times), "--height", &spec]);
    fails_with(
        &o,
        &["geoid-pgm-zero-columns.pgm", "0 × 4444444444443 samples"],
    );
    let t = text(&o);
    assert_eq!(
        t.matches("geoid-pgm-zero-columns.pgm").count(),
        1,
        "named once: {t}"
    );
    assert!(!out.exists());
}
