//! The truth of a textured block, written beside the project and read back to check
//! measurements made on its photos: `truth.toml` (seed, site origin, terrain extent),
//! `truth_exposures.csv` (exact poses) and `camera.toml` (the exact camera), from which
//! [`Truth::load`] rebuilds the poses, the camera and the terrain bit for bit.
//!
//! What enters: a folder written by [`super::textured_block`]. What leaves: [`Truth`], which
//! maps a pixel of an image to the ground point it sees ([`Truth::ground_of`]) and a ground
//! point to its pixel in an image ([`Truth::project`]).
//!
//! Frame: ENU at the site origin (`truth.toml`), metres; the terrain is `u = h(e, n)` in it.
//! Pixels: column right, row down, origin at the top-left corner of the top-left pixel (the
//! centre of pixel (i, j) is (i + 0.5, j + 0.5)) — as `photo::camera` and
//! `image_observations.csv`. Rotations: R camera → ENU = Rω·Rφ·Rκ of the ω, φ, κ (degrees) in
//! `truth_exposures.csv`.

use super::terrain::{pixel_ray, Extent, Terrain};
use crate::error::SimError;
use adjust::camera_section::{camera_def, CameraSection};
use gnss::frame::{Ecef, Enu, Geodetic};
use nalgebra::{Vector2, Vector3};
use photo::camera::{Camera, Pose};
use photo::rotation::Angles;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::Path;

/// An exposure: id, strip (from 0), GPST seconds, centre (site ENU, m), ω, φ, κ (degrees).
pub(super) type Exposure = (String, usize, f64, Vector3<f64>, [f64; 3]);

/// The pose of an exposure: the same bits wherever its numbers come from.
pub(super) fn pose_of(centre: Vector3<f64>, opk_deg: [f64; 3]) -> Pose {
    let [o, p, k] = opk_deg.map(f64::to_radians);
    Pose {
        r: Angles::OmegaPhiKappa {
            omega: o,
            phi: p,
            kappa: k,
        }
        .matrix(),
        centre,
    }
}

/// The keys of `truth.toml`.
#[derive(Clone, Debug, Deserialize)]
pub(super) struct TruthToml {
    /// Seed of the terrain and texture.
    pub seed: u64,
    /// Site origin: latitude, longitude (degrees), ellipsoidal height (m).
    pub origin: [f64; 3],
    /// Terrain extent: east min, east max, north min, north max (m).
    pub extent: [f64; 4],
    /// Lever arm (u, v, w) in the camera frame, m.
    pub lever_arm: [f64; 3],
    /// σ of the GNSS antenna positions (E, N, U), m.
    pub gnss_sigma: [f64; 3],
}

impl TruthToml {
    pub(super) fn text(&self) -> String {
        let [lat, lon, h] = self.origin;
        let [a, b, c, d] = self.extent;
        let [u, v, w] = self.lever_arm;
        let [se, sn, su] = self.gnss_sigma;
        format!(
            "# Truth of the textured block (ppkat simulate --builtin textured-block).\n\
             # Frame: ENU on the tangent plane at `origin` (lat, lon deg, ellipsoidal h m); terrain\n\
             # u = h(e, n) rebuilt from `seed` over `extent` (e min, e max, n min, n max; m).\n\
             # Poses: truth_exposures.csv (R camera->ENU = R_omega*R_phi*R_kappa); camera: camera.toml.\n\
             # Pixels: column right, row down, origin at the top-left corner of the top-left pixel\n\
             # (pixel (i, j) has its centre at (i + 0.5, j + 0.5)), as image_observations.csv.\n\
             # GNSS: antennas.csv = centre + R*lever_arm + noise of gnss_sigma (E, N, U; m).\n\
             seed = {}\norigin = [{lat:?}, {lon:?}, {h:?}]\nextent = [{a:?}, {b:?}, {c:?}, {d:?}]\n\
             lever_arm = [{u:?}, {v:?}, {w:?}]\ngnss_sigma = [{se:?}, {sn:?}, {su:?}]\n",
            self.seed
        )
    }

    pub(super) fn extent(&self) -> Extent {
        let [xmin, xmax, ymin, ymax] = self.extent;
        Extent {
            xmin,
            xmax,
            ymin,
            ymax,
        }
    }
}

/// `truth_exposures.csv`: every number written so that it reads back to the same bits.
pub(super) fn exposures_csv(exposures: &[Exposure]) -> String {
    let mut s = String::from(
        "# true exposures: projection centre in the site ENU (m); omega/phi/kappa (deg) of R camera->ENU = R_omega*R_phi*R_kappa; GPST\nid,strip,week,tow,e,n,u,omega,phi,kappa\n",
    );
    for (id, strip, t, c, [o, p, k]) in exposures {
        let (week, tow) = gnss::time::week_tow(gnss::time::from_week_tow(0, *t));
        let _ = writeln!(
            s,
            "{id},{},{week},{tow:.6},{:?},{:?},{:?},{o:?},{p:?},{k:?}",
            strip + 1,
            c.x,
            c.y,
            c.z
        );
    }
    s
}

