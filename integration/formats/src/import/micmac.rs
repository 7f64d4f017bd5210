//! `ppkat import micmac`: MicMac's ground points (`DicoAppuisFlottant`, σ from
//! `Incertitude`), image measurements (`SetOfMesureAppuisFlottants`, pixels with origin at the
//! top-left), calibration (`ExportAPERO/CalibrationInternConique`, `ModRad` or `ModPhgrStd`,
//! converted by `photo::camera_convert`), orientations (`OrientationConique`: p = Rᵀ(X − Centre),
//! R's rows `L1 L2 L3`, camera z forward; ppkat's R = R·diag(1, −1, −1)) as start values, and
//! GNSS camera positions in `OriConvert`-style text (`#F=N X Y Z`).
//!
//! Measured points missing from the ground files are skipped and counted with the reason;
//! duplicated points or measurements, measurements outside the calibration's image, and
//! unknown images are errors naming the file, the line and what to do.

use super::common::{ferr, GroundFrame, ImportError, Summary};
use super::micmac_gnss::add_gnss;
#[cfg(test)]
use super::micmac_gnss::gnss_assumptions;
pub use super::micmac_job::{GnssKind, MicMacJob};
use super::write::{CameraOut, GroundOut, ProjectOut, StartOut};
use nalgebra::{Matrix3, Vector3};
use photo::camera_convert::MicMacCalibration;
use std::collections::{BTreeMap, BTreeSet, HashSet};
use std::path::{Path, PathBuf};

/// A ground point: name, position (ground frame), σ.
type DicoPoint = (String, Vector3<f64>, [f64; 3]);
/// A measurement: image, point, column, row, line.
type Mesure = (String, String, f64, f64, usize);
/// An orientation: the calibration file it names, the centre, R (rows L1 L2 L3).
type Orientation = (Option<String>, Vector3<f64>, Matrix3<f64>);

/// An XML file parsed, with its path and text for messages.
struct Xml {
    path: PathBuf,
    text: String,
    /// Byte offsets of the line ends of the text, for line numbers in O(log n) (roxmltree's
    /// `text_pos_at` scans from the start: quadratic over a file of measurements).
    newlines: Vec<usize>,
}

impl Xml {
    fn read(path: &Path) -> Result<Xml, ImportError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ferr(path, None, format!("cannot read: {e}")))?;
        let newlines = text.match_indices('\n').map(|(i, _)| i).collect();
        Ok(Xml {
            path: path.to_path_buf(),
            text,
            newlines,
        })
    }
    fn doc(&self) -> Result<roxmltree::Document<'_>, ImportError> {
        roxmltree::Document::parse(self.text.trim_start())
            .map_err(|e| ferr(&self.path, None, format!("not well-formed XML: {e}")))
    }
    fn line(&self, n: roxmltree::Node) -> usize {
        // The document is the text without its leading blanks: offsets shift by their length.
        let lead = self.text.len() - self.text.trim_start().len();
        let at = lead + n.range().start;
        self.newlines.partition_point(|&nl| nl < at) + 1
    }
    fn err(&self, n: roxmltree::Node, what: String) -> ImportError {
        ferr(&self.path, Some(self.line(n)), what)
    }
}

/// The trimmed text of the child `tag` of `n`.
fn child<'a>(n: roxmltree::Node<'a, 'a>, tag: &str) -> Option<roxmltree::Node<'a, 'a>> {
    n.children().find(|c| c.has_tag_name(tag))
}
fn text_of(n: roxmltree::Node, tag: &str) -> Option<String> {
    child(n, tag).map(|c| c.text().unwrap_or("").trim().to_string())
}

