//! RINEX clock files: the hand-made fixtures in the 2.00 and 3.04 layouts (record counts,
//! values, continuation lines, unknown systems, gzip), interpolation of their clocks in the
//! precise orbits, and bad input (every error names the file and the line).

use gnss::orbit::{ClockFile, ClockSource, PreciseOrbits, Sp3, Unavailable};
use gnss::sv::{Constellation, Sv};
use gnss::time::gpst;
use gnss::Error;
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};
use testkit::scratch_path as tmp;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures")
        .join(name)
}

fn g(prn: u8) -> Sv {
    Sv::new(Constellation::Gps, prn)
}

/// 2020-06-25 00:mm:ss GPST.
fn at(min: u32, sec: u32) -> Epoch {
    gpst(2020, 6, 25, 0, min as u8, sec as u8, 0)
}

#[test]
fn rinex_clock_2_00() {
    let f = ClockFile::read(&fixture("clock_v200.clk")).unwrap();
    assert_eq!(f.version, 2.0);
    // 7 epochs: G01 misses one, G02 two; R03 all; one L51 record (system unknown).
    assert_eq!(f.records, 6 + 5 + 7 + 1);
    assert_eq!(f.unknown_system, 1);
    assert_eq!(f.interval, 300.0);
    assert_eq!(f.sats.len(), 3);
    assert_eq!(f.sats[&g(1)].len(), 6);
    assert_eq!(f.sats[&g(2)].len(), 5);
    let r03 = &f.sats[&Sv::new(Constellation::Glonass, 3)];
    assert_eq!(
        r03.len(),
        7,
        "the record after the continuation line is read"
    );
    assert_eq!(r03[1], (at(5, 0), 5.015e-5));
    assert_eq!(f.sats[&g(2)][1], (at(5, 0), -0.25006e-3));
    assert_eq!(f.span(), Some((at(0, 0), at(30, 0))));
}

#[test]
fn rinex_clock_3_04_plain_and_gzip() {
    let plain = fixture("clock_v304.clk");
    let gz = tmp("clock_v304.clk.gz");
    let mut enc = flate2::write::GzEncoder::new(
        std::fs::File::create(&gz).unwrap(),
        flate2::Compression::default(),
    );
    std::io::copy(&mut std::fs::File::open(&plain).unwrap(), &mut enc).unwrap();
    enc.finish().unwrap();
    for p in [plain, gz] {
        let f = ClockFile::read(&p).unwrap();
        assert_eq!(f.version, 3.04);
        assert_eq!(f.records, 7 + 7 + 6);
        assert_eq!(f.interval, 30.0);
        let g05 = &f.sats[&g(5)];
        assert_eq!(g05[2], (at(1, 0), -1.06018e-5));
        assert_eq!(
            f.sats[&Sv::new(Constellation::Galileo, 11)][1].1,
            2.000003e-4
        );
        assert_eq!(f.sats[&Sv::new(Constellation::BeiDou, 20)].len(), 6);
    }
}

/// A synthetic SP3 of the given satellites on a slow circular orbit, every 15 min from
/// 2020-06-24 22:00 to 2020-06-25 02:00, without clocks.
fn sp3_for(svs: &[Sv]) -> Sp3 {
    let mut f = Sp3 {
        path: PathBuf::from("synthetic.sp3"),
        version: 'c',
        frame: "IGS14".into(),
        interval: 900.0,
        ..Sp3::default()
    };
    let t0 = gpst(2020, 6, 24, 22, 0, 0, 0);
    for k in 0..17 {
        f.epochs.push(t0 + Duration::from_seconds(900.0 * k as f64));
    }
    for &sv in svs {
        let v = (0..17)
            .map(|k| {
                let a = k as f64 * 0.13 + sv.prn as f64;
                (Vector3::new(a.cos(), a.sin(), 0.2) * 2.6e7, f64::NAN)
            })
            .collect();
        f.sats.insert(sv, v);
    }
    f
}

