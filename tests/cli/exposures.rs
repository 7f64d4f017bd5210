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
    succeeds(&ppkat(&["demo", "-o", p(&dir)]));
    let traj = dir.join("rover_ppk.pos");
    let rover = dir.join("rover.obs");
    for (fmt, needle) in [
        ("csv", "id,week,tow,lat,lon"),
        ("metashape", "#label,longitude"),
        ("pix4d", "imagename,latitude"),
        ("odm", "EPSG:4326"),
        ("pos", "latitude(deg)"),
        ("kml", "<kml xmlns"),
        ("geojson", "\"FeatureCollection\""),
        ("gpx", "<gpx version=\"1.1\""),
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
    demo_exposures(&dir, &["--projection", "utm"], &out);
    let body = std::fs::read_to_string(&out).unwrap();
    assert!(
        body.contains("UTM zone 32N") && body.contains("easting,northing"),
        "{}",
        &body[..300]
    );
    vector_stations(&dir);
    odm_geo_txt_first_line(&dir);
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

/// The SRS of a `geo.txt` first line as OpenDroneMap's `parse_srs_header` reads it: split at
/// single spaces; `WGS84 UTM <zone><N|S>`; else a line holding `+proj`; else `epsg:CODE`
/// (case-insensitive); anything else is refused.
#[derive(Debug, PartialEq)]
enum OdmSrs {
    Utm { zone: u8, south: bool },
    Proj(String),
    Epsg(u32),
}

fn odm_parse_srs_header(header: &str) -> Option<OdmSrs> {
    let header = header.trim();
    let r: Vec<&str> = header.split(' ').collect();
    if r.len() >= 3 && r[0] == "WGS84" && r[1] == "UTM" {
        let (zone, pole) = r[2].split_at(r[2].len() - 1);
        return Some(OdmSrs::Utm {
            zone: zone.parse().ok()?,
            south: pole.eq_ignore_ascii_case("S"),
        });
    }
    if header.contains("+proj") {
        return Some(OdmSrs::Proj(header.to_string()));
    }
    let l = header.to_lowercase();
    l.strip_prefix("epsg:")
        .and_then(|c| c.parse().ok())
        .map(OdmSrs::Epsg)
}

/// ODM `geo.txt` for `utm`, `--crs EPSG:32632` and `gk:9`: first lines ODM parses, and the
/// same easting/northing (to 1 mm) from our transverse Mercator and from proj4rs' EPSG:32632.
fn odm_geo_txt_first_line(dir: &Path) {
    let geo = |crs: &str, name: &str| -> Vec<String> {
        let out = dir.join(name);
        demo_exposures(dir, &["--format", "odm", "--crs", crs], &out);
        std::fs::read_to_string(&out)
            .unwrap()
            .lines()
            .map(String::from)
            .collect()
    };
    let utm = geo("utm", "geo-utm.txt");
    let epsg = geo("EPSG:32632", "geo-epsg.txt");
    let gk = geo("gk:9", "geo-gk.txt");
    assert_eq!(utm[0], "WGS84 UTM 32N");
    assert_eq!(
        odm_parse_srs_header(&utm[0]),
        Some(OdmSrs::Utm {
            zone: 32,
            south: false
        })
    );
    assert_eq!(epsg[0], "EPSG:32632");
    assert_eq!(odm_parse_srs_header(&epsg[0]), Some(OdmSrs::Epsg(32632)));
    assert!(
        matches!(odm_parse_srs_header(&gk[0]), Some(OdmSrs::Proj(s)) if s.contains("+lon_0=9 "))
    );
    assert_eq!(utm.len(), epsg.len());
    let nums = |l: &str| -> Vec<f64> {
        l.split_whitespace()
            .skip(1)
            .map(|x| x.parse().unwrap())
            .collect()
    };
    for (a, b) in utm[1..].iter().zip(&epsg[1..]) {
        let (a, b) = (nums(a), nums(b));
        assert!(
            a[0] > 400_000.0 && a[1] > 4_000_000.0,
            "easting, northing: {a:?}"
        );
        assert!((a[0] - b[0]).hypot(a[1] - b[1]) < 1e-3, "{a:?} vs {b:?}");
        assert_eq!(a[2], b[2], "heights untouched");
    }
    // UTM zone 32 is Gauss–Krüger at 9° scaled by 0.9996 about the central meridian.
    let (u, g) = (nums(&utm[1]), nums(&gk[1]));
    assert!(((u[0] - 500_000.0) - 0.9996 * (g[0] - 500_000.0)).abs() < 1e-3);
    assert!((u[1] - 0.9996 * g[1]).abs() < 1e-3);
}

/// `ppkat exposures` of the demo's rover events on its PPK trajectory in `dir`, with `extra`
/// arguments, into `out`; it must succeed.
fn demo_exposures(dir: &Path, extra: &[&str], out: &Path) {
    let (traj, rover) = (dir.join("rover_ppk.pos"), dir.join("rover.obs"));
    let mut args = vec!["exposures", "--trajectory", p(&traj), "--events", p(&rover)];
    args.extend_from_slice(extra);
    args.extend(["-o", p(out)]);
    succeeds(&ppkat(&args));
}

/// KML, GeoJSON and GPX of the stations: one point per CSV station, named by its label, at
/// the CSV's latitude and longitude.
fn vector_stations(dir: &Path) {
    let csv = std::fs::read_to_string(dir.join("stations.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(2)
        .map(|l| l.split(',').collect())
        .collect();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("stations.geojson")).unwrap())
            .unwrap();
    let f = &v["features"].as_array().unwrap()[1..];
    assert_eq!(f.len(), rows.len());
    for (feat, r) in f.iter().zip(&rows) {
        assert_eq!(feat["properties"]["name"], r[0]);
        let c = &feat["geometry"]["coordinates"];
        let lat: f64 = r[3].parse().unwrap();
        let lon: f64 = r[4].parse().unwrap();
        assert!((c[1].as_f64().unwrap() - lat).abs() < 2e-9, "{c} vs {lat}");
        assert!((c[0].as_f64().unwrap() - lon).abs() < 2e-9, "{c} vs {lon}");
    }
    let kml = std::fs::read_to_string(dir.join("stations.kml")).unwrap();
    assert_eq!(kml.matches("<Placemark>").count(), rows.len() + 1);
    assert!(kml.contains(&format!("<Placemark><name>{}</name>", rows[0][0])));
    let gpx = std::fs::read_to_string(dir.join("stations.gpx")).unwrap();
    assert_eq!(gpx.matches("<trkpt ").count(), rows.len());
}

/// `--height`: ellipsoidal by default, EGM96 built in, a text geoid grid given by the user;
/// every header says which height it holds, and the heights differ by the undulation N.
/// `egm2008` finds its grid in PROJ's data folder and names it (here the real EGM2008 crop,
/// which does not reach the demo's area: a failure naming the point and the crop's extent).
#[test]
fn exposure_heights_ellipsoidal_egm96_and_grid() {
    let dir = demo_dir();
    let csv = |extra: &[&str], name: &str| -> (String, Vec<f64>) {
        let out = tmp(name);
        demo_exposures(dir, extra, &out);
        let body = std::fs::read_to_string(&out).unwrap();
        let h = body
            .lines()
            .skip(2)
            .map(|l| l.split(',').nth(5).unwrap().parse().unwrap())
            .collect();
        (body.lines().next().unwrap().to_string(), h)
    };
    let (head_e, h_e) = csv(&[], "h-ell.csv");
    assert!(head_e.contains("ellipsoidal heights (WGS84)"), "{head_e}");
    let (head_96, h_96) = csv(&["--height", "egm96"], "h-egm96.csv");
    assert!(
        head_96.contains("orthometric heights H = h - N, EGM96 geoid"),
        "{head_96}"
    );
    // The demo flies near 48° N, 11° E, where EGM96 puts the geoid ~47 m above the ellipsoid.
    let d = h_e[0] - h_96[0];
    assert!((40.0..55.0).contains(&d), "N = {d}");
    // A user's grid: N = 30 m + 0.5 m per degree of latitude around the demo area.
    let grid = tmp("geoid.txt");
    let mut lines = String::from("# LAT LON N\n");
    for lat in [40, 60] {
        for lon in [0, 20] {
            lines += &format!("{lat} {lon} {}\n", 30.0 + 0.5 * (lat - 40) as f64);
        }
    }
    std::fs::write(&grid, lines).unwrap();
    let spec = format!("geoid:{}", p(&grid));
    let (head_g, h_g) = csv(&["--height", &spec], "h-grid.csv");
    assert!(head_g.contains("geoid grid geoid.txt"), "{head_g}");
    let d = h_e[0] - h_g[0];
    assert!((30.0..40.0).contains(&d), "N = {d}");
    let pos = tmp("h-egm96.pos");
    demo_exposures(dir, &["--height", "egm96", "--format", "pos"], &pos);
    let body = std::fs::read_to_string(&pos).unwrap();
    assert!(body.contains("height=WGS84/geodetic(EGM96)"), "{body:.600}");
    // EGM2008 found in PROJ's data folder (PROJ_DATA); a crop that does not cover the flight.
    if let Some(crop) = shared("geoid/egm2008-norcal-crop") {
        let proj = tmp("proj-data");
        std::fs::create_dir_all(&proj).unwrap();
        std::fs::copy(
            crop.join("egm2008_25_norcal_crop.gtx"),
            proj.join("egm08_25.gtx"),
        )
        .unwrap();
        let (traj, times) = (dir.join("rover_ppk.pos"), dir.join("rover.obs"));
        let o = Command::new(env!("CARGO_BIN_EXE_ppkat"))
            .args(["exposures", "--height", "egm2008", "--trajectory", p(&traj)])
            .args(["--events", p(&times), "-o", p(&tmp("h-egm2008.csv"))])
            .env("PROJ_DATA", &proj)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1), "{}", text(&o));
        for needle in [
            "EGM2008 from",
            "egm08_25.gtx",
            "does not cover latitude 4",
            "latitudes 37.000000° to 38.000000°",
        ] {
            assert!(text(&o).contains(needle), "{needle:?} not in {}", text(&o));
        }
    }
    let bad = tmp("bad-geoid.txt");
    std::fs::write(&bad, "48 11 47\n48 12 x\n").unwrap();
    let spec = format!("geoid:{}", p(&bad));
    let (traj, rover) = (dir.join("rover_ppk.pos"), dir.join("rover.obs"));
    let o = ppkat(&[
        "exposures",
        "--trajectory",
        p(&traj),
        "--events",
        p(&rover),
        "--height",
        &spec,
        "-o",
        p(&tmp("never.csv")),
    ]);
    fails_with(&o, &["bad-geoid.txt:2", "LAT LON N"]);
}

