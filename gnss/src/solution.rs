//! Position solutions and the RTKLIB-compatible `.pos` format (GPST, llh or ECEF xyz): the
//! writer, the reader (ours and RTKLIB's files), and the atomic file writer.
//!
//! Columns: date, time (GPST), then lat (deg), lon (deg), h (m, ellipsoidal) or ECEF x, y, z
//! (m); Q; number of satellites; standard deviations and signed square roots of the
//! covariances (sdn sde sdu sdne sdeu sdun in the local ENU frame for llh, sdx sdy sdz sdxy
//! sdyz sdzx in ECEF for xyz); age (s); ratio. [`crate::trajectory::Trajectory`] is the value
//! these lines serialise.

pub use crate::atomic::write_atomic;
use crate::error::{Error, Result};
use crate::frame::{enu_rotation, Ecef, Geodetic};
use hifitime::Epoch;
use nalgebra::Matrix3;
use std::path::Path;

/// Solution quality, numbered as RTKLIB numbers it (lower is better).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Quality {
    /// Carrier phase, ambiguities fixed.
    Fixed = 1,
    /// Carrier phase, float ambiguities.
    Float = 2,
    /// SBAS-corrected code.
    Sbas = 3,
    /// Differential code.
    Dgps = 4,
    /// Single point (code).
    Single = 5,
    /// Precise point positioning.
    Ppp = 6,
}

impl Quality {
    /// The quality of an RTKLIB Q number (unknown numbers read as single).
    pub fn from_q(q: u8) -> Quality {
        match q {
            1 => Quality::Fixed,
            2 => Quality::Float,
            3 => Quality::Sbas,
            4 => Quality::Dgps,
            6 => Quality::Ppp,
            _ => Quality::Single,
        }
    }
}

/// One line of a `.pos` file.
#[derive(Clone, Debug)]
pub struct PosRecord {
    /// GPST.
    pub time: Epoch,
    /// Position, ECEF.
    pub pos: Ecef,
    /// Q.
    pub quality: Quality,
    /// Number of satellites.
    pub nsat: usize,
    /// Position covariance in ECEF, m².
    pub cov: Matrix3<f64>,
    /// Age of differential corrections, s.
    pub age: f64,
    /// Ambiguity ratio test value.
    pub ratio: f64,
}

/// Coordinates written in a `.pos` file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PosFormat {
    /// Latitude, longitude (degrees), ellipsoidal height; ENU standard deviations.
    Llh,
    /// ECEF x, y, z; ECEF standard deviations.
    Xyz,
}

/// Signed square root, as RTKLIB writes covariances.
fn sqvar(v: f64) -> f64 {
    if v < 0.0 {
        -(-v).sqrt()
    } else {
        v.sqrt()
    }
}

/// Format one record as RTKLIB does.
pub fn format_record(r: &PosRecord, format: PosFormat) -> String {
    let t = crate::time::format_ymdhms_us(r.time);
    // Coordinates, then the covariance in RTKLIB's order: sn se su sne seu sun (llh) or
    // sx sy sz sxy syz szx (xyz), as signed square roots.
    let (coords, c, order) = match format {
        PosFormat::Llh => {
            let g = r.pos.to_geodetic();
            let rot = enu_rotation(&g);
            (
                format!(
                    "{:14.9} {:14.9} {:10.4}",
                    g.lat.to_degrees(),
                    g.lon.to_degrees(),
                    g.h
                ),
                rot * r.cov * rot.transpose(),
                [(1, 1), (0, 0), (2, 2), (1, 0), (0, 2), (2, 1)],
            )
        }
        PosFormat::Xyz => (
            format!("{:14.4} {:14.4} {:14.4}", r.pos.0.x, r.pos.0.y, r.pos.0.z),
            r.cov,
            [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)],
        ),
    };
    let sd = |k: usize| c[order[k]].max(0.0).sqrt();
    let cross = |k: usize| sqvar(c[order[k]]);
    format!(
        "{t} {coords} {:3} {:3} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4} {:6.2} {:6.1}",
        r.quality as u8,
        r.nsat,
        sd(0),
        sd(1),
        sd(2),
        cross(3),
        cross(4),
        cross(5),
        r.age,
        r.ratio
    )
}

/// The column header line.
pub fn column_header(format: PosFormat) -> &'static str {
    match format {
        PosFormat::Llh => "%  GPST                      latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio",
        PosFormat::Xyz => "%  GPST                         x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns   sdx(m)   sdy(m)   sdz(m)  sdxy(m)  sdyz(m)  sdzx(m) age(s)  ratio",
    }
}

