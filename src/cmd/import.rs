//! `ppkat import`: other tools' projects written as ppkat project folders.

use anyhow::{bail, Result};
use clap::Subcommand;
use integration::import::{colmap, micmac, patb, ProjectOut, Summary};
use std::path::PathBuf;

/// Turn a MicMac, COLMAP or PATB project into a ppkat project folder (project.toml and CSV tables)
/// that `ppkat adjust --project DIR/project.toml` runs as it is.
///
/// Prints how many points, measurements, images and positions were read, and every item
/// skipped with its reason (e.g. a measured point that is not in the ground file). Problems
/// that would make the project wrong (duplicated points, measurements outside the
/// calibration's image, unreadable files) stop the import with the file, line and what to do.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: ImportCmd,
}

/// What GNSS camera positions are (`--gnss-kind`).
#[derive(Clone, Copy, clap::ValueEnum)]
enum GnssKindArg {
    /// RTK or PPK positions.
    Survey,
    /// Navigation-grade positions (code GPS, an autopilot's log).
    Nav,
}

#[derive(Subcommand)]
enum ImportCmd {
    Micmac(MicmacArgs),
    Colmap(ColmapArgs),
    Patb(PatbArgs),
}

/// Import MicMac ground control, image measurements, calibration, orientations and GNSS.
///
/// Ground points keep their `Incertitude` as σ east, north, up; measurements are pixels
/// (column, row from the top-left corner). Without --crs the ground coordinates are a local
/// Cartesian frame, placed east/north/up on the tangent plane at latitude 0, longitude 0
/// (outputs are then geodetic). The calibration (ModRad, ModPhgrStd) is converted into
/// ppkat's camera and the largest difference to MicMac's model is printed.
#[derive(clap::Args)]
struct MicmacArgs {
    /// Ground control points: MicMac DicoAppuisFlottant XML (NamePt, Pt, Incertitude).
    #[arg(long, value_name = "FILE.xml")]
    ground: PathBuf,
    /// Image measurements of the control: SetOfMesureAppuisFlottants XML (pixels).
    #[arg(long, value_name = "FILE.xml")]
    measures: PathBuf,
    /// Camera calibration: ExportAPERO/CalibrationInternConique XML (ModRad or ModPhgrStd);
    /// default: the calibration the orientation files name, in their folder.
    #[arg(long, value_name = "FILE.xml")]
    calibration: Option<PathBuf>,
    /// Check points (DicoAppuisFlottant XML); needs --check-measures.
    #[arg(long, value_name = "FILE.xml", requires = "check_measures")]
    check_ground: Option<PathBuf>,
    /// Image measurements of the check points (SetOfMesureAppuisFlottants XML).
    #[arg(long, value_name = "FILE.xml", requires = "check_ground")]
    check_measures: Option<PathBuf>,
    /// Coordinate system of the ground and GNSS coordinates: EPSG:326ZZ / EPSG:327ZZ or
    /// utm:ZZN / utm:ZZS (default: a local Cartesian frame).
    #[arg(long, value_name = "CRS")]
    crs: Option<String>,
    /// GNSS camera positions, OriConvert-style text (one image per line; see --gnss-format).
    #[arg(long, value_name = "FILE")]
    gnss: Option<PathBuf>,
    /// Columns of the --gnss file: N image name, X Y Z coordinates, other letters ignored.
    #[arg(long, value_name = "FORMAT", default_value = "#F=N X Y Z")]
    gnss_format: String,
    /// σ of the GNSS positions, horizontal and vertical, metres (default: by --gnss-kind).
    #[arg(long, value_name = "H,V")]
    gnss_sigma: Option<String>,
    /// What the --gnss positions are: survey (RTK/PPK: σ 0.05,0.10 m, no drift) or nav
    /// (navigation-grade: σ 3,5 m and an offset per strip, strips from the positions' track
    /// with the images in name order). Without it survey-grade is assumed, and the import
    /// says so.
    #[arg(long, value_enum, value_name = "KIND")]
    gnss_kind: Option<GnssKindArg>,
    /// Folder of MicMac orientation files (Orientation-IMAGE.xml), used as start values.
    #[arg(long, value_name = "DIR")]
    orientations: Option<PathBuf>,
    /// Pixel size written for the camera, µm (MicMac works in pixels; it only sets the
    /// scale of millimetre values).
    #[arg(long, value_name = "UM", default_value_t = 1.0)]
    pixel_um: f64,
    /// Image measurement σ, pixels.
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    sigma_px: f64,
    /// Output folder for project.toml and its tables (written whole, or not at all; an
    /// existing folder holding other files is refused).
    #[arg(short, long, value_name = "DIR")]
    out: PathBuf,
}

