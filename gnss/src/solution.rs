//! Position solutions and the RTKLIB-compatible `.pos` writer (GPST, llh or ECEF xyz).

use crate::error::{Error, Result};
use crate::frame::{enu_rotation, Ecef};
use hifitime::Epoch;
use nalgebra::Matrix3;
use std::io::Write;
use std::path::Path;

/// Solution quality, numbered as RTKLIB numbers it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Quality {
    Fixed = 1,
    Float = 2,
    Sbas = 3,
    Dgps = 4,
    Single = 5,
    Ppp = 6,
}

/// One line of a `.pos` file.
#[derive(Clone, Debug)]
pub struct PosRecord {
    pub time: Epoch,
    pub pos: Ecef,
    pub quality: Quality,
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
    Llh,
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

/// Write `path` atomically: to a temporary file beside it, then renamed over it.
pub fn write_atomic(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let res = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::new(file);
        f(&mut w)?;
        w.flush()?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if res.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    res.map_err(io)
}

/// Format one record as RTKLIB does.
pub fn format_record(r: &PosRecord, format: PosFormat) -> String {
    let t = crate::time::format_ymdhms_us(r.time);
    match format {
        PosFormat::Llh => {
            let g = r.pos.to_geodetic();
            let rot = enu_rotation(&g);
            let c = rot * r.cov * rot.transpose();
            format!(
                "{t} {:14.9} {:14.9} {:10.4} {:3} {:3} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4} {:6.2} {:6.1}",
                g.lat.to_degrees(),
                g.lon.to_degrees(),
                g.h,
                r.quality as u8,
                r.nsat,
                c[(1, 1)].max(0.0).sqrt(),
                c[(0, 0)].max(0.0).sqrt(),
                c[(2, 2)].max(0.0).sqrt(),
                sqvar(c[(1, 0)]),
                sqvar(c[(0, 2)]),
                sqvar(c[(2, 1)]),
                r.age,
                r.ratio
            )
        }
        PosFormat::Xyz => {
            let c = r.cov;
            format!(
                "{t} {:14.4} {:14.4} {:14.4} {:3} {:3} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4} {:6.2} {:6.1}",
                r.pos.0.x,
                r.pos.0.y,
                r.pos.0.z,
                r.quality as u8,
                r.nsat,
                c[(0, 0)].max(0.0).sqrt(),
                c[(1, 1)].max(0.0).sqrt(),
                c[(2, 2)].max(0.0).sqrt(),
                sqvar(c[(0, 1)]),
                sqvar(c[(1, 2)]),
                sqvar(c[(2, 0)]),
                r.age,
                r.ratio
            )
        }
    }
}

/// The column header line.
pub fn column_header(format: PosFormat) -> &'static str {
    match format {
        PosFormat::Llh => "%  GPST                      latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio",
        PosFormat::Xyz => "%  GPST                         x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns   sdx(m)   sdy(m)   sdz(m)  sdxy(m)  sdyz(m)  sdzx(m) age(s)  ratio",
    }
}

/// Write a `.pos` file: `%` header lines (given, then the column names), then one line per record.
pub fn write_pos(
    path: &Path,
    header: &[String],
    records: &[PosRecord],
    format: PosFormat,
) -> Result<()> {
    write_atomic(path, |w| {
        for h in header {
            writeln!(w, "% {h}")?;
        }
        writeln!(
            w,
            "% (lat/lon/height=WGS84/ellipsoidal, Q=1:fix,2:float,4:dgps,5:single, ns=# of satellites)"
        )?;
        writeln!(w, "{}", column_header(format))?;
        for r in records {
            writeln!(w, "{}", format_record(r, format))?;
        }
        Ok(())
    })
}
