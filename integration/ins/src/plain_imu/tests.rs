use super::*;
use crate::spec::G0;

/// 2026-06-01 10:00:00 GPST: week 2421, second 122400.
fn near() -> Epoch {
    gnss::time::from_week_tow(2421, 122_400.0)
}

/// A 100 Hz CSV turning 10 °/s about z, 1 g down, with `rows` lines after `header`.
fn csv(header: &str, row: impl Fn(usize, f64) -> String, n: usize) -> String {
    let mut s = format!("# a comment\n{header}\n");
    for k in 0..n {
        s += &row(k, 122_400.0 + k as f64 * 0.01);
        s.push('\n');
    }
    s
}

#[test]
fn rates_in_degrees_and_g_read_as_increments() {
    let text = csv(
        "gpst_week,gpst_tow,extra,gx_dps,gy_dps,gz_dps,ax_g,ay_g,az_g",
        |_, t| format!("2421,{t:.3},7,0,0,10,0,0,-1"),
        50,
    );
    let p = testkit::scratch_file("plain_imu_rates.csv", text);
    let (log, notes) = read_csv(&p, near()).unwrap();
    assert!(notes.is_empty() && log.skipped.is_empty() && log.gaps.is_empty());
    assert_eq!(log.samples.len(), 49);
    let s = log.samples[0];
    assert!((s.dt - 0.01).abs() < 1e-9);
    assert!((s.dtheta.z - 10f64.to_radians() * 0.01).abs() < 1e-9);
    assert!((s.dv.z + G0 * 0.01).abs() < 1e-9);
    assert_eq!(s.time, gnss::time::from_week_tow(2421, 122_400.01));
}

#[test]
fn increments_with_seconds_of_week_take_the_nearest_week() {
    // KF-GINS: tow and increments, whitespace; the file crosses into the next week.
    let mut text = String::new();
    for k in 0..20 {
        let tow = (604_799.9 + k as f64 * 0.01) % 604_800.0;
        text += &format!("{tow:.3} 0 0 0.001 0 0 -0.0981\n");
    }
    let p = testkit::scratch_file("plain_imu_kf.txt", text);
    let near = gnss::time::from_week_tow(2421, 604_790.0);
    let (log, notes) = read_kf_gins(&p, near).unwrap();
    assert_eq!(log.samples.len(), 19, "{:?}", log.skipped);
    assert!(notes[0].contains("GPS weeks 2421–2422"), "{notes:?}");
    assert!(log.samples.iter().all(|s| (s.dt - 0.01).abs() < 1e-6));
    assert!((log.samples[0].dtheta.z - 0.001).abs() < 1e-12);
}

#[test]
fn repeated_and_backward_times_and_gaps_are_named_by_line() {
    let text = csv(
        "gpst_s,dthx_rad,dthy_rad,dthz_rad,dvx_mps,dvy_mps,dvz_mps",
        |k, _| {
            let t = match k {
                10 => 9.0,
                11 => 5.0,
                k if k > 20 => k as f64 + 0.5,
                k => k as f64,
            } * 0.01
                + 1.4e9;
            format!("{t:.3},0,0,0,0,0,-0.0981")
        },
        40,
    );
    let p = testkit::scratch_file("plain_imu_bad.csv", text);
    let (log, _) = read_csv(&p, near()).unwrap();
    // Lines 1–2 are the comment and the header: row k is on line k + 3.
    assert_eq!(
        log.skipped,
        vec![
            "line 13: its time does not follow the row before".to_string(),
            "line 14: its time does not follow the row before".to_string()
        ]
    );
    assert!(log.gaps.is_empty(), "{:?}", log.gaps);
    let text = csv(
        "gpst_s,dthx_rad,dthy_rad,dthz_rad,dvx_mps,dvy_mps,dvz_mps",
        |k, _| {
            format!(
                "{:.2},0,0,0,0,0,-0.0981",
                1.4e9 + k as f64 * 0.01 + if k >= 30 { 0.5 } else { 0.0 }
            )
        },
        40,
    );
    let p = testkit::scratch_file("plain_imu_gap.csv", text);
    let (log, _) = read_csv(&p, near()).unwrap();
    assert_eq!(log.gaps, vec!["line 33: 0.510 s".to_string()]);
}

#[test]
fn wrong_units_and_headers_say_what_to_do() {
    let err = |name: &str, header: &str, row: &dyn Fn(usize, f64) -> String| {
        let p = testkit::scratch_file(name, csv(header, row, 300));
        read_csv(&p, near()).unwrap_err().to_string()
    };
    let h = "gpst_week,gpst_tow,gx_radps,gy_radps,gz_radps,ax_mps2,ay_mps2,az_mps2";
    // g written under m/s² columns, m/s² under g columns.
    let e = err("plain_imu_g.csv", h, &|_, t| {
        format!("2421,{t:.3},0,0,0,0,0,-1")
    });
    assert!(e.contains("looks like g: name the columns ax_g"), "{e}");
    let hg = h.replace("_mps2", "_g");
    let e = err("plain_imu_ms2.csv", &hg, &|_, t| {
        format!("2421,{t:.3},0,0,0,0,0,-9.81")
    });
    assert!(e.contains("ax_mps2"), "{e}");
    // °/s under rad/s columns: a turn at 90 °/s.
    let e = err("plain_imu_dps.csv", h, &|_, t| {
        format!("2421,{t:.3},0,0,90,0,0,-9.81")
    });
    assert!(e.contains("gx_dps"), "{e}");
    // Times in milliseconds.
    let e = err(
        "plain_imu_ms.csv",
        "gpst_s,gx_dps,gy_dps,gz_dps,ax_g,ay_g,az_g",
        &|k, _| format!("{},0,0,0,0,0,-1", 1_000_000 + 10 * k),
    );
    assert!(e.contains("are the times in seconds?"), "{e}");
    let e = err("plain_imu_nog.csv", "gpst_s,ax_g,ay_g,az_g", &|k, _| {
        format!("{k},0,0,-1")
    });
    assert!(e.contains("header: no rotation: name gx_radps"), "{e}");
}