/// Import a COLMAP sparse model (text): cameras, images, tie-point measurements and start
/// values.
///
/// A COLMAP model has no datum: --gnss-exif reads the photos' EXIF GPS as GNSS camera
/// positions with the σ of --gnss-sigma, the model is moved onto them by a similarity
/// transformation for the start values, and the GNSS positions give the adjustment its datum.
/// Without --gnss-exif the import stops (the adjustment would have no datum).
#[derive(clap::Args)]
struct ColmapArgs {
    /// Folder with cameras.txt, images.txt and points3D.txt.
    #[arg(value_name = "SPARSE_TXT_DIR")]
    dir: PathBuf,
    /// Folder of the photos: their EXIF GPS positions become GNSS camera positions.
    #[arg(long, value_name = "PHOTO_DIR")]
    gnss_exif: Option<PathBuf>,
    /// σ of the EXIF GPS positions, horizontal and vertical, metres.
    #[arg(long, value_name = "H,V", default_value = "3,5")]
    gnss_sigma: String,
    /// Points seen in fewer images are skipped (counted).
    #[arg(long, value_name = "N", default_value_t = 3)]
    min_track: usize,
    /// Pixel size written for the camera, µm (it only sets the scale of millimetre values).
    #[arg(long, value_name = "UM", default_value_t = 1.0)]
    pixel_um: f64,
    /// Image measurement σ, pixels.
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    sigma_px: f64,
    /// Output folder for project.toml and its tables (written whole, or not at all; an
    /// existing folder holding other files is refused).
    #[arg(short, long, value_name = "DIR")]
    out: PathBuf,
}

/// Import PATB image coordinates (millimetres or pixels) and PATB control points.
///
/// Image file: a line `PHOTO [CAMERA]`, then `POINT x y` lines, closed by `-99`. In mm the
/// origin is the image centre (fiducial centre), x right, y up; in px it is the top-left
/// corner, column right, row down. Both are written as ppkat pixels (column, row from the
/// top-left corner) with the camera's size and pixel pitch. Control file: `ID X Y Z
/// [σX σY σZ | σXY σZ] [gcp|gcp-xy|gcp-z|check]` (X east, Y north, Z up, metres). Points not in
/// the control file are tie points.
#[derive(clap::Args)]
struct PatbArgs {
    /// PATB image coordinates.
    #[arg(long, value_name = "FILE.patb")]
    images: PathBuf,
    /// Units of the image coordinates: mm (x right, y up from the image centre) or px
    /// (column right, row down from the top-left corner).
    #[arg(long, value_name = "UNITS", default_value = "mm", value_parser = ["mm", "px"])]
    units: String,
    /// Cameras: the [[camera]] tables of a ppkat project file (a photo names its camera in
    /// the header's second field); or give --focal-mm, --pixel-um, --width-px, --height-px.
    #[arg(long, value_name = "FILE.toml", conflicts_with_all = ["focal_mm", "pixel_um", "width_px", "height_px"])]
    camera: Option<PathBuf>,
    /// Principal distance, mm (one ideal camera `cam`).
    #[arg(long, value_name = "F", requires = "pixel_um")]
    focal_mm: Option<f64>,
    /// Pixel pitch, µm.
    #[arg(long, value_name = "P", requires = "focal_mm")]
    pixel_um: Option<f64>,
    /// Image width, pixels.
    #[arg(long, value_name = "W")]
    width_px: Option<usize>,
    /// Image height, pixels.
    #[arg(long, value_name = "H")]
    height_px: Option<usize>,
    /// Image measurement σ, pixels (with --focal-mm; a camera file has its own).
    #[arg(long, value_name = "PX", default_value_t = 0.5)]
    sigma_px: f64,
    /// PATB control points: ID X Y Z [σ…] [kind].
    #[arg(long, value_name = "FILE")]
    ground: Option<PathBuf>,
    /// Control points to use as check points, comma-separated ids.
    #[arg(long, value_name = "IDS", value_delimiter = ',')]
    check: Vec<String>,
    /// σ of control points that give none, horizontal and vertical, metres.
    #[arg(long, value_name = "H,V", default_value = "0.02,0.03")]
    ground_sigma: String,
    /// Coordinate system of the control: EPSG:326ZZ / EPSG:327ZZ or utm:ZZN / utm:ZZS
    /// (default: a local Cartesian frame).
    #[arg(long, value_name = "CRS")]
    crs: Option<String>,
    /// Output folder for project.toml and its tables (written whole, or not at all; an
    /// existing folder holding other files is refused).
    #[arg(short, long, value_name = "DIR")]
    out: PathBuf,
}

