//! Trajectories as files other tools open: RTKLIB `.pos` (llh or xyz), and the vector formats
//! Google Earth and QGIS read — KML, GeoJSON and GPX — with every epoch's time, Q, number of
//! satellites and σ east/north/up.
//!
//! Enters: the `.pos` records of a run (GPST, ECEF, ECEF covariance) and its header lines.
//! Leaves: one file written atomically. In the vector files times are UTC (ISO 8601, as the
//! formats require) with the GPST beside them where the format has room, coordinates WGS84
//! longitude/latitude (degrees, 9 decimals) and the height of [`Heights`] (m): ellipsoidal by
//! default — not above sea level, which KML and GPX viewers assume — or orthometric above a
//! geoid; every file says which. KML points are clamped to the ground and the height is given
//! as data.

use crate::height::Heights;
use common::atomic::write_atomic;
use gnss::error::Result;
use gnss::frame::{enu_rotation, Geodetic};
use gnss::solution::{write_pos, write_pos_framed, PosFormat, PosRecord, Quality};
use gnss::time::format_ymdhms_us;
use std::fmt::Write as _;
use std::path::Path;

/// The layout of a trajectory file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrajectoryFormat {
    /// RTKLIB `.pos` in the given coordinates.
    Pos(PosFormat),
    /// KML: a line of the whole track and a placemark per epoch, styled by Q.
    Kml,
    /// GeoJSON: a LineString feature of the track and a Point feature per epoch.
    GeoJson,
    /// GPX 1.1: one track of track points.
    Gpx,
}

impl TrajectoryFormat {
    /// The coordinates of the `.pos` header lines (llh for the vector formats).
    pub fn pos_format(self) -> PosFormat {
        match self {
            TrajectoryFormat::Pos(f) => f,
            _ => PosFormat::Llh,
        }
    }
}

/// Write `records` to `path` in `format` with `heights` (ellipsoidal or above a geoid; the
/// header says which); `header` are the `.pos` header lines (for the vector formats they
/// become the description). Epochs are named by their GPST.
pub fn write(
    path: &Path,
    header: &[String],
    records: &[PosRecord],
    format: TrajectoryFormat,
    heights: &Heights,
) -> Result<()> {
    write_named(path, header, records, &[], format, heights)
}

/// [`write()`] with a name per record (photo labels; records beyond `names` are named by their
/// GPST). A `.pos` has no room for names. Orthometric heights need llh coordinates: an ECEF
/// `.pos` with them is refused.
pub fn write_named(
    path: &Path,
    header: &[String],
    records: &[PosRecord],
    names: &[String],
    format: TrajectoryFormat,
    heights: &Heights,
) -> Result<()> {
    match format {
        TrajectoryFormat::Pos(PosFormat::Xyz) if heights.orthometric() => {
            return Err(gnss::error::Error::input(
                path,
                "ECEF x/y/z has no orthometric height: use --format llh with --height, or ellipsoidal heights",
            ))
        }
        TrajectoryFormat::Pos(f) if !heights.orthometric() => {
            return write_pos(path, header, records, f)
        }
        _ => {}
    }
    // Only the formats below read the points (a plain `.pos` converts its records itself).
    let pts: Vec<Point> = records
        .iter()
        .enumerate()
        .map(|(i, r)| point(r, names.get(i), heights))
        .collect::<Result<_>>()?;
    let text = match format {
        TrajectoryFormat::Pos(f) => {
            // Orthometric heights (ellipsoidal ones were written above): the geoid heights as
            // the records' heights, each point moved along its normal.
            let moved: Vec<PosRecord> = records
                .iter()
                .zip(&pts)
                .map(|(r, p)| PosRecord {
                    pos: Geodetic::from_degrees(p.lat, p.lon, p.h).to_ecef(),
                    ..r.clone()
                })
                .collect();
            let frame = format!("lat/lon/height=WGS84/geodetic({})", heights.short());
            let mut header = header.to_vec();
            header.push(format!("heights   : {}", heights.describe()));
            return write_pos_framed(path, &header, &moved, f, &frame);
        }
        TrajectoryFormat::Kml => kml(header, &pts, heights),
        TrajectoryFormat::GeoJson => geojson(header, &pts, heights),
        TrajectoryFormat::Gpx => gpx(header, &pts, heights),
    };
    write_atomic(path, |w| w.write_all(text.as_bytes())).map_err(gnss::Error::from)
}