#[test]
fn clock_file_clocks_are_interpolated_linearly_and_not_across_gaps() {
    let clk = ClockFile::read(&fixture("clock_v200.clk")).unwrap();
    let r03 = Sv::new(Constellation::Glonass, 3);
    let sp3 = sp3_for(&[g(1), g(2), r03, g(9)]);
    let p = PreciseOrbits::new(&[sp3], &[clk]).unwrap();
    assert_eq!(p.clock_source, ClockSource::ClockFiles);
    // Records come back exactly; between records the straight line of the fixture.
    assert_eq!(p.clock(g(1), at(5, 0)).unwrap().0, 1.0003e-4);
    let (c, rate) = p.clock(g(1), at(7, 30)).unwrap();
    assert!((c - (1e-4 + 450.0e-10)).abs() < 1e-17, "{c}");
    assert!((rate - 1e-10).abs() < 1e-16, "{rate}");
    // G01 misses 00:20: 00:15–00:25 is 2 intervals, bridged.
    let (c, _) = p.clock(g(1), at(20, 0)).unwrap();
    assert!((c - (1e-4 + 1200.0e-10)).abs() < 1e-17, "{c}");
    // G02 misses 00:10 and 00:15: 00:05–00:20 is 3 intervals, not bridged.
    assert!(p.clock(g(2), at(12, 0)).is_none());
    assert!(p.clock(g(2), at(5, 0)).is_some() && p.clock(g(2), at(20, 0)).is_some());
    assert_eq!(
        p.compute(g(2), at(12, 0)).unwrap_err(),
        Unavailable::NoClock
    );
    // No extrapolation beyond the last record; no clock at all for G09.
    assert!(p.clock(g(1), at(30, 0)).is_some());
    assert!(p.clock(g(1), at(30, 1)).is_none());
    assert_eq!(
        p.compute(g(9), at(10, 0)).unwrap_err(),
        Unavailable::NoClock
    );
    // The relativistic correction is added to the interpolated clock by `compute`.
    let s = p.compute(g(1), at(7, 30)).unwrap();
    let (pos, vel) = p.position(g(1), at(7, 30)).unwrap();
    let rel = -2.0 * pos.dot(&vel) / (gnss::orbit::C * gnss::orbit::C);
    assert!((s.clock - (1e-4 + 450.0e-10 + rel)).abs() < 1e-17);
    // Outside the orbit tables there is no orbit, whatever the clocks.
    let late = gpst(2020, 6, 25, 2, 0, 1, 0);
    assert_eq!(p.compute(g(1), late).unwrap_err(), Unavailable::NoOrbit);
}

/// The error of reading `text` as a clock file: it names the file and, for a line, the line.
fn error_of(name: &str, text: &str) -> String {
    let p = tmp(name);
    std::fs::write(&p, text).unwrap();
    let e = ClockFile::read(&p).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains(&p.display().to_string()), "{msg}");
    msg
}

/// The v2.00 fixture with line `n` (1-based) replaced by `line` (or removed when `None`),
/// cut after line `keep`.
fn edited(n: usize, line: Option<&str>, keep: usize) -> String {
    let text = std::fs::read_to_string(fixture("clock_v200.clk")).unwrap();
    let mut out = String::new();
    for (i, l) in text.lines().enumerate().take(keep) {
        match (i + 1 == n, line) {
            (true, Some(r)) => out.push_str(r),
            (true, None) => continue,
            _ => out.push_str(l),
        }
        out.push('\n');
    }
    out
}

fn parse_line(e: &Error) -> Option<usize> {
    match e {
        Error::Parse { line, .. } => Some(*line),
        _ => None,
    }
}

#[test]
fn bad_clock_files_name_file_and_line() {
    let all = usize::MAX;
    // Line 15 is the first AS record (G01 at 00:00).
    let truncated = edited(15, Some("AS G01  2020  6 25  0  0  0.0000"), all);
    let msg = error_of("truncated.clk", &truncated);
    assert!(msg.contains(":15:") && msg.contains("truncated"), "{msg}");
    let garbled = edited(
        15,
        Some("AS G01  2020  6 25  0  0  0.000000  2    1.0000x0000000E-04  1.0E-11"),
        all,
    );
    let msg = error_of("garbled.clk", &garbled);
    assert!(msg.contains(":15:") && msg.contains("clock bias"), "{msg}");
    let bad_date = edited(
        15,
        Some("AS G01  2020 13 25  0  0  0.000000  1    1.0E-04"),
        all,
    );
    assert!(error_of("date.clk", &bad_date).contains(":15:"));
    let bad_name = edited(
        15,
        Some("AS G0?  2020  6 25  0  0  0.000000  1    1.0E-04"),
        all,
    );
    assert!(error_of("name.clk", &bad_name).contains("satellite name"));
    // A stray line among the records.
    let stray = edited(16, Some("these are not clocks"), all);
    let msg = error_of("stray.clk", &stray);
    assert!(
        msg.contains(":16:") && msg.contains("not a clock data record"),
        "{msg}"
    );
    // Cut right after a record that announces a continuation line (R03 at 00:05, line 22).
    let cut = edited(0, None, 22);
    let msg = error_of("cut.clk", &cut);
    assert!(msg.contains(":22:") && msg.contains("truncated"), "{msg}");
    // Not a clock file, no header end, no record.
    let p = fixture("events_v304.rnx");
    assert!(ClockFile::read(&p)
        .unwrap_err()
        .to_string()
        .contains("not a RINEX clock file"));
    assert!(error_of("noend.clk", &edited(0, None, 12)).contains("END OF HEADER"));
    assert!(error_of("empty.clk", &edited(0, None, 13)).contains("no satellite clock"));
    // The line number is also in the typed error.
    let p = tmp("typed.clk");
    std::fs::write(&p, &garbled).unwrap();
    assert_eq!(parse_line(&ClockFile::read(&p).unwrap_err()), Some(15));
    assert!(ClockFile::read(Path::new("/nonexistent/x.clk")).is_err());
}
