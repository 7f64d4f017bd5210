//! Outputs other tools read: the PPK quality report (HTML), and trajectories as KML, GeoJSON
//! and GPX holding the same epochs and coordinates as the `.pos`.

use super::adjust::numbers;
use super::*;

/// `ppk --report`: a self-contained page with its plots and the fix-rate table of the run.
#[test]
fn ppk_report_is_written_with_its_plots() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let (out, html) = (tmp("report-ppk.pos"), tmp("report-ppk.html"));
    let t = succeeds(&ppkat(&[
        "ppk",
        "--rover",
        p(&rover),
        "--base",
        p(&base),
        "--nav",
        p(&nav),
        GEONET_BASE_POS,
        "-o",
        p(&out),
        "--report",
        p(&html),
    ]));
    assert!(
        t.contains("report → ") && t.contains("report-ppk.html"),
        "{t}"
    );
    let page = std::fs::read_to_string(&html).unwrap();
    // Ground track, satellites, ratio, σ E/N/U, separation, resets, age.
    assert_eq!(page.matches("<svg").count(), 7, "seven plots");
    // Where both passes are fixed they agree within the 5 cm the combination demands of an
    // epoch it calls fixed (all 120 are; measured 2.2 cm at most, partial fixes near the end
    // where 5–6 satellites remain). At the ends one pass is still float: decimetres apart.
    let title = page
        .find("separation (cm): largest ")
        .map(|at| &page[at..at + 120])
        .expect("a separation plot");
    let nums = numbers(title);
    assert!(
        nums[1] < 5.0,
        "both fixed, yet {} cm apart: {title}",
        nums[1]
    );
    assert!(nums[0] > 10.0 * nums[1], "a float pass end shows: {title}");
    // The resets drawn are those the run reports (slips of every cause + post-fit outliers).
    for pass in ["forward", "backward"] {
        let line = t
            .lines()
            .find(|l| {
                l.trim_start()
                    .starts_with(&format!("{pass}: ambiguity resets"))
            })
            .unwrap();
        let n = numbers(line);
        let total = n[0]
            + line
                .split("post-fit outliers ")
                .nth(1)
                .map_or(0.0, |x| numbers(x)[0]);
        assert!(
            page.contains(&format!("{pass} ({} resets at ", total as u64)),
            "{pass}: {line}"
        );
    }
    for needle in [
        "Ground track",
        "Satellites used",
        "Ambiguity ratio test",
        "Standard deviations",
        "Age of the base observations",
        "Ambiguity segments",
        "<td class=\"l\">fixed (Q=1)</td><td>120</td><td>100.0</td>",
        "<th class=\"l\">rover epochs</th><th>120</th>",
        "<th class=\"l\">elev mask</th><td class=\"l\">10.0 deg</td>",
    ] {
        assert!(page.contains(needle), "report lacks {needle}");
    }
    // Self-contained: nothing is fetched.
    assert!(!page.contains("<script") && !page.contains("src=\"http") && !page.contains("<link"));
}

/// lat, lon, h of the rows of a llh `.pos`.
fn llh_rows(path: &Path) -> Vec<[f64; 3]> {
    pos_rows(path)
        .iter()
        .map(|r| [2, 3, 4].map(|k| r[k].parse().unwrap()))
        .collect()
}

/// `spp --format geojson|kml|gpx`: one feature / placemark / track point per `.pos` epoch at
/// the `.pos` coordinates (to their printed precision), with Q, satellites and σ.
#[test]
fn spp_trajectory_as_geojson_kml_gpx() {
    let Some([obs, nav]) = shared_all([GEONET_ROVER, GEONET_NAV]) else {
        return;
    };
    let run = |fmt: &str, name: &str| -> (PathBuf, String) {
        let out = tmp(name);
        succeeds(&spp_to(&obs, &nav, fmt, &out));
        let text = std::fs::read_to_string(&out).unwrap();
        (out, text)
    };
    let (pos, _) = run("llh", "vec.pos");
    let want = llh_rows(&pos);
    let rows = pos_rows(&pos);
    assert!(want.len() >= 110);
    let close = |a: [f64; 3], b: [f64; 3]| {
        assert!(
            (a[0] - b[0]).abs() < 2e-9 && (a[1] - b[1]).abs() < 2e-9,
            "{a:?} vs {b:?}"
        );
        assert!((a[2] - b[2]).abs() < 2e-4, "{a:?} vs {b:?}");
    };
    // GeoJSON: the track, then a point per epoch ([lon, lat, h]) with its numbers.
    let (_, gj) = run("geojson", "vec.geojson");
    let v: serde_json::Value = serde_json::from_str(&gj).unwrap();
    assert_eq!(v["type"], "FeatureCollection");
    let f = v["features"].as_array().unwrap();
    assert_eq!(f.len(), want.len() + 1);
    assert_eq!(f[0]["geometry"]["type"], "LineString");
    for (k, (feat, w)) in f[1..].iter().zip(&want).enumerate() {
        let c = feat["geometry"]["coordinates"].as_array().unwrap();
        let c = [
            c[1].as_f64().unwrap(),
            c[0].as_f64().unwrap(),
            c[2].as_f64().unwrap(),
        ];
        close(c, *w);
        let pr = &feat["properties"];
        assert_eq!(pr["q"], 5);
        assert_eq!(pr["ns"].to_string(), rows[k][6]);
        let sdu: f64 = rows[k][9].parse().unwrap();
        assert!((pr["sigma_u_m"].as_f64().unwrap() - sdu).abs() < 1e-4);
        assert_eq!(
            pr["gpst"].as_str().unwrap(),
            format!("{} {}", rows[k][0], rows[k][1])
        );
    }
    // KML: the track plus a placemark per epoch, lon,lat,h.
    let (_, kml) = run("kml", "vec.kml");
    assert_eq!(kml.matches("<Placemark>").count(), want.len() + 1);
    let pts: Vec<[f64; 3]> = kml
        .split("<Point><coordinates>")
        .skip(1)
        .map(|s| {
            let c: Vec<f64> = s
                .split('<')
                .next()
                .unwrap()
                .split(',')
                .map(|x| x.parse().unwrap())
                .collect();
            [c[1], c[0], c[2]]
        })
        .collect();
    assert_eq!(pts.len(), want.len());
    pts.iter().zip(&want).for_each(|(a, b)| close(*a, *b));
    // GPX: a track point per epoch with lat, lon and ele.
    let (_, gpx) = run("gpx", "vec.gpx");
    assert_eq!(gpx.matches("<trkpt ").count(), want.len());
    let pts: Vec<[f64; 3]> = gpx
        .split("<trkpt lat=\"")
        .skip(1)
        .map(|s| {
            let lat: f64 = s.split('"').next().unwrap().parse().unwrap();
            let lon: f64 = s
                .split("lon=\"")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap()
                .parse()
                .unwrap();
            let ele: f64 = s
                .split("<ele>")
                .nth(1)
                .unwrap()
                .split('<')
                .next()
                .unwrap()
                .parse()
                .unwrap();
            [lat, lon, ele]
        })
        .collect();
    pts.iter().zip(&want).for_each(|(a, b)| close(*a, *b));
    assert!(gpx.contains("<fix>3d</fix>") && gpx.contains("<ppkat:q>5</ppkat:q>"));
}