/// One epoch in the numbers the vector formats carry.
struct Point {
    name: String,
    lat: f64,
    lon: f64,
    h: f64,
    /// σ east, north, up, m.
    sigma: [f64; 3],
    utc: String,
    gpst: String,
    q: u8,
    ns: usize,
    ratio: f64,
    age: f64,
}

fn point(r: &PosRecord, name: Option<&String>, heights: &Heights) -> Result<Point> {
    let g = r.pos.to_geodetic();
    let rot = enu_rotation(&g);
    let c = rot * r.cov * rot.transpose();
    let gpst = format_ymdhms_us(r.time);
    Ok(Point {
        name: name.cloned().unwrap_or_else(|| gpst.clone()),
        lat: g.lat.to_degrees(),
        lon: g.lon.to_degrees(),
        h: heights.height(&g)?,
        sigma: [0, 1, 2].map(|k| c[(k, k)].max(0.0).sqrt()),
        utc: iso_utc(r.time),
        gpst,
        q: r.quality as u8,
        ns: r.nsat,
        ratio: r.ratio,
        age: r.age,
    })
}

/// `YYYY-MM-DDThh:mm:ss.sssZ` of a GPST epoch.
fn iso_utc(t: hifitime::Epoch) -> String {
    let t = t.round(hifitime::Duration::from_milliseconds(1.0));
    let (y, mo, d, h, mi, s, ns) = t.to_gregorian_utc();
    format!(
        "{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}.{:03}Z",
        ns / 1_000_000
    )
}

/// The name of a quality, as the `.pos` legend gives it.
fn q_name(q: u8) -> &'static str {
    match Quality::from_q(q) {
        Quality::Fixed => "fixed",
        Quality::Float => "float",
        Quality::Sbas => "sbas",
        Quality::Dgps => "dgps",
        Quality::Single => "single",
        Quality::Ppp => "ppp",
    }
}

/// Text safe inside XML.
fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// KML colours (aabbggrr) per Q: fixed green, float orange, others red.
fn kml_colour(q: u8) -> &'static str {
    match q {
        1 => "ff3c9600",
        2 => "ff008cf0",
        _ => "ff1e1ed2",
    }
}

fn kml(header: &[String], pts: &[Point], heights: &Heights) -> String {
    let mut s = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n<Document>\n<name>ppkat trajectory</name>\n");
    let _ = writeln!(
        s,
        "<description>{}\nHeights are {}: points are clamped to the ground, h is in the data.</description>",
        xml(&header.join("\n")),
        heights.describe()
    );
    let h_key = if heights.orthometric() {
        "h_orthometric_m"
    } else {
        "h_ellipsoidal_m"
    };
    for q in 1..=6u8 {
        let _ = writeln!(s, "<Style id=\"q{q}\"><IconStyle><color>{}</color><scale>0.5</scale><Icon><href>http://maps.google.com/mapfiles/kml/shapes/shaded_dot.png</href></Icon></IconStyle><LabelStyle><scale>0</scale></LabelStyle></Style>", kml_colour(q));
    }
    s += "<Style id=\"track\"><LineStyle><color>ff808080</color><width>2</width></LineStyle></Style>\n";
    s += "<Placemark><name>track</name><styleUrl>#track</styleUrl><LineString><tessellate>1</tessellate><coordinates>\n";
    for p in pts {
        let _ = writeln!(s, "{:.9},{:.9},{:.4}", p.lon, p.lat, p.h);
    }
    s += "</coordinates></LineString></Placemark>\n<Folder><name>epochs</name>\n";
    for p in pts {
        let _ = writeln!(
            s,
            "<Placemark><name>{}</name><TimeStamp><when>{}</when></TimeStamp><styleUrl>#q{}</styleUrl><ExtendedData>{}</ExtendedData><Point><coordinates>{:.9},{:.9},{:.4}</coordinates></Point></Placemark>",
            xml(&p.name),
            p.utc,
            p.q.clamp(1, 6),
            [
                ("gpst", p.gpst.clone()),
                ("Q", format!("{} ({})", p.q, q_name(p.q))),
                ("ns", p.ns.to_string()),
                (h_key, format!("{:.4}", p.h)),
                ("sigma_e_m", format!("{:.4}", p.sigma[0])),
                ("sigma_n_m", format!("{:.4}", p.sigma[1])),
                ("sigma_u_m", format!("{:.4}", p.sigma[2])),
                ("ratio", format!("{:.1}", p.ratio)),
                ("age_s", format!("{:.2}", p.age)),
            ]
            .iter()
            .map(|(k, v)| format!("<Data name=\"{k}\"><value>{v}</value></Data>"))
            .collect::<String>(),
            p.lon,
            p.lat,
            p.h
        );
    }
    s + "</Folder>\n</Document>\n</kml>\n"
}

