//! Exports of camera stations: Metashape and Pix4D reference CSVs, OpenDroneMap `geo.txt`, a
//! full CSV (time, coordinates, sigmas, quality, attitude, flags) and an RTKLIB `.pos`; in
//! geodetic coordinates or projected (UTM, Gauss–Krüger, any projected EPSG code), with
//! ellipsoidal or orthometric heights ([`georef::height`]).
//!
//! Enters: camera stations ([`super::CameraStation`], ECEF with ECEF covariance). Leaves: files
//! written atomically; times GPST, sigmas in the local ENU frame (m), angles degrees (R camera
//! → ENU). Also the antenna table that `adjust` reads ([`antenna_table`]), shared with
//! the simulator. Uses `common::tmerc` for UTM and Gauss–Krüger, [`georef::crs`] for EPSG codes,
//! and `gnss::solution` for `.pos`.

use super::attitude::omega_phi_kappa;
use super::CameraStation;
use common::atomic::write_atomic;
use common::tmerc::{Projected, TransverseMercator};
use georef::crs::EpsgProjection;
use georef::height::Heights;
use georef::vector::TrajectoryFormat;
use gnss::error::Result;
use gnss::frame::enu_rotation;
use gnss::solution::{PosFormat, PosRecord};
use std::io::Write;
use std::path::Path;

/// Output layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Agisoft Metashape reference CSV (label, coordinates, sigmas, yaw/pitch/roll).
    Metashape,
    /// Pix4D image geolocation CSV (coordinates, ω-φ-κ, accuracies).
    Pix4d,
    /// OpenDroneMap `geo.txt`.
    Odm,
    /// Every column ppkat knows (time, coordinates, sigmas, Q, both angle sets, flags).
    Csv,
    /// RTKLIB `.pos` of the projection centres (llh, with the ECEF covariance).
    Pos,
    /// KML of the projection centres (a placemark per station, named by its label).
    Kml,
    /// GeoJSON of the projection centres (a point feature per station).
    GeoJson,
    /// GPX of the projection centres (a track point per station).
    Gpx,
    /// Antenna positions with their full ENU covariance, ambiguity segment and attitude:
    /// the GNSS input of `ppkat adjust` (lever arm not applied).
    Antenna,
}

/// Horizontal coordinates of the outputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// WGS84 latitude and longitude (degrees), ellipsoidal height.
    Geodetic,
    /// UTM; the zone of the first station when `None`.
    Utm(Option<u8>),
    /// Gauss–Krüger with a central meridian (degrees).
    GaussKruger(f64),
    /// A projected system by its EPSG code (UTM on any datum, national grids).
    Epsg(u16),
}

impl Projection {
    /// `geodetic`, `utm`, `utm:ZONE`, `gk:CENTRAL_MERIDIAN` (degrees) or `EPSG:CODE`.
    pub fn parse(s: &str) -> Option<Projection> {
        if let Some(code) = s.get(..5).filter(|p| p.eq_ignore_ascii_case("epsg:")) {
            return s[code.len()..].parse().ok().map(Projection::Epsg);
        }
        match s {
            "geodetic" => Some(Projection::Geodetic),
            "utm" => Some(Projection::Utm(None)),
            p if p.starts_with("utm:") => p[4..]
                .trim_end_matches(['N', 'S', 'n', 's'])
                .parse()
                .ok()
                .filter(|z| (1..=60).contains(z))
                .map(|z| Projection::Utm(Some(z))),
            p if p.starts_with("gk:") => p[3..].parse().ok().map(Projection::GaussKruger),
            _ => None,
        }
    }

    /// The transverse Mercator of this projection near `near` and its name; `None` for
    /// geodetic and for EPSG codes (see [`Projection::projector`]).
    pub fn mercator(&self, near: &gnss::frame::Geodetic) -> Option<(TransverseMercator, String)> {
        match *self {
            Projection::Geodetic | Projection::Epsg(_) => None,
            Projection::Utm(z) => {
                let zone = z.unwrap_or_else(|| TransverseMercator::utm_zone_of(near.lon));
                let north = near.lat >= 0.0;
                Some((
                    TransverseMercator::utm(zone, north),
                    format!("UTM zone {zone}{}", if north { "N" } else { "S" }),
                ))
            }
            Projection::GaussKruger(cm) => Some((
                TransverseMercator::gauss_kruger(cm),
                format!("Gauss-Krueger CM {cm}"),
            )),
        }
    }

