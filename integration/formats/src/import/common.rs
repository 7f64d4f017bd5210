//! What every importer shares: [`ImportError`] (and `ferr`, an error about a file and line),
//! the [`Summary`] of what was read and skipped, the [`GroundFrame`] of an import, and the data
//! lines of a text file.

use ::common::frame::{Ecef, Geodetic};
use common::tmerc::{Projected, TransverseMercator};
use nalgebra::Vector3;
use std::path::Path;

/// Why an import failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImportError {
    /// A problem in a file, at a line when known.
    #[error("{path}{}: {what}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    File {
        /// The file.
        path: String,
        /// Its line (1-based), when known.
        line: Option<usize>,
        /// What is wrong and what to do.
        what: String,
    },
    /// A problem with the options.
    #[error("{0}")]
    Usage(String),
}

/// An error about `path` (line optional).
pub(crate) fn ferr(path: &Path, line: Option<usize>, what: impl Into<String>) -> ImportError {
    ImportError::File {
        path: path.display().to_string(),
        line,
        what: what.into(),
    }
}

/// What an import read and skipped.
#[derive(Clone, Debug, Default)]
pub struct Summary {
    /// (what, count) of everything read, in order.
    pub read: Vec<(String, usize)>,
    /// (what, reason) of every item skipped.
    pub skipped: Vec<(String, String)>,
    /// Other things worth knowing (frame, fitted camera error, …).
    pub notes: Vec<String>,
}

impl Summary {
    /// The count read for `what` (0 when absent).
    pub fn count(&self, what: &str) -> usize {
        self.read.iter().find(|(w, _)| w == what).map_or(0, |x| x.1)
    }

    /// Printable lines: counts read, skipped items with their reason, notes.
    pub fn lines(&self) -> Vec<String> {
        let mut out: Vec<String> = self
            .read
            .iter()
            .map(|(w, n)| format!("read {n} {w}"))
            .collect();
        out.push(format!("skipped {}", self.skipped.len()));
        out.extend(
            self.skipped
                .iter()
                .map(|(w, r)| format!("  skipped {w}: {r}")),
        );
        out.extend(self.notes.iter().map(|n| format!("note: {n}")));
        out
    }
}

/// The origin of local ground frames: latitude 0, longitude 0, height 0.
pub const LOCAL_ORIGIN: [f64; 3] = [0.0, 0.0, 0.0];

/// The ground frame of an import: a UTM projection, or a local Cartesian frame.
#[derive(Clone, Debug)]
pub enum GroundFrame {
    /// A local east/north/up frame on the tangent plane at [`LOCAL_ORIGIN`].
    Local,
    /// UTM: zone, north.
    Utm(u8, bool),
}

impl GroundFrame {
    /// `EPSG:326ZZ` / `EPSG:327ZZ` or `utm:ZZ[N|S]`; `None` → local.
    pub fn parse(crs: Option<&str>) -> Result<GroundFrame, ImportError> {
        let Some(c) = crs else {
            return Ok(GroundFrame::Local);
        };
        let bad = || {
            ImportError::Usage(format!(
                "--crs {c}: use EPSG:326ZZ (UTM north), EPSG:327ZZ (UTM south) or utm:ZZN / utm:ZZS"
            ))
        };
        let u = c.to_ascii_lowercase();
        let (zone, north) = if let Some(e) = u.strip_prefix("epsg:") {
            let n: u32 = e.parse().map_err(|_| bad())?;
            match n {
                32601..=32660 => ((n - 32600) as u8, true),
                32701..=32760 => ((n - 32700) as u8, false),
                _ => return Err(bad()),
            }
        } else if let Some(z) = u.strip_prefix("utm:") {
            let north = !z.ends_with('s');
            let zone: u8 = z.trim_end_matches(['n', 's']).parse().map_err(|_| bad())?;
            (zone, north)
        } else {
            return Err(bad());
        };
        if !(1..=60).contains(&zone) {
            return Err(bad());
        }
        Ok(GroundFrame::Utm(zone, north))
    }

    /// A ground-frame position (x = east, y = north, z = up or height) as ECEF.
    pub fn to_ecef(&self, p: &Vector3<f64>) -> Ecef {
        match *self {
            GroundFrame::Local => {
                let o = Geodetic::from_degrees(LOCAL_ORIGIN[0], LOCAL_ORIGIN[1], LOCAL_ORIGIN[2]);
                let r = ::common::frame::enu_rotation(&o);
                Ecef(o.to_ecef().0 + r.transpose() * p)
            }
            GroundFrame::Utm(zone, north) => TransverseMercator::utm(zone, north)
                .inverse(
                    &Projected {
                        easting: p.x,
                        northing: p.y,
                    },
                    p.z,
                )
                .to_ecef(),
        }
    }

    /// An ECEF position in the ground frame (inverse of [`GroundFrame::to_ecef`]).
    pub fn from_ecef(&self, e: &Ecef) -> Vector3<f64> {
        match *self {
            GroundFrame::Local => {
                let o = Geodetic::from_degrees(LOCAL_ORIGIN[0], LOCAL_ORIGIN[1], LOCAL_ORIGIN[2]);
                ::common::frame::enu_rotation(&o) * (e.0 - o.to_ecef().0)
            }
            GroundFrame::Utm(zone, north) => {
                let g = e.to_geodetic();
                let p = TransverseMercator::utm(zone, north).forward(&g);
                Vector3::new(p.easting, p.northing, g.h)
            }
        }
    }

    /// The project's `output` key for this frame.
    pub fn output(&self) -> String {
        match *self {
            GroundFrame::Local => "geodetic".into(),
            GroundFrame::Utm(zone, _) => format!("utm:{zone}"),
        }
    }

    /// A sentence on the frame for the project file and the summary.
    pub fn describe(&self) -> String {
        match *self {
            GroundFrame::Local => "local ground frame (no --crs): x east, y north, z up on the tangent plane at latitude 0, longitude 0, height 0; outputs are geodetic, convert back with GroundFrame::from_ecef or ECEF = (6378137 + z, x, y)".into(),
            GroundFrame::Utm(zone, north) => format!("UTM zone {zone}{}, heights as given", if north { "N" } else { "S" }),
        }
    }
}

/// The data lines of a text file (not `#` comments) with their 1-based line numbers, read
/// through `common::lines` (plain or gzip, no line over 1 MiB).
pub(crate) fn lines(path: &Path) -> Result<Vec<(usize, String)>, ImportError> {
    use ::common::lines::{Error, Lines};
    let read_err = |e: Error| ferr(path, e.line(), e.reason());
    let mut src = Lines::open(path).map_err(read_err)?;
    let mut out = Vec::new();
    loop {
        let n = src.line_no + 1;
        let Some(line) = src.next_line().map_err(read_err)? else {
            return Ok(out);
        };
        let Ok(l) = std::str::from_utf8(line) else {
            let what = "not text (not valid UTF-8): check that it is the file meant";
            return Err(ferr(path, Some(n), what));
        };
        if !l.trim_start().starts_with('#') {
            out.push((n, l.to_string()));
        }
    }
}
