//! Hostile inputs found by reading the parsers (issue 19's audit): each once panicked, hung or
//! allocated without bound, and must now be a counted skip or an error naming file and line.

use gnss::model::antex::Antex;
use gnss::orbit::Ephemerides;
use gnss::rinex::nav::{NavFile, NavKind, NavRecord};
use gnss::rinex::ObsFile;
use gnss::sv::{Constellation, Sv};
use std::path::PathBuf;
use testkit::scratch_file as file;

/// A header line: `content` padded to column 60, then the label.
fn hl(content: &str, label: &str) -> String {
    format!("{content:<60}{label}\n")
}

/// The first line of a RINEX 3.04 GPS observation file.
fn version_line() -> String {
    hl(
        "     3.04           OBSERVATION DATA    G",
        "RINEX VERSION / TYPE",
    )
}

#[test]
fn a_negative_count_of_observation_types_is_an_error_at_its_line() {
    for count in ["-1", "-99"] {
        let text = version_line()
            + &hl(&format!("G {count:>4} C1C"), "SYS / # / OBS TYPES")
            + &hl("", "END OF HEADER");
        let p = file(&format!("count{count}.rnx"), text.as_bytes());
        let e = ObsFile::read(&p).unwrap_err().to_string();
        assert!(
            e.contains(&format!("count{count}.rnx:2")) && e.contains("0..=999"),
            "{count}: {e}"
        );
    }
}

#[test]
fn a_line_of_megabytes_is_an_error_not_a_buffer_of_the_whole_file() {
    let mut text = version_line().into_bytes();
    text.extend(vec![b'A'; 3 << 20]);
    let p = file("long-line.rnx", &text);
    let e = ObsFile::read(&p).unwrap_err().to_string();
    assert!(
        e.contains("long-line.rnx:2") && e.contains("longer than 1024 KiB"),
        "{e}"
    );
}

#[test]
fn an_antex_validity_date_that_is_no_date_is_an_error() {
    for (name, date) in [
        ("feb30", "  2021     2    30     0     0    0.0000000"),
        ("sec60", "  2021     1     1     0     0   60.2000000"),
    ] {
        let text = hl(
            "     1.4            M                                       ",
            "ANTEX VERSION / SYST",
        ) + &hl("", "END OF HEADER")
            + &hl("", "START OF ANTENNA")
            + &hl(
                "BLOCK IIF           G01                 G063      2010-022A ",
                "TYPE / SERIAL NO",
            )
            + &hl(date, "VALID FROM")
            + &hl("", "END OF ANTENNA");
        let p = file(&format!("{name}.atx"), text.as_bytes());
        let e = Antex::read(&p).unwrap_err().to_string();
        assert!(
            e.contains(&format!("{name}.atx:")) && e.contains("validity date"),
            "{e}"
        );
    }
}

/// A GPS record with the elements of a real satellite (G01, 2020-06-25).
fn gps_record(line: usize) -> NavRecord {
    let mut orbit = vec![0.0; 28];
    orbit[..17].copy_from_slice(&[
        62.0, -52.0, 4.3e-9, 1.2, -2.7e-6, 0.0089, 8.1e-6, 5153.7, 345_600.0, 1.1e-7, -1.3,
        -5.6e-8, 0.97, 220.0, 0.81, -8.0e-9, 1.0e-10,
    ]);
    orbit[22] = 5.1e-9;
    NavRecord {
        sv: Sv::new(Constellation::Gps, 1),
        kind: NavKind::Kepler,
        toc: gnss::time::gpst(2020, 6, 25, 0, 0, 0, 0),
        clock: [-1.7e-4, -1.1e-11, 0.0],
        orbit,
        line,
    }
}

#[test]
fn non_finite_or_impossible_ephemerides_are_skipped_and_named() {
    let mut nan_toe = gps_record(9);
    nan_toe.orbit[8] = f64::NAN;
    let mut blank = gps_record(17);
    blank.orbit.iter_mut().for_each(|v| *v = 0.0);
    let mut inf_clock = gps_record(25);
    inf_clock.clock[0] = f64::INFINITY;
    let mut nan_health = gps_record(33);
    nan_health.orbit[21] = f64::NAN;
    let nav = NavFile {
        path: PathBuf::from("hostile.nav"),
        version: 3.04,
        records: vec![gps_record(1), nan_toe, blank, inf_clock, nan_health],
        ..NavFile::default()
    };
    let e = Ephemerides::from_nav(&[nav]);
    assert_eq!(e.stats.records, 5);
    let lines: Vec<&str> = e.stats.skipped.iter().map(String::as_str).collect();
    assert_eq!(lines.len(), 4, "{lines:?}");
    for (k, l) in [9, 17, 25, 33].iter().enumerate() {
        assert!(
            lines[k].starts_with(&format!("hostile.nav:{l}: record of G01")),
            "{lines:?}"
        );
    }
    assert!(lines[1].contains("√A = 0"), "{lines:?}");
    // The real record stays, and gives a finite position.
    let sv = Sv::new(Constellation::Gps, 1);
    let t = gnss::time::gpst(2020, 6, 25, 1, 0, 0, 0);
    let eph = e.select(sv, t).expect("the good record");
    let (p, clock) = eph.position_clock(t);
    assert!(p.0.norm() > 2.0e7 && p.0.norm() < 3.0e7 && clock.is_finite());
}