/// The demo's exposures as `ppkat exposures` writes them (CSV) into `out` with `extra`
/// arguments: the process output and the data rows split at commas.
fn exposure_rows(extra: &[&str], out: &Path) -> (Output, Vec<Vec<String>>) {
    let dir = demo_dir();
    let (traj, rover) = (dir.join("rover_ppk.pos"), dir.join("rover.obs"));
    let mut args = vec!["exposures", "--trajectory", p(&traj), "--events", p(&rover)];
    args.extend_from_slice(extra);
    args.extend(["-o", p(out)]);
    let o = ppkat(&args);
    let rows = std::fs::read_to_string(out)
        .map(|b| {
            b.lines()
                .skip(2)
                .map(|l| l.split(',').map(str::to_string).collect())
                .collect()
        })
        .unwrap_or_default();
    (o, rows)
}

/// Exposure names: RINEX events without photos or names are E0001 … with a note on stderr
/// (silenced by --quiet, the outputs identical); --names gives them in order (a count
/// mismatch names both counts and the file); DJI MRK lines are DJI_NNNN and, with the real
/// Brighton Beach photos, pair by number with DJI_0018.JPG ….
#[test]
fn exposure_names() {
    let (o, rows) = exposure_rows(&[], &tmp("names-generic.csv"));
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(rows[0][0], "E0001");
    assert!(
        rows.iter().all(|r| r[0].starts_with('E')),
        "never bare numbers"
    );
    assert!(err.contains("--photos") && err.contains("--names"), "{err}");
    let (q, _) = exposure_rows(&["--quiet"], &tmp("names-quiet.csv"));
    assert_eq!(q.status.code(), Some(0), "{}", text(&q));
    assert!(
        q.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&q.stderr)
    );
    assert_eq!(
        std::fs::read(tmp("names-generic.csv")).unwrap(),
        std::fs::read(tmp("names-quiet.csv")).unwrap(),
        "--quiet changes no output"
    );
    // A names file.
    let n = rows.len();
    let names = tmp("names.txt");
    let mut text_ = String::from("# one name per exposure\n");
    for k in 0..n {
        text_ += &format!("strip1-{k:03}.tif\n");
    }
    std::fs::write(&names, &text_).unwrap();
    let (o, named) = exposure_rows(&["--names", p(&names)], &tmp("names-file.csv"));
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(o.stderr.is_empty(), "no note: {}", text(&o));
    assert_eq!(named[0][0], "strip1-000.tif");
    assert_eq!(named[n - 1][0], format!("strip1-{:03}.tif", n - 1));
    std::fs::write(&names, "a\nb\n").unwrap();
    let (o, _) = exposure_rows(&["--names", p(&names)], &tmp("names-bad.csv"));
    fails_with(&o, &["names.txt", &format!("2 names for {n} exposures")]);
    mrk_names_and_photos(&rows);
}