/// `k` numbers of the child `tag` of `n`, or an error naming the element.
fn numbers<const K: usize>(
    x: &Xml,
    n: roxmltree::Node,
    tag: &str,
) -> Result<[f64; K], ImportError> {
    let t = text_of(n, tag).ok_or_else(|| {
        x.err(
            n,
            format!("<{}> has no <{tag}>: add it", n.tag_name().name()),
        )
    })?;
    let v: Vec<f64> = t
        .split_whitespace()
        .filter_map(|s| s.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect();
    if v.len() != K || t.split_whitespace().count() != K {
        return Err(x.err(n, format!("<{tag}>{t}</{tag}>: expected {K} numbers")));
    }
    let mut out = [0.0; K];
    out.copy_from_slice(&v);
    Ok(out)
}

/// Ground points of a `DicoAppuisFlottant`: (name, position, σ) in file order.
fn read_dico(path: &Path) -> Result<Vec<DicoPoint>, ImportError> {
    let x = Xml::read(path)?;
    let doc = x.doc()?;
    let mut out: Vec<DicoPoint> = Vec::new();
    let mut names = HashSet::new();
    for n in doc.descendants().filter(|n| n.has_tag_name("OneAppuisDAF")) {
        let name = text_of(n, "NamePt").unwrap_or_default();
        if name.is_empty() {
            return Err(x.err(n, "<OneAppuisDAF> without <NamePt>: name the point".into()));
        }
        let p = numbers::<3>(&x, n, "Pt")?;
        let s = match child(n, "Incertitude") {
            Some(_) => numbers::<3>(&x, n, "Incertitude")?,
            None => [1.0; 3],
        };
        if s.iter().any(|v| *v <= 0.0) {
            return Err(x.err(n, format!("point {name}: <Incertitude> must be positive")));
        }
        if !names.insert(name.clone()) {
            return Err(x.err(n, format!("point {name} is listed twice: keep one")));
        }
        out.push((name, Vector3::from(p), s));
    }
    if out.is_empty() {
        return Err(ferr(
            path,
            None,
            "no <OneAppuisDAF>: is this a DicoAppuisFlottant file?",
        ));
    }
    Ok(out)
}

/// Measurements of a `SetOfMesureAppuisFlottants`: (image, point, column, row, line).
fn read_mesures(path: &Path) -> Result<Vec<Mesure>, ImportError> {
    let x = Xml::read(path)?;
    let doc = x.doc()?;
    let mut out: Vec<Mesure> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for im in doc
        .descendants()
        .filter(|n| n.has_tag_name("MesureAppuiFlottant1Im"))
    {
        let name = text_of(im, "NameIm").unwrap_or_default();
        if name.is_empty() {
            return Err(x.err(im, "<MesureAppuiFlottant1Im> without <NameIm>".into()));
        }
        for m in im.children().filter(|n| n.has_tag_name("OneMesureAF1I")) {
            let pt = text_of(m, "NamePt").unwrap_or_default();
            let [c, r] = numbers::<2>(&x, m, "PtIm")?;
            let line = x.line(m);
            if !seen.insert((name.clone(), pt.clone())) {
                return Err(x.err(
                    m,
                    format!("point {pt} is measured twice in image {name}: keep one"),
                ));
            }
            out.push((name.clone(), pt, c, r, line));
        }
    }
    if out.is_empty() {
        return Err(ferr(
            path,
            None,
            "no <OneMesureAF1I>: is this a SetOfMesureAppuisFlottants file?",
        ));
    }
    Ok(out)
}

/// A `CalibrationInternConique` (inside `ExportAPERO` or alone).
pub fn read_calibration(path: &Path) -> Result<MicMacCalibration, ImportError> {
    let x = Xml::read(path)?;
    let doc = x.doc()?;
    let c = doc
        .descendants()
        .find(|n| n.has_tag_name("CalibrationInternConique"))
        .ok_or_else(|| ferr(path, None, "no <CalibrationInternConique>"))?;
    if let Some(k) = text_of(c, "KnownConv") {
        if k != "eConvApero_DistM2C" {
            return Err(x.err(
                c,
                format!("<KnownConv>{k}: only eConvApero_DistM2C is supported"),
            ));
        }
    }
    let pp = numbers::<2>(&x, c, "PP")?;
    let [f] = numbers::<1>(&x, c, "F")?;
    let sz = numbers::<2>(&x, c, "SzIm")?;
    let mut cal = MicMacCalibration {
        pp,
        f,
        size: [sz[0].max(0.0) as usize, sz[1].max(0.0) as usize],
        cdist: pp,
        radial: Vec::new(),
        p: [0.0; 2],
        b: [0.0; 2],
    };
    let dist =
        child(c, "CalibDistortion").ok_or_else(|| x.err(c, "no <CalibDistortion>".into()))?;
    let (rad, std) = if let Some(r) = child(dist, "ModRad") {
        (r, None)
    } else if let Some(s) = child(dist, "ModPhgrStd") {
        let r = child(s, "RadialePart")
            .ok_or_else(|| x.err(s, "<ModPhgrStd> without <RadialePart>".into()))?;
        (r, Some(s))
    } else {
        return Err(x.err(
            dist,
            "only <ModRad> and <ModPhgrStd> distortions are supported".into(),
        ));
    };
    cal.cdist = numbers::<2>(&x, rad, "CDist")?;
    for k in rad.children().filter(|n| n.has_tag_name("CoeffDist")) {
        let t = k.text().unwrap_or("").trim();
        let v = t
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| x.err(k, format!("<CoeffDist>{t}: not a number")))?;
        cal.radial.push(v);
    }
    if let Some(s) = std {
        let one = |tag: &str| numbers::<1>(&x, s, tag).map(|v| v[0]);
        cal.p = [one("P1")?, one("P2")?];
        cal.b = [one("b1")?, one("b2")?];
    }
    Ok(cal)
}