fn geojson(header: &[String], pts: &[Point], heights: &Heights) -> String {
    use serde_json::json;
    let mut features = vec![json!({
        "type": "Feature",
        "properties": {
            "name": "track",
            "epochs": pts.len(),
            "header": header,
            "heights": format!("{}, m", heights.describe()),
        },
        "geometry": {
            "type": "LineString",
            "coordinates": pts.iter().map(|p| [p.lon, p.lat, p.h]).collect::<Vec<_>>(),
        },
    })];
    features.extend(pts.iter().map(|p| {
        json!({
            "type": "Feature",
            "properties": {
                "name": p.name,
                "time": p.utc,
                "gpst": p.gpst,
                "q": p.q,
                "quality": q_name(p.q),
                "ns": p.ns,
                "sigma_e_m": p.sigma[0],
                "sigma_n_m": p.sigma[1],
                "sigma_u_m": p.sigma[2],
                "ratio": p.ratio,
                "age_s": p.age,
            },
            "geometry": {"type": "Point", "coordinates": [p.lon, p.lat, p.h]},
        })
    }));
    let v = json!({"type": "FeatureCollection", "features": features});
    serde_json::to_string_pretty(&v).unwrap_or_default() + "\n"
}

fn gpx(header: &[String], pts: &[Point], heights: &Heights) -> String {
    let mut s = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<gpx version=\"1.1\" creator=\"ppkat\" xmlns=\"http://www.topografix.com/GPX/1/1\" xmlns:ppkat=\"https://ppkat.invalid/gpx/1\">\n");
    let _ = writeln!(
        s,
        "<metadata><desc>{}\nele is the height: {}.</desc></metadata>\n<trk><name>ppkat trajectory</name><trkseg>",
        xml(&header.join("\n")),
        heights.describe()
    );
    for p in pts {
        // GPX fix: carrier-phase and code differential → dgps, single point → 3d.
        let fix = match p.q {
            1 | 2 | 4 => "dgps",
            _ => "3d",
        };
        let _ = writeln!(
            s,
            "<trkpt lat=\"{:.9}\" lon=\"{:.9}\"><ele>{:.4}</ele><time>{}</time><name>{}</name><desc>Q={} {} ns={} sE={:.4} sN={:.4} sU={:.4} m</desc><fix>{fix}</fix><sat>{}</sat><extensions><ppkat:q>{}</ppkat:q><ppkat:sigma_e>{:.4}</ppkat:sigma_e><ppkat:sigma_n>{:.4}</ppkat:sigma_n><ppkat:sigma_u>{:.4}</ppkat:sigma_u><ppkat:ratio>{:.1}</ppkat:ratio><ppkat:age>{:.2}</ppkat:age></extensions></trkpt>",
            p.lat, p.lon, p.h, p.utc, xml(&p.name), p.q, q_name(p.q), p.ns, p.sigma[0], p.sigma[1], p.sigma[2],
            p.ns, p.q, p.sigma[0], p.sigma[1], p.sigma[2], p.ratio, p.age
        );
    }
    s + "</trkseg></trk>\n</gpx>\n"
}