/// The `ref pos   : …` header line (without the leading `% `) in the layout RTKLIB's
/// `postpos.c` writes for each format, so that RTKLIB's solution reader gets the base back:
/// it reads the three numbers after the `:` in the coordinates the column header announces —
/// latitude and longitude in degrees (`%13.9f %14.9f`) and ellipsoidal height (`%10.4f`) when
/// the body is llh, ECEF x y z (`%14.4f` each) when it is xyz. Nothing may follow them.
pub fn ref_pos_line(base: &Ecef, format: PosFormat) -> String {
    match format {
        PosFormat::Llh => {
            let g = base.to_geodetic();
            format!(
                "ref pos   :{:13.9} {:14.9} {:10.4}",
                g.lat.to_degrees(),
                g.lon.to_degrees(),
                g.h
            )
        }
        PosFormat::Xyz => format!(
            "ref pos   :{:14.4} {:14.4} {:14.4}",
            base.0.x, base.0.y, base.0.z
        ),
    }
}

/// The base position of a `.pos` text read as RTKLIB's solution reader (`solution.c`) reads
/// it: the format and the field separator come from the column header (`latitude(deg)` →
/// llh, `x-ecef(m)` → xyz; the character after that name), then the first `%` line holding
/// `ref pos` and a `:` gives three numbers after the `:`, split at that separator, each read
/// as C's `atof` reads (the longest numeric prefix, else 0). `None` without such a line.
pub fn rtklib_ref_pos(text: &str) -> Option<Ecef> {
    let head: Vec<&str> = text.lines().take(100).collect();
    let mut format = None;
    for l in head
        .iter()
        .filter(|l| l.starts_with('%') || l.starts_with('+'))
    {
        for (name, f) in [
            ("x-ecef(m)", PosFormat::Xyz),
            ("latitude(deg)", PosFormat::Llh),
        ] {
            if let Some(at) = l.find(name) {
                let sep = l[at + name.len()..].chars().next().unwrap_or(' ');
                format = Some((f, sep));
            }
        }
    }
    let (format, sep) = format?;
    let line = text
        .lines()
        .find(|l| l.starts_with('%') && l.contains("ref pos") && l.contains(':'))?;
    let rest = &line[line.find(':')? + 1..];
    let v: Vec<f64> = rest
        .split(sep)
        .filter(|f| !f.is_empty())
        .map(c_atof)
        .collect();
    if v.len() < 3 {
        return None;
    }
    Some(match format {
        PosFormat::Xyz => Ecef::new(v[0], v[1], v[2]),
        PosFormat::Llh => Geodetic::from_degrees(v[0], v[1], v[2]).to_ecef(),
    })
}

/// C's `atof`: leading white space skipped, the longest prefix that is a number, else 0.
fn c_atof(s: &str) -> f64 {
    let s = s.trim_start();
    (0..=s.len())
        .rev()
        .filter(|&n| s.is_char_boundary(n))
        .find_map(|n| s[..n].parse::<f64>().ok())
        .unwrap_or(0.0)
}

/// Write a `.pos` file: `%` header lines (given, then the column names), then one line per record.
pub fn write_pos(
    path: &Path,
    header: &[String],
    records: &[PosRecord],
    format: PosFormat,
) -> Result<()> {
    let frame = match format {
        PosFormat::Llh => "lat/lon/height=WGS84/ellipsoidal",
        PosFormat::Xyz => "x/y/z-ecef=WGS84",
    };
    write_pos_framed(path, header, records, format, frame)
}

/// [`write_pos`] with the frame words of the legend line given, e.g.
/// `lat/lon/height=WGS84/geodetic(EGM96)` when the records' heights are above a geoid (as
/// RTKLIB calls orthometric heights).
pub fn write_pos_framed(
    path: &Path,
    header: &[String],
    records: &[PosRecord],
    format: PosFormat,
    frame: &str,
) -> Result<()> {
    write_atomic(path, |w| {
        for h in header {
            writeln!(w, "% {h}")?;
        }
        writeln!(
            w,
            "% ({frame}, Q=1:fix,2:float,4:dgps,5:single,6:ppp, ns=# of satellites)"
        )?;
        writeln!(w, "{}", column_header(format))?;
        for r in records {
            writeln!(w, "{}", format_record(r, format))?;
        }
        Ok(())
    })
    .map_err(Error::from)
}

/// Inverse of [`sqvar`].
fn sqvar_inv(v: f64) -> f64 {
    v.signum() * v * v
}