/// An `OrientationConique`: the calibration file it names, the centre and R (rows L1 L2 L3).
fn read_orientation(path: &Path) -> Result<Orientation, ImportError> {
    let x = Xml::read(path)?;
    let doc = x.doc()?;
    let o = doc
        .descendants()
        .find(|n| n.has_tag_name("OrientationConique"))
        .ok_or_else(|| ferr(path, None, "no <OrientationConique>"))?;
    let ext = child(o, "Externe").ok_or_else(|| x.err(o, "no <Externe>".into()))?;
    let centre = Vector3::from(numbers::<3>(&x, ext, "Centre")?);
    let m = ext
        .descendants()
        .find(|n| n.has_tag_name("CodageMatr"))
        .ok_or_else(|| {
            x.err(
                ext,
                "no <ParamRotation><CodageMatr>: only matrix rotations are supported".into(),
            )
        })?;
    let rows: Vec<[f64; 3]> = ["L1", "L2", "L3"]
        .iter()
        .map(|t| numbers::<3>(&x, m, t))
        .collect::<Result<_, _>>()?;
    let r = Matrix3::from_row_slice(&rows.concat());
    let file = text_of(o, "FileInterne");
    Ok((file, centre, r))
}

/// Ground points and their measurements of one pair of files, as `kind`, into `out`.
fn add_points(
    job_files: (&Path, &Path),
    kind: &'static str,
    frame: &GroundFrame,
    out: &mut ProjectOut,
    sum: &mut Summary,
) -> Result<(), ImportError> {
    let (gpath, mpath) = job_files;
    let dico = read_dico(gpath)?;
    let mes = read_mesures(mpath)?;
    sum.read.push((format!("{kind} points"), dico.len()));
    sum.read.push((format!("{kind} measurements"), mes.len()));
    let measured: BTreeSet<&str> = mes.iter().map(|m| m.1.as_str()).collect();
    let mut ground_ids: HashSet<String> = out.ground.iter().map(|g| g.id.clone()).collect();
    for (id, p, s) in &dico {
        if !measured.contains(id.as_str()) {
            sum.skipped.push((
                format!("{kind} point {id} ({})", gpath.display()),
                format!("not measured in {}", mpath.display()),
            ));
            continue;
        }
        if !ground_ids.insert(id.clone()) {
            return Err(ferr(
                gpath,
                None,
                format!("point {id} is also in another ground file: keep it in one"),
            ));
        }
        out.ground.push(GroundOut {
            id: id.clone(),
            kind,
            pos: frame.to_ecef(p),
            sigma: *s,
        });
    }
    let known: BTreeSet<&str> = dico.iter().map(|d| d.0.as_str()).collect();
    let mut images: HashSet<String> = out.images.iter().map(|(i, _)| i.clone()).collect();
    for (im, pt, c, r, line) in mes {
        if !known.contains(pt.as_str()) {
            sum.skipped.push((
                format!("measurement of {pt} in {im} ({}:{line})", mpath.display()),
                format!("point {pt} is not in {}", gpath.display()),
            ));
            continue;
        }
        if images.insert(im.clone()) {
            out.images.push((im.clone(), "cam".into()));
        }
        out.measurements.push((im, pt, c, r));
    }
    Ok(())
}