#[cfg(test)]
mod tests {
    use super::*;
    use gnss::frame::Geodetic;
    use nalgebra::Matrix3;

    fn points(names: &[String]) -> Vec<Point> {
        records()
            .iter()
            .enumerate()
            .map(|(i, r)| point(r, names.get(i), &Heights::Ellipsoidal).unwrap())
            .collect()
    }

    fn records() -> Vec<PosRecord> {
        let t0 =
            hifitime::Epoch::from_gregorian_hms(2005, 4, 2, 0, 0, 0, hifitime::TimeScale::GPST);
        (0..5)
            .map(|i| PosRecord {
                time: t0 + hifitime::Duration::from_seconds(30.0 * i as f64),
                pos: Geodetic::from_degrees(35.16 + 1e-5 * i as f64, 139.61, 120.0 + i as f64)
                    .to_ecef(),
                quality: if i < 3 {
                    Quality::Fixed
                } else {
                    Quality::Float
                },
                nsat: 8 + i,
                cov: Matrix3::from_diagonal(&nalgebra::Vector3::new(4e-4, 1e-4, 9e-4)),
                age: 1.0,
                ratio: 9.5,
            })
            .collect()
    }

    /// GeoJSON: a track and one point per epoch with the epoch's numbers; times in UTC
    /// (GPST − 13 s in 2005).
    #[test]
    fn geojson_holds_every_epoch() {
        let v: serde_json::Value =
            serde_json::from_str(&geojson(&[], &points(&[]), &Heights::Ellipsoidal)).unwrap();
        let f = v["features"].as_array().unwrap();
        assert_eq!(f.len(), 6);
        assert_eq!(f[0]["geometry"]["coordinates"].as_array().unwrap().len(), 5);
        let p = &f[3];
        let c = p["geometry"]["coordinates"].as_array().unwrap();
        assert!((c[1].as_f64().unwrap() - 35.16002).abs() < 1e-9);
        assert!((c[2].as_f64().unwrap() - 122.0).abs() < 1e-6);
        assert_eq!(p["properties"]["time"], "2005-04-02T00:00:47.000Z");
        assert_eq!(p["properties"]["q"], 1);
        assert_eq!(f[5]["properties"]["quality"], "float");
        assert_eq!(p["properties"]["ns"], 10);
        let total: f64 = ["sigma_e_m", "sigma_n_m", "sigma_u_m"]
            .iter()
            .map(|k| p["properties"][k].as_f64().unwrap().powi(2))
            .sum();
        assert!((total - 14e-4).abs() < 1e-9, "{total}");
    }

    #[test]
    fn kml_and_gpx_hold_every_epoch() {
        let k = kml(
            &["a <b>".into()],
            &points(&["DJI_0001".into()]),
            &Heights::Ellipsoidal,
        );
        assert!(k.contains("<Placemark><name>DJI_0001</name>"));
        assert_eq!(k.matches("<Placemark>").count(), 6);
        assert_eq!(k.matches("<styleUrl>#q2</styleUrl>").count(), 2);
        assert!(k.contains("a &lt;b&gt;"));
        assert!(k.contains("<coordinates>139.610000000,35.160040000,124.0000</coordinates>"));
        let g = gpx(&[], &points(&[]), &Heights::Ellipsoidal);
        assert_eq!(g.matches("<trkpt ").count(), 5);
        assert!(g.contains("<trkpt lat=\"35.160040000\" lon=\"139.610000000\"><ele>124.0000</ele><time>2005-04-02T00:01:47.000Z</time>"));
    }
}