/// The one camera of a `[[camera]]` file, read as `ppkat adjust` reads a project's camera.
pub(super) fn parse_camera(text: &str, path: &Path) -> Result<Camera, SimError> {
    #[derive(Deserialize)]
    struct File {
        camera: Vec<CameraSection>,
    }
    let err = |what: String| SimError::File {
        path: path.display().to_string(),
        what,
    };
    let file: File = toml::from_str(text).map_err(|e| err(e.message().to_string()))?;
    let [c] = file.camera.as_slice() else {
        return Err(err("expected exactly one [[camera]] table".into()));
    };
    Ok(camera_def(c, path).map_err(|e| err(e.to_string()))?.camera)
}

/// The exact truth of a textured block, for checking measurements on its photos.
#[derive(Clone, Debug)]
pub struct Truth {
    /// Origin of the site ENU frame of the poses, the terrain and the ground points.
    pub origin: Geodetic,
    /// The camera of every image (that of `camera.toml` and `project.toml`).
    pub camera: Camera,
    /// Image id and exact pose (site ENU), in the order of `truth_exposures.csv`.
    pub poses: Vec<(String, Pose)>,
    /// The terrain.
    pub terrain: Terrain,
}

impl Truth {
    /// Read the truth of the textured block written into `dir` (`truth.toml`,
    /// `truth_exposures.csv`, `camera.toml`).
    pub fn load(dir: &Path) -> Result<Truth, SimError> {
        let read = |name: &str| {
            let p = dir.join(name);
            std::fs::read_to_string(&p)
                .map_err(|e| SimError::File {
                    path: p.display().to_string(),
                    what: format!("cannot read ({e}): is this a textured-block folder?"),
                })
                .map(|t| (p, t))
        };
        let (p, text) = read("truth.toml")?;
        let t: TruthToml = toml::from_str(&text).map_err(|e| SimError::File {
            path: p.display().to_string(),
            what: e.message().to_string(),
        })?;
        let (p, text) = read("camera.toml")?;
        let camera = parse_camera(&text, &p)?;
        let (p, text) = read("truth_exposures.csv")?;
        let poses = parse_exposures(&text, &p)?;
        Ok(Truth {
            origin: Geodetic::from_degrees(t.origin[0], t.origin[1], t.origin[2]),
            camera,
            poses,
            terrain: Terrain::generate(t.seed, &t.extent()),
        })
    }

    /// The exact pose of an image (site ENU), if the block has it.
    pub fn pose(&self, image: &str) -> Option<&Pose> {
        self.poses
            .iter()
            .find(|(id, _)| id == image)
            .map(|(_, p)| p)
    }

    /// The ground point (site ENU) seen at pixel `px` of `image`: the exact camera ray
    /// intersected with the terrain to 1 nm. `None` for an unknown image or a pixel position
    /// outside the image (0 ≤ column ≤ width, 0 ≤ row ≤ height).
    pub fn ground_of(&self, image: &str, px: Vector2<f64>) -> Option<Enu> {
        let pose = self.pose(image)?;
        let (w, h) = (self.camera.width_px as f64, self.camera.height_px as f64);
        if !((0.0..=w).contains(&px.x) && (0.0..=h).contains(&px.y)) {
            return None;
        }
        let ray = pixel_ray(&self.camera, pose, px);
        let start = self.terrain.height(pose.centre.xy());
        self.terrain.intersect(&ray, start, 1e-9).map(Enu)
    }

    /// The pixel where `ground` (site ENU) appears in `image`, through the exact camera.
    /// `None` for an unknown image, a point behind the camera or outside the image. The
    /// terrain is not consulted: a point is not tested for being hidden (the block's gentle
    /// terrain hides nothing).
    pub fn project(&self, image: &str, ground: &Enu) -> Option<Vector2<f64>> {
        let pose = self.pose(image)?;
        let px = self
            .camera
            .image_to_pixel(self.camera.project(pose, &ground.0)?);
        let (w, h) = (self.camera.width_px as f64, self.camera.height_px as f64);
        ((0.0..=w).contains(&px.x) && (0.0..=h).contains(&px.y)).then_some(px)
    }

    /// A site ENU point in ECEF.
    pub fn to_ecef(&self, ground: &Enu) -> Ecef {
        ground.to_ecef(&self.origin.to_ecef())
    }
}

/// The image ids and poses of `truth_exposures.csv`.
fn parse_exposures(text: &str, path: &Path) -> Result<Vec<(String, Pose)>, SimError> {
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.starts_with("id,") || line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        let num = |i: usize| f.get(i).and_then(|v| v.trim().parse::<f64>().ok());
        let v: Option<Vec<f64>> = (4..10).map(num).collect();
        let Some(v) = v else {
            return Err(SimError::File {
                path: format!("{}:{}", path.display(), k + 1),
                what: "expected id,strip,week,tow,e,n,u,omega,phi,kappa".into(),
            });
        };
        let pose = pose_of(Vector3::new(v[0], v[1], v[2]), [v[3], v[4], v[5]]);
        out.push((f[0].to_string(), pose));
    }
    Ok(out)
}