/// Import a MicMac project: the ppkat project and what was read and skipped.
pub fn import(job: &MicMacJob) -> Result<(ProjectOut, Summary), ImportError> {
    let frame = GroundFrame::parse(job.crs.as_deref())?;
    let mut out = ProjectOut {
        name: format!("MicMac import of {}", job.measures.display()),
        output: frame.output(),
        notes: vec![format!(
            "written by ppkat import micmac; {}",
            frame.describe()
        )],
        ..Default::default()
    };
    let mut sum = Summary::default();
    sum.notes.push(frame.describe());
    add_points(
        (&job.ground, &job.measures),
        "gcp",
        &frame,
        &mut out,
        &mut sum,
    )?;
    if let Some((g, m)) = &job.check {
        add_points((g, m), "check", &frame, &mut out, &mut sum)?;
    }
    let orientations = match &job.orientations {
        Some(dir) => read_orientations(dir, &out, &mut sum)?,
        None => Vec::new(),
    };
    let cal_path = match (&job.calibration, orientations.first()) {
        (Some(c), _) => c.clone(),
        (None, Some((_, Some(file), ..))) => job
            .orientations
            .as_ref()
            .map(|d| d.join(Path::new(file).file_name().unwrap_or_default()))
            .unwrap_or_default(),
        _ => return Err(ImportError::Usage(
            "no calibration: give --calibration FILE.xml (or --orientations whose files name one)"
                .into(),
        )),
    };
    let cal = read_calibration(&cal_path)?;
    sum.read.push(("calibration".into(), 1));
    check_inside(&cal, &cal_path, &out)?;
    let conv = cal
        .to_camera(job.pixel_um * 1e-6)
        .map_err(|e| ferr(&cal_path, None, e.to_string()))?;
    sum.notes.push(format!(
        "camera from {}: largest difference to MicMac's model over the image {:.3} px",
        cal_path.display(),
        conv.max_error_px
    ));
    out.cameras.push(CameraOut {
        id: "cam".into(),
        camera: conv.camera,
        sigma_px: job.sigma_px,
        self_calibrate: Vec::new(),
    });
    let flip = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    for (im, _, centre, r) in &orientations {
        let pos = frame.to_ecef(centre);
        // Map or local axes taken as ENU at the centre (start values only).
        let r_enu = enu_at(&frame, centre) * r * flip;
        out.starts.push(StartOut {
            image: im.clone(),
            pos,
            r_enu,
        });
    }
    if let Some((path, format)) = &job.gnss {
        add_gnss(path, format, job, &frame, &mut out, &mut sum)?;
    }
    sum.read.push(("images".into(), out.images.len()));
    Ok((out, sum))
}

/// Rotation ground-frame axes → ENU at `p` (identity for a map projection, taken as ENU).
fn enu_at(frame: &GroundFrame, p: &Vector3<f64>) -> Matrix3<f64> {
    match frame {
        GroundFrame::Utm(..) => Matrix3::identity(),
        GroundFrame::Local => {
            let o = ::common::frame::Geodetic::from_degrees(0.0, 0.0, 0.0);
            let at = frame.to_ecef(p).to_geodetic();
            ::common::frame::enu_rotation(&at) * ::common::frame::enu_rotation(&o).transpose()
        }
    }
}

/// Every measurement must fall inside the calibration's image.
fn check_inside(cal: &MicMacCalibration, path: &Path, out: &ProjectOut) -> Result<(), ImportError> {
    let (w, h) = (cal.size[0] as f64, cal.size[1] as f64);
    if let Some((im, pt, c, r)) = out
        .measurements
        .iter()
        .find(|m| !(0.0..=w).contains(&m.2) || !(0.0..=h).contains(&m.3))
    {
        return Err(ferr(path, None, format!(
            "the measurement of {pt} in {im} at ({c}, {r}) px lies outside this calibration's image ({w} × {h} px): give the calibration of these images"
        )));
    }
    Ok(())
}

/// Orientation files of the measured images: (image, calibration file, centre, R).
#[allow(clippy::type_complexity)]
fn read_orientations(
    dir: &Path,
    out: &ProjectOut,
    sum: &mut Summary,
) -> Result<Vec<(String, Option<String>, Vector3<f64>, Matrix3<f64>)>, ImportError> {
    let mut found = BTreeMap::new();
    let entries =
        std::fs::read_dir(dir).map_err(|e| ferr(dir, None, format!("cannot list: {e}")))?;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        if let Some(im) = name
            .strip_prefix("Orientation-")
            .and_then(|n| n.strip_suffix(".xml"))
        {
            found.insert(im.to_string(), e.path());
        }
    }
    let mut res = Vec::new();
    let images: HashSet<&str> = out.images.iter().map(|(i, _)| i.as_str()).collect();
    for (im, path) in &found {
        if !images.contains(im.as_str()) {
            sum.skipped.push((
                format!("orientation {}", path.display()),
                format!("image {im} has no measurement"),
            ));
            continue;
        }
        let (file, c, r) = read_orientation(path)?;
        res.push((im.clone(), file, c, r));
    }
    sum.read.push(("orientations".into(), res.len()));
    let missing: Vec<&str> = out
        .images
        .iter()
        .map(|(i, _)| i.as_str())
        .filter(|i| !found.contains_key(*i))
        .collect();
    if !missing.is_empty() {
        sum.notes.push(format!(
            "no orientation in {} for {}: their start comes from the control",
            dir.display(),
            missing.join(", ")
        ));
    }
    Ok(res)
}

#[cfg(test)]
#[path = "micmac_tests.rs"]
mod tests;