    /// The projection near `near` (`None` for geodetic); an error naming the code when an
    /// EPSG code is unknown or not projected.
    pub fn projector(&self, near: &gnss::frame::Geodetic) -> Result<Option<Projector>> {
        let odm = match *self {
            Projection::Geodetic => return Ok(None),
            Projection::Epsg(code) => {
                let p = EpsgProjection::new(code).map_err(gnss::error::Error::NoData)?;
                return Ok(Some(Projector {
                    name: p.name(),
                    odm: format!("EPSG:{code}"),
                    kind: ProjectorKind::Epsg(Box::new(p)),
                }));
            }
            Projection::Utm(z) => {
                let zone = z.unwrap_or_else(|| TransverseMercator::utm_zone_of(near.lon));
                format!("WGS84 UTM {zone}{}", if near.lat >= 0.0 { "N" } else { "S" })
            }
            Projection::GaussKruger(cm) => format!(
                "+proj=tmerc +lat_0=0 +lon_0={cm} +k=1 +x_0=500000 +y_0=0 +datum=WGS84 +units=m +no_defs"
            ),
        };
        let (tm, name) = self
            .mercator(near)
            .expect("a transverse Mercator projection");
        Ok(Some(Projector {
            kind: ProjectorKind::Tm(tm),
            name,
            odm,
        }))
    }
}

/// A projection ready to use, with its names.
#[derive(Debug)]
pub struct Projector {
    kind: ProjectorKind,
    /// The name people read in headers.
    pub name: String,
    /// The first line of an OpenDroneMap `geo.txt`, in a form ODM parses: `EPSG:CODE`,
    /// `WGS84 UTM <zone><N|S>` or a PROJ string.
    pub odm: String,
}

#[derive(Debug)]
enum ProjectorKind {
    Tm(TransverseMercator),
    Epsg(Box<EpsgProjection>),
}

impl Projector {
    /// Easting and northing (metres) of a WGS84 position.
    pub fn forward(&self, g: &gnss::frame::Geodetic) -> Result<(f64, f64)> {
        match &self.kind {
            ProjectorKind::Tm(t) => {
                let Projected { easting, northing } = t.forward(g);
                Ok((easting, northing))
            }
            ProjectorKind::Epsg(p) => p.forward(g).map_err(gnss::error::Error::NoData),
        }
    }
}

struct Row {
    id: String,
    week: u32,
    tow: f64,
    /// lat/lon degrees or easting/northing metres.
    x: f64,
    y: f64,
    h: f64,
    sigma_enu: [f64; 3],
    quality: u8,
    ypr: [f64; 3],
    opk: [f64; 3],
    flags: String,
}

/// The names of the output's coordinate system: for people, and for ODM's first line.
struct CrsNames {
    name: String,
    odm: String,
}

fn rows(st: &[CameraStation], proj: Projection, heights: &Heights) -> Result<(Vec<Row>, CrsNames)> {
    let tm = match st.first() {
        Some(s) => proj.projector(&s.centre.to_geodetic())?,
        None => None,
    };
    let names = match &tm {
        Some(p) => CrsNames {
            name: format!("{}, {}", p.name, heights.describe()),
            odm: p.odm.clone(),
        },
        None => CrsNames {
            name: format!("WGS84 geodetic (EPSG:4326), {}", heights.describe()),
            odm: "EPSG:4326".into(),
        },
    };
    let out = st
        .iter()
        .map(|s| {
            let g = s.centre.to_geodetic();
            let r = enu_rotation(&g);
            let c = r * s.cov * r.transpose();
            let (x, y) = match &tm {
                Some(p) => p.forward(&g)?,
                None => (g.lat.to_degrees(), g.lon.to_degrees()),
            };
            let photo::rotation::Angles::YawPitchRoll { yaw, pitch, roll } =
                photo::rotation::Angles::yaw_pitch_roll(&s.rotation)
            else {
                unreachable!("yaw_pitch_roll returns that convention")
            };
            let opk = omega_phi_kappa(&s.rotation);
            let (week, tow) = gnss::time::week_tow(s.time);
            Ok(Row {
                id: s.id.clone(),
                week,
                tow,
                x,
                y,
                h: heights.height(&g)?,
                sigma_enu: [
                    c[(0, 0)].max(0.0).sqrt(),
                    c[(1, 1)].max(0.0).sqrt(),
                    c[(2, 2)].max(0.0).sqrt(),
                ],
                quality: s.quality as u8,
                ypr: [
                    yaw.to_degrees().rem_euclid(360.0),
                    pitch.to_degrees(),
                    roll.to_degrees(),
                ],
                opk: opk.map(f64::to_degrees),
                flags: s.flags.join("; "),
            })
        })
        .collect::<Result<_>>()?;
    Ok((out, names))
}