/// Read the lines of an RTKLIB-compatible `.pos` (llh or xyz, told by the column header or,
/// without one, by the size of the first coordinate; GPST; `%` comments), in file order.
/// Columns after the ratio (RTKLIB's velocities) are ignored.
pub fn read_pos(path: &Path) -> Result<Vec<PosRecord>> {
    let text = std::fs::read_to_string(path).map_err(Error::io(path))?;
    let mut records = Vec::new();
    let mut xyz: Option<bool> = None;
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.starts_with('%') {
            if l.contains("x-ecef") {
                xyz = Some(true);
            } else if l.contains("latitude") {
                xyz = Some(false);
            }
            continue;
        }
        if l.is_empty() {
            continue;
        }
        let bad = |what: &str| Error::Parse {
            path: path.to_path_buf(),
            line: i + 1,
            what: what.to_string(),
        };
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() < 6 {
            return Err(bad("too few columns for a .pos line (date time a b c Q …)"));
        }
        let time = parse_time(f[0], f[1])
            .ok_or_else(|| bad("unreadable date/time (yyyy/mm/dd hh:mm:ss.sss GPST expected)"))?;
        let num = |k: usize| f.get(k).and_then(|x| x.parse::<f64>().ok());
        let (a, b, c) = (
            num(2).ok_or_else(|| bad("bad number"))?,
            num(3).ok_or_else(|| bad("bad number"))?,
            num(4).ok_or_else(|| bad("bad number"))?,
        );
        let is_xyz = xyz.unwrap_or(a.abs() > 1000.0);
        let pos = if is_xyz {
            Ecef::new(a, b, c)
        } else {
            Geodetic::from_degrees(a, b, c).to_ecef()
        };
        // Q and ns are integers; tools that write every column as a float ("1.0000000", as
        // the GNSS_IMU data's converter does) are read too when the value is whole.
        let whole = |x: &str| {
            x.parse::<u64>().ok().or_else(|| {
                let v = x.parse::<f64>().ok()?;
                (v.fract() == 0.0 && (0.0..1e6).contains(&v)).then_some(v as u64)
            })
        };
        let q = whole(f[5])
            .and_then(|q| u8::try_from(q).ok())
            .ok_or_else(|| bad("bad quality flag"))?;
        let sd: Vec<f64> = (7..13).map(|k| num(k).unwrap_or(0.0)).collect();
        let cov = if is_xyz {
            Matrix3::new(
                sd[0] * sd[0],
                sqvar_inv(sd[3]),
                sqvar_inv(sd[5]),
                sqvar_inv(sd[3]),
                sd[1] * sd[1],
                sqvar_inv(sd[4]),
                sqvar_inv(sd[5]),
                sqvar_inv(sd[4]),
                sd[2] * sd[2],
            )
        } else {
            // sdn sde sdu sdne sdeu sdun → ENU covariance → ECEF.
            let (n, e, u) = (sd[0], sd[1], sd[2]);
            let (ne, eu, un) = (sqvar_inv(sd[3]), sqvar_inv(sd[4]), sqvar_inv(sd[5]));
            let c_enu = Matrix3::new(e * e, ne, eu, ne, n * n, un, eu, un, u * u);
            let r = enu_rotation(&pos.to_geodetic());
            r.transpose() * c_enu * r
        };
        records.push(PosRecord {
            time,
            pos,
            quality: Quality::from_q(q),
            nsat: f.get(6).and_then(|x| whole(x)).map_or(0, |n| n as usize),
            cov,
            age: num(13).unwrap_or(0.0),
            ratio: num(14).unwrap_or(0.0),
        });
    }
    Ok(records)
}