/// Two positive numbers "H,V".
fn pair(flag: &str, s: &str) -> Result<[f64; 2]> {
    let v: Vec<f64> = s.split(',').filter_map(|t| t.trim().parse().ok()).collect();
    if v.len() != 2 || v.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        bail!("{flag} '{s}': give two positive numbers, horizontal,vertical (m)");
    }
    Ok([v[0], v[1]])
}

fn positive(flag: &str, v: f64) -> Result<f64> {
    if !(v.is_finite() && v > 0.0) {
        bail!("{flag} {v}: give a positive number");
    }
    Ok(v)
}

/// Write the project folder (whole, see [`ProjectOut::write_folder`]) and print the summary.
fn finish(p: &ProjectOut, s: &Summary, out: &std::path::Path) -> Result<()> {
    p.write_folder(out)?;
    for l in s.lines() {
        println!("{l}");
    }
    println!("project written: {}", out.join("project.toml").display());
    Ok(())
}

/// Run `ppkat import …`.
pub fn run(args: Args) -> Result<()> {
    match args.what {
        ImportCmd::Micmac(a) => {
            let job = micmac::MicMacJob {
                ground: a.ground,
                measures: a.measures,
                calibration: a.calibration,
                check: a.check_ground.zip(a.check_measures),
                crs: a.crs,
                gnss: a.gnss.map(|g| (g, a.gnss_format)),
                gnss_sigma: match &a.gnss_sigma {
                    Some(s) => Some(pair("--gnss-sigma", s)?),
                    None => None,
                },
                gnss_kind: a.gnss_kind.map(|k| match k {
                    GnssKindArg::Survey => micmac::GnssKind::Survey,
                    GnssKindArg::Nav => micmac::GnssKind::Navigation,
                }),
                orientations: a.orientations,
                pixel_um: positive("--pixel-um", a.pixel_um)?,
                sigma_px: positive("--sigma-px", a.sigma_px)?,
            };
            let (p, s) = micmac::import(&job)?;
            finish(&p, &s, &a.out)
        }
        ImportCmd::Colmap(a) => {
            let job = colmap::ColmapJob {
                dir: a.dir,
                gnss_exif: a.gnss_exif,
                gnss_sigma: pair("--gnss-sigma", &a.gnss_sigma)?,
                min_track: a.min_track.max(2),
                pixel_um: positive("--pixel-um", a.pixel_um)?,
                sigma_px: positive("--sigma-px", a.sigma_px)?,
            };
            let (p, s) = colmap::import(&job)?;
            finish(&p, &s, &a.out)
        }
        ImportCmd::Patb(a) => {
            let camera = match (a.camera, a.focal_mm, a.pixel_um) {
                (Some(f), ..) => patb::CameraSource::File(f),
                (None, Some(focal_mm), Some(pixel_um)) => {
                    patb::CameraSource::Numbers(patb::CameraNumbers {
                        focal_mm: positive("--focal-mm", focal_mm)?,
                        pixel_um: positive("--pixel-um", pixel_um)?,
                        width_px: a.width_px,
                        height_px: a.height_px,
                        sigma_px: positive("--sigma-px", a.sigma_px)?,
                    })
                }
                _ => bail!("give the camera: --camera FILE.toml, or --focal-mm F --pixel-um P --width-px W --height-px H"),
            };
            let job = patb::PatbJob {
                images: a.images,
                units: if a.units == "px" {
                    patb::Units::Px
                } else {
                    patb::Units::Mm
                },
                camera,
                ground: a.ground,
                check: a.check,
                ground_sigma: pair("--ground-sigma", &a.ground_sigma)?,
                crs: a.crs,
            };
            let (p, s) = patb::import(&job)?;
            finish(&p, &s, &a.out)
        }
    }
}