/// Write stations in a format with `heights` (ellipsoidal or above a geoid; every header says
/// which). The antenna table, the input of `ppkat adjust`, is always ellipsoidal: asking it
/// for orthometric heights is an error.
pub fn write(
    path: &Path,
    st: &[CameraStation],
    format: Format,
    proj: Projection,
    heights: &Heights,
) -> Result<()> {
    let centres = |f| write_centres(path, st, f, heights);
    let text_format: TextFormat = match format {
        Format::Pos => return centres(TrajectoryFormat::Pos(PosFormat::Llh)),
        Format::Kml => return centres(TrajectoryFormat::Kml),
        Format::GeoJson => return centres(TrajectoryFormat::GeoJson),
        Format::Gpx => return centres(TrajectoryFormat::Gpx),
        Format::Antenna if heights.orthometric() => {
            return Err(gnss::error::Error::input(
                path,
                "the antenna table (the input of ppkat adjust) holds ellipsoidal heights only: leave out --height",
            ))
        }
        Format::Antenna => return write_antenna(path, st),
        Format::Metashape => write_metashape,
        Format::Pix4d => write_pix4d,
        Format::Odm => write_odm,
        Format::Csv => write_csv,
    };
    let (rows, crs) = rows(st, proj, heights)?;
    let geo = proj == Projection::Geodetic;
    write_atomic(path, |w| text_format(w, &rows, &crs, geo)).map_err(gnss::Error::from)
}

/// A writer of one text layout: the rows, the names of their coordinate system, and whether
/// they are geodetic (x = latitude, y = longitude, degrees) rather than projected (easting,
/// northing, metres).
type TextFormat = fn(&mut dyn Write, &[Row], &CrsNames, bool) -> std::io::Result<()>;

/// The projection centres as an RTKLIB `.pos` (llh) with their ECEF covariance, or as KML,
/// GeoJSON or GPX named by the station labels.
fn write_centres(
    path: &Path,
    st: &[CameraStation],
    format: TrajectoryFormat,
    heights: &Heights,
) -> Result<()> {
    let recs: Vec<PosRecord> = st
        .iter()
        .map(|s| PosRecord {
            time: s.time,
            pos: s.centre,
            quality: s.quality,
            nsat: 0,
            cov: s.cov,
            age: 0.0,
            ratio: 0.0,
        })
        .collect();
    let names: Vec<String> = st.iter().map(|s| s.id.clone()).collect();
    let header = ["program   : ppkat exposures (projection centres)".to_string()];
    georef::vector::write_named(path, &header, &recs, &names, format, heights)
}

/// Metashape reference CSV: label, longitude/latitude (or easting/northing), altitude,
/// sigmas, yaw/pitch/roll.
fn write_metashape(
    w: &mut dyn Write,
    rows: &[Row],
    crs: &CrsNames,
    geo: bool,
) -> std::io::Result<()> {
    writeln!(w, "# ppkat camera stations; {}", crs.name)?;
    if geo {
        writeln!(
            w,
            "#label,longitude,latitude,altitude,sx,sy,sz,yaw,pitch,roll"
        )?;
    } else {
        writeln!(
            w,
            "#label,easting,northing,altitude,sx,sy,sz,yaw,pitch,roll"
        )?;
    }
    for r in rows {
        let (a, b) = if geo { (r.y, r.x) } else { (r.x, r.y) };
        writeln!(
            w,
            "{},{a:.9},{b:.9},{:.4},{:.4},{:.4},{:.4},{:.3},{:.3},{:.3}",
            r.id, r.h, r.sigma_enu[0], r.sigma_enu[1], r.sigma_enu[2], r.ypr[0], r.ypr[1], r.ypr[2]
        )?;
    }
    Ok(())
}