/// `yyyy/mm/dd` + `hh:mm:ss.sss` in GPST.
fn parse_time(date: &str, time: &str) -> Option<Epoch> {
    let d: Vec<i64> = date
        .split('/')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let mut tp = time.split(':');
    let (h, m, s) = (
        tp.next()?.parse::<i64>().ok()?,
        tp.next()?.parse::<i64>().ok()?,
        tp.next()?.parse::<f64>().ok()?,
    );
    // Fields out of their ranges (an infinite or huge second among them) are no time.
    let in_range = d.len() == 3
        && crate::time::file_year(d[0])
        && (1..=12).contains(&d[1])
        && (1..=31).contains(&d[2])
        && (0..=23).contains(&h)
        && (0..=59).contains(&m)
        && (0.0..61.0).contains(&s);
    if !in_range {
        return None;
    }
    let base = Epoch::maybe_from_gregorian(
        d[0] as i32,
        d[1] as u8,
        d[2] as u8,
        h as u8,
        m as u8,
        0,
        0,
        hifitime::TimeScale::GPST,
    )
    .ok()?;
    Some(base + hifitime::Duration::from_seconds(s))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fuzzed `.pos` line's second `00.09e9800` (infinite) panicked in the time library;
    /// fields out of their ranges are no time.
    #[test]
    fn times_out_of_range_are_refused() {
        assert!(parse_time("2024/06/12", "09:00:00.099800").is_some());
        for (date, time) in [
            ("2024/06/12", "09:00:00.09e9800"),
            ("2024/06/12", "09:00:NaN"),
            ("2024/06/12", "09:00:-1"),
            ("2024/06/12", "24:00:00"),
            ("2024/06/12", "09:60:00"),
            ("2024/06/12", "265:00:00"),
            ("2024/13/12", "09:00:00"),
            ("2024/06/300", "09:00:00"),
        ] {
            assert!(parse_time(date, time).is_none(), "{date} {time}");
        }
    }

    /// A `.pos` with the header `write_pos` writes and RTKLIB's base line for `format`.
    fn written(format: PosFormat, base: &Ecef, name: &str) -> String {
        let path = testkit::scratch_path(&format!("refpos-{name}"));
        let t = Epoch::from_gregorian_hms(2005, 4, 2, 0, 0, 0, hifitime::TimeScale::GPST);
        let rec = PosRecord {
            time: t,
            pos: Ecef::new(-3976219.1869, 3382371.6036, 3652511.1410),
            quality: Quality::Fixed,
            nsat: 9,
            cov: Matrix3::identity() * 1e-4,
            age: 0.0,
            ratio: 12.5,
        };
        let header = vec![
            "program   : ppkat (carrier-phase kinematic)".to_string(),
            ref_pos_line(base, format),
            "ref point : base marker".to_string(),
        ];
        write_pos(&path, &header, &[rec], format).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        text
    }

    /// RTKLIB's reader gets the base back from our llh and xyz files (to 0.1 mm: the nine
    /// decimals of a degree are 0.1 mm, the height and ECEF have four).
    #[test]
    fn rtklib_reads_the_base_position_we_wrote() {
        let base = Ecef::new(-3978241.958, 3382840.234, 3649900.853);
        for (format, name) in [(PosFormat::Llh, "llh"), (PosFormat::Xyz, "xyz")] {
            let text = written(format, &base, name);
            let got = rtklib_ref_pos(&text).expect("a ref pos line");
            let err = (got.0 - base.0).norm();
            assert!(err < 1e-4, "{name}: {err} m off\n{text}");
        }
        let llh = written(PosFormat::Llh, &base, "llh2");
        let line = llh.lines().find(|l| l.contains("ref pos")).unwrap();
        // RTKLIB's %13.9f %14.9f %10.4f (checked against an independent ECEF→geodetic).
        assert_eq!(line, "% ref pos   : 35.132057068  139.624306577    73.9077");
        assert!(llh.contains("% (lat/lon/height=WGS84/ellipsoidal, Q=1:fix"));
        let xyz = written(PosFormat::Xyz, &base, "xyz2");
        let line = xyz.lines().find(|l| l.contains("ref pos")).unwrap();
        assert_eq!(
            line,
            "% ref pos   : -3978241.9580   3382840.2340   3649900.8530"
        );
        assert!(xyz.contains("% (x/y/z-ecef=WGS84, Q=1:fix"));
    }

    /// The old layout (ECEF in an llh file) is what RTKLIB misread: latitude −3978241.958°.
    #[test]
    fn an_ecef_ref_pos_in_an_llh_file_is_misread() {
        let text = format!(
            "% ref pos   : -3978241.9580 3382840.2340 3649900.8530 (ECEF, base marker)\n{}\n",
            column_header(PosFormat::Llh)
        );
        let got = rtklib_ref_pos(&text).unwrap();
        let g = got.to_geodetic();
        assert!((g.lat.to_degrees() - 35.1344).abs() > 1.0, "{g:?}");
        assert_eq!(c_atof(" 12.5e1xyz"), 125.0);
        assert_eq!(c_atof("(ECEF,"), 0.0);
    }

    /// A `.pos` whose Q and ns are written as floats (the GNSS_IMU data's converter) reads;
    /// a fractional Q does not.
    #[test]
    fn whole_floats_are_read_as_q_and_ns() {
        let line = "2025/07/08 19:34:18.499 40.0966268 -105.1474483 1601.4740000 1.0000000 21.0000000 0.0098995 0.0098995 0.0100000 0.0000000 0.0000000 0.0000000 0.0000000 0.0000000";
        let p = testkit::scratch_file(
            "float_q.pos",
            format!("{}\n{line}\n", column_header(PosFormat::Llh)),
        );
        let r = read_pos(&p).unwrap();
        assert_eq!((r[0].quality, r[0].nsat), (Quality::Fixed, 21));
        let bad = testkit::scratch_file(
            "float_q2.pos",
            format!(
                "{}\n{}\n",
                column_header(PosFormat::Llh),
                line.replace(" 1.0000000 ", " 1.5000000 ")
            ),
        );
        let e = read_pos(&bad).unwrap_err().to_string();
        assert!(e.contains("quality"), "{e}");
    }
}