#[test]
fn rinex_numbers_that_are_not_finite_are_unreadable() {
    use gnss::rinex::lines::parse_real;
    for s in ["NaN", "inf", "-inf", "1.0D+999", "  1e400"] {
        assert_eq!(parse_real(s.as_bytes()), Err(()), "{s}");
    }
    assert_eq!(parse_real(b" 1.5D+02"), Ok(Some(150.0)));
}

#[test]
fn raw_log_times_out_of_range_saturate_instead_of_overflowing() {
    use gnss::raw::items::gpst;
    let end = gpst(u16::MAX, 604_799.0);
    assert!(end > gpst(15_250, 0.0), "week 65535 lies after week 15250");
    for tow in [9.3e10, f64::INFINITY, f64::NEG_INFINITY, f64::NAN, -1e12] {
        let _ = gpst(u16::MAX, tow);
        let _ = gpst(0, tow);
    }
    assert_eq!(
        gpst(0, -5.0),
        gpst(0, 0.0),
        "before the GPS epoch clamps to it"
    );
    assert_eq!(
        gpst(2315, 345_600.5),
        gnss::time::gpst(2024, 5, 23, 0, 0, 0, 500_000_000),
        "ordinary times unchanged"
    );
}

#[test]
fn short_records_under_a_header_of_999_types_cost_their_size_not_the_header_s() {
    // 999 types, then epochs of 12 satellites each holding one value: before, every record
    // kept 999 slots (16 kB for a line of 20 bytes, 800 times the file).
    let mut text = version_line();
    let codes: Vec<String> = (0..999)
        .map(|k| format!("C{}{}", 1 + k % 9, (b'A' + (k / 9 % 26) as u8) as char))
        .collect();
    for (i, chunk) in codes.chunks(13).enumerate() {
        let head = if i == 0 {
            "G  999".to_string()
        } else {
            " ".repeat(6)
        };
        text += &hl(
            &format!("{head} {}", chunk.join(" ")),
            "SYS / # / OBS TYPES",
        );
    }
    text += &hl("", "END OF HEADER");
    for e in 0..50 {
        text += &format!("> 2024 01 01 00 00 {:>2}.0000000  0 12\n", e);
        for prn in 1..=12 {
            text += &format!("G{prn:02}  20000000.000\n");
        }
    }
    let f = ObsFile::read(&file("999types.rnx", text.as_bytes())).unwrap();
    assert_eq!(f.epochs.len(), 50);
    assert_eq!(f.header.types_of(Constellation::Gps).len(), 999);
    for s in f.epochs.iter().flat_map(|e| &e.sats) {
        assert_eq!(
            s.obs.len(),
            1,
            "the blank fields after the value are not kept"
        );
        assert!(s.obs.capacity() < 8, "nor their room: {}", s.obs.capacity());
        assert_eq!(s.get(0).value, 20_000_000.0);
        assert!(!s.get(998).is_present());
    }
}

#[test]
fn sp3_epochs_without_positions_cannot_ask_for_gigabytes() {
    // 100,000 epoch lines, then one position for each of 600 satellites: 60 million slots
    // (1.9 GB) for a file of 3 MB.
    let mut text = String::from("#dP2020  6 25  0  0  0.00000000     96 ORBIT IGS14 HLM  IGS\n");
    for k in 0..100_000 {
        text += &format!("*  2020  6 25  0  0 {:>2}.{:08}\n", k % 60, k);
    }
    for sys in ['G', 'E', 'C', 'R', 'J', 'I'] {
        for prn in 1..=99 {
            text += &format!(
                "P{sys}{prn:02}  -1000.000000  20000.000000  15000.000000      1.000000\n"
            );
        }
    }
    let p = file("sparse.sp3", text.as_bytes());
    let e = gnss::orbit::sp3::Sp3::read(&p).unwrap_err().to_string();
    assert!(
        e.contains("sparse.sp3:") && e.contains("not a usable SP3"),
        "{e}"
    );
}