/// Pix4D image geolocation CSV: name, coordinates, altitude, ω-φ-κ, horizontal and vertical
/// accuracy.
fn write_pix4d(w: &mut dyn Write, rows: &[Row], _crs: &CrsNames, geo: bool) -> std::io::Result<()> {
    writeln!(
        w,
        "imagename,{},altitude,omega,phi,kappa,accuracy_horz,accuracy_vert",
        if geo {
            "latitude,longitude"
        } else {
            "easting,northing"
        }
    )?;
    for r in rows {
        let sh = r.sigma_enu[0].hypot(r.sigma_enu[1]);
        writeln!(
            w,
            "{},{:.9},{:.9},{:.4},{:.4},{:.4},{:.4},{sh:.4},{:.4}",
            r.id, r.x, r.y, r.h, r.opk[0], r.opk[1], r.opk[2], r.sigma_enu[2]
        )?;
    }
    Ok(())
}

/// OpenDroneMap `geo.txt`: the projection line as ODM parses it (`EPSG:CODE`, `WGS84 UTM
/// <zone><N|S>` or a PROJ string), then image geo_x geo_y geo_z omega phi kappa horizontal
/// and vertical accuracy.
fn write_odm(w: &mut dyn Write, rows: &[Row], crs: &CrsNames, geo: bool) -> std::io::Result<()> {
    writeln!(w, "{}", crs.odm)?;
    for r in rows {
        let (a, b) = if geo { (r.y, r.x) } else { (r.x, r.y) };
        let sh = r.sigma_enu[0].hypot(r.sigma_enu[1]);
        writeln!(
            w,
            "{} {a:.9} {b:.9} {:.4} {:.4} {:.4} {:.4} {sh:.4} {:.4}",
            r.id, r.h, r.opk[0], r.opk[1], r.opk[2], r.sigma_enu[2]
        )?;
    }
    Ok(())
}

/// The full CSV: time, coordinates, ENU sigmas, quality, both attitude conventions, flags.
fn write_csv(w: &mut dyn Write, rows: &[Row], crs: &CrsNames, geo: bool) -> std::io::Result<()> {
    let crs = &crs.name;
    writeln!(w, "# ppkat camera stations (projection centres), GPST; {crs}; sigmas ENU (m); Q as RTKLIB; angles degrees, R camera->ENU, omega/phi/kappa: R = Rw*Rp*Rk")?;
    writeln!(
        w,
        "id,week,tow,{},h,sigma_e,sigma_n,sigma_u,quality,yaw,pitch,roll,omega,phi,kappa,flags",
        if geo { "lat,lon" } else { "easting,northing" }
    )?;
    for r in rows {
        writeln!(
            w,
            "{},{},{:.6},{:.9},{:.9},{:.4},{:.4},{:.4},{:.4},{},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5},\"{}\"",
            r.id, r.week, r.tow, r.x, r.y, r.h, r.sigma_enu[0], r.sigma_enu[1], r.sigma_enu[2], r.quality, r.ypr[0], r.ypr[1], r.ypr[2], r.opk[0], r.opk[1], r.opk[2], r.flags
        )?;
    }
    Ok(())
}

/// One row of the antenna table read by `ppkat adjust` (`adjust::tables::read_antennas`).
pub struct AntennaRow<'a> {
    /// Image (station) id.
    pub id: &'a str,
    /// Exposure time, GPST.
    pub time: hifitime::Epoch,
    /// Antenna position, WGS84.
    pub pos: gnss::frame::Geodetic,
    /// Covariance in the ENU frame at `pos`, m².
    pub cov_enu: nalgebra::Matrix3<f64>,
    /// RTKLIB's Q (1 fixed).
    pub quality: u8,
    /// Ambiguity segment of the trajectory (the adjustment's drift groups).
    pub segment: u32,
    /// ω, φ, κ (degrees) of R camera → ENU, when known.
    pub opk_deg: Option<[f64; 3]>,
    /// σ of the attitude about the camera's x, y, z (degrees), when its source gives them.
    pub opk_sigma_deg: Option<[f64; 3]>,
    /// Antenna velocity in the ENU frame at `pos` (m/s), when known (for a GNSS latency).
    pub vel_enu: Option<[f64; 3]>,
}

