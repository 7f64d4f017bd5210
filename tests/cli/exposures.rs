//! `ppkat exposures` in every export format, and `ppkat leverarm` from tape lengths.

use super::*;

#[test]
fn leverarm_from_tapes() {
    let o = ppkat(&[
        "leverarm",
        "--tapes",
        "1.840674,1.868176,2.087123,0.904479",
        "--ruler",
        "1.0",
    ]);
    let t = succeeds(&o);
    assert!(t.contains("0.4490 0.0160 1.7850"), "{t}");
    let o = ppkat(&["leverarm", "--tapes", "1.0,0.5,0.5", "--ruler", "1.0"]);
    fails_with(&o, &["--tapes", "four lengths"]);
}

/// The demo's rover events on its PPK trajectory, in every export format; the report says
/// where the ambiguity segments came from.
#[test]
fn exposures_in_every_format() {
    let dir = tmp("exp-formats");
    succeeds(&ppkat(&["demo", "--out", p(&dir)]));
    let traj = dir.join("rover_ppk.pos");
    let rover = dir.join("rover.obs");
    for (fmt, needle) in [
        ("csv", "id,week,tow,lat,lon"),
        ("metashape", "#label,longitude"),
        ("pix4d", "imagename,latitude"),
        ("odm", "EPSG:4326"),
        ("pos", "latitude(deg)"),
        (
            "antenna",
            "id,week,tow,lat,lon,h,c_ee,c_en,c_eu,c_nn,c_nu,c_uu,quality,segment,omega,phi,kappa,ve,vn,vu",
        ),
    ] {
        let out = dir.join(format!("stations.{fmt}"));
        let t = succeeds(&ppkat(&[
            "exposures",
            "--trajectory",
            p(&traj),
            "--events",
            p(&rover),
            "--lever-arm",
            "0.10,-0.05,0.45",
            "--format",
            fmt,
            "-o",
            p(&out),
        ]));
        assert!(
            t.contains("camera stations written") && t.contains("heading"),
            "{t}"
        );
        // A .pos carries no ambiguity segments: the report says they were derived.
        assert!(
            t.contains("note: ambiguity segments derived from Q changes and gaps of")
                && t.contains("rover_ppk.pos"),
            "{t}"
        );
        let body = std::fs::read_to_string(&out).unwrap();
        assert!(
            body.contains(needle),
            "{fmt}: {}",
            &body[..body.len().min(300)]
        );
        assert!(body.lines().count() > 100, "{fmt}");
    }
    // The antenna table carries the antenna velocity from the trajectory (the demo flies its
    // strips at 55 m/s), for `ppkat adjust` to estimate a GNSS latency with.
    let body = std::fs::read_to_string(dir.join("stations.antenna")).unwrap();
    let mut speeds: Vec<f64> = body
        .lines()
        .skip(2)
        .map(|l| {
            let c: Vec<f64> = l
                .split(',')
                .rev()
                .take(3)
                .map(|x| x.parse().unwrap())
                .collect();
            c[1].hypot(c[2])
        })
        .collect();
    speeds.sort_by(f64::total_cmp);
    let median = speeds[speeds.len() / 2];
    assert!((median - 55.0).abs() < 1.0, "median speed {median} m/s");
    let out = dir.join("stations-utm.csv");
    succeeds(&ppkat(&[
        "exposures",
        "--trajectory",
        p(&traj),
        "--events",
        p(&rover),
        "--projection",
        "utm",
        "-o",
        p(&out),
    ]));
    let body = std::fs::read_to_string(&out).unwrap();
    assert!(
        body.contains("UTM zone 32N") && body.contains("easting,northing"),
        "{}",
        &body[..300]
    );
    // An observation file without events is refused by name.
    let o = ppkat(&[
        "exposures",
        "--trajectory",
        p(&traj),
        "--events",
        p(&dir.join("base.obs")),
        "-o",
        p(&dir.join("x.csv")),
    ]);
    fails_with(&o, &["base.obs", "no flag-5 event"]);
}