/// An MRK of 18 exposures (indices 18–35) at the times and places of the demo's first
/// stations: named DJI_0018 … without photos; with the Brighton Beach photos (DJI_0018.JPG …
/// DJI_0035.JPG, whose own capture times are years away) paired by number.
fn mrk_names_and_photos(rows: &[Vec<String>]) {
    let dir = demo_dir();
    let mrk = tmp("names.MRK");
    let mut body = String::new();
    for (k, r) in rows.iter().take(18).enumerate() {
        body += &format!(
            "{}\t{}\t[{}]\t0,N\t0,E\t0,V\t{},Lat\t{},Lon\t{},Ellh\t0.01, 0.01, 0.02\t50,Q\n",
            18 + k,
            r[2],
            r[1],
            r[3],
            r[4],
            r[5]
        );
    }
    std::fs::write(&mrk, body).unwrap();
    let traj = dir.join("rover_ppk.pos");
    let run = |extra: &[&str], out: &Path| {
        let mut args = vec!["exposures", "--trajectory", p(&traj), "--mrk", p(&mrk)];
        args.extend_from_slice(extra);
        args.extend(["-o", p(out)]);
        let o = ppkat(&args);
        let first = std::fs::read_to_string(out)
            .map(|b| b.lines().nth(2).unwrap_or("").to_string())
            .unwrap_or_default();
        (o, first)
    };
    let (o, first) = run(&[], &tmp("names-mrk.csv"));
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(first.starts_with("DJI_0018,"), "{first}");
    let Some(photos) = shared("photo/brighton-beach") else {
        return;
    };
    let (o, first) = run(&["--photos", p(&photos)], &tmp("names-mrk-photos.csv"));
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(first.starts_with("DJI_0018.JPG,"), "{first}");
    assert!(t.contains("18 paired by MRK index"), "{t}");
}