/// The antenna table as text: a comment line, the header, the rows. The attitude columns
/// are written when every row has an attitude (and their σ, `sd_omega,sd_phi,sd_kappa`
/// in degrees, when every row has them too), the velocity columns (`ve,vn,vu`, m/s in the
/// ENU at the antenna) when every row has a velocity.
pub fn antenna_table(comment: &str, rows: &[AntennaRow]) -> String {
    use std::fmt::Write as _;
    let with_opk = !rows.is_empty() && rows.iter().all(|r| r.opk_deg.is_some());
    let with_vel = !rows.is_empty() && rows.iter().all(|r| r.vel_enu.is_some());
    let with_sd = with_opk && rows.iter().all(|r| r.opk_sigma_deg.is_some());
    let mut s = format!(
        "# {comment}; GPST; WGS84 lat/lon (deg), ellipsoidal h (m); covariance ENU (m^2); segment = trajectory ambiguity segment{}{}{}\nid,week,tow,lat,lon,h,c_ee,c_en,c_eu,c_nn,c_nu,c_uu,quality,segment{}{}{}\n",
        if with_opk { "; omega/phi/kappa (deg) of R camera->ENU" } else { "" },
        if with_sd { "; sd_omega/sd_phi/sd_kappa their sigma about the camera's x/y/z (deg)" } else { "" },
        if with_vel { "; ve/vn/vu antenna velocity ENU (m/s)" } else { "" },
        if with_opk { ",omega,phi,kappa" } else { "" },
        if with_sd { ",sd_omega,sd_phi,sd_kappa" } else { "" },
        if with_vel { ",ve,vn,vu" } else { "" }
    );
    for r in rows {
        let (week, tow) = gnss::time::week_tow(r.time);
        let c = &r.cov_enu;
        let _ = write!(
            s,
            "{},{week},{tow:.6},{:.10},{:.10},{:.4},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{},{}",
            r.id,
            r.pos.lat.to_degrees(),
            r.pos.lon.to_degrees(),
            r.pos.h,
            c[(0, 0)],
            c[(0, 1)],
            c[(0, 2)],
            c[(1, 1)],
            c[(1, 2)],
            c[(2, 2)],
            r.quality,
            r.segment
        );
        if let (true, Some(o)) = (with_opk, r.opk_deg) {
            let _ = write!(s, ",{:.5},{:.5},{:.5}", o[0], o[1], o[2]);
        }
        if let (true, Some(o)) = (with_sd, r.opk_sigma_deg) {
            let _ = write!(s, ",{:.6},{:.6},{:.6}", o[0], o[1], o[2]);
        }
        if let (true, Some(v)) = (with_vel, r.vel_enu) {
            let _ = write!(s, ",{:.4},{:.4},{:.4}", v[0], v[1], v[2]);
        }
        s.push('\n');
    }
    s
}

/// The antenna table of camera stations (lever arm not applied).
fn write_antenna(path: &Path, st: &[CameraStation]) -> Result<()> {
    let rows: Vec<AntennaRow> = st
        .iter()
        .map(|s| {
            let g = s.antenna.to_geodetic();
            let r = enu_rotation(&g);
            AntennaRow {
                id: &s.id,
                time: s.time,
                pos: g,
                cov_enu: r * s.cov * r.transpose(),
                quality: s.quality as u8,
                segment: s.segment,
                opk_deg: Some(omega_phi_kappa(&s.rotation).map(f64::to_degrees)),
                opk_sigma_deg: s.rotation_sigma.map(|x| x.map(f64::to_degrees)),
                vel_enu: Some((r * s.velocity).into()),
            }
        })
        .collect();
    let text = antenna_table("ppkat antenna positions at the exposures", &rows);
    write_atomic(path, |w| w.write_all(text.as_bytes())).map_err(gnss::Error::from)
}
