//! The project folder an import writes: `project.toml`, `images.csv`,
//! `image_observations.csv`, and when there are any `ground_points.csv`, `antennas.csv`
//! (GNSS) and `start.csv` (start orientations) — each file atomically, and with
//! [`ProjectOut::write_folder`] the folder as a whole.

use super::common::{ferr, ImportError};
use ::common::frame::Ecef;
use common::atomic::write_atomic;
use nalgebra::{Matrix3, Vector2};
use photo::camera::Camera;
use photo::rotation::Angles;
use std::fmt::Write as _;
use std::path::Path;

/// The files of a project folder [`ProjectOut::write`] may write.
pub const FILES: [&str; 6] = [
    "project.toml",
    "images.csv",
    "image_observations.csv",
    "ground_points.csv",
    "antennas.csv",
    "start.csv",
];

/// A camera to write.
#[derive(Clone, Debug)]
pub struct CameraOut {
    /// Its id.
    pub id: String,
    /// The ppkat camera.
    pub camera: Camera,
    /// Image measurement σ, pixels.
    pub sigma_px: f64,
    /// Interior parameters to estimate.
    pub self_calibrate: Vec<String>,
}

/// A ground point to write.
#[derive(Clone, Debug)]
pub struct GroundOut {
    /// Its id.
    pub id: String,
    /// `gcp` or `check`.
    pub kind: &'static str,
    /// Its position.
    pub pos: Ecef,
    /// σ east, north, up (m).
    pub sigma: [f64; 3],
}

/// A start orientation (or a GNSS antenna position) to write.
#[derive(Clone, Debug)]
pub struct StartOut {
    /// The image.
    pub image: String,
    /// Projection centre (antenna position for GNSS).
    pub pos: Ecef,
    /// Rotation camera → local ENU at `pos`.
    pub r_enu: Matrix3<f64>,
}

/// A whole project to write.
#[derive(Clone, Debug, Default)]
pub struct ProjectOut {
    /// Its name.
    pub name: String,
    /// The `output` key.
    pub output: String,
    /// Comment lines at the top of `project.toml`.
    pub notes: Vec<String>,
    /// The cameras.
    pub cameras: Vec<CameraOut>,
    /// Images: id and camera id.
    pub images: Vec<(String, String)>,
    /// Image measurements: image, point, column, row (pixels).
    pub measurements: Vec<(String, String, f64, f64)>,
    /// Control and check points.
    pub ground: Vec<GroundOut>,
    /// GNSS antenna positions with σ east, north, up (m).
    pub gnss: Vec<(String, Ecef, [f64; 3])>,
    /// The positions are navigation-grade (metres, offset): the project estimates a block
    /// offset; otherwise survey-grade (no drift).
    pub gnss_navigation: bool,
    /// Start orientations.
    pub starts: Vec<StartOut>,
    /// No control and no positions: `[datum] free = true`.
    pub free_datum: bool,
    /// The strip of each image (same order as `images`; empty: no strip column). With
    /// navigation-grade GNSS the drift is then one offset per strip.
    pub image_strips: Vec<String>,
    /// The σ of each measurement, pixels (same order as `measurements`; empty: no σ column,
    /// every measurement has its camera's).
    pub measurement_sigmas: Vec<f64>,
}

fn px(cam: &Camera, xy: Vector2<f64>) -> [f64; 2] {
    let p = cam.image_to_pixel(xy);
    [p.x, p.y]
}

impl ProjectOut {
    /// The `project.toml` text.
    fn toml(&self) -> String {
        let mut s = String::new();
        for n in &self.notes {
            let _ = writeln!(s, "# {n}");
        }
        let _ = writeln!(s, "name = {:?}\noutput = {:?}\n", self.name, self.output);
        for c in &self.cameras {
            let k = &c.camera;
            let pp = px(k, Vector2::new(k.x0, k.y0));
            let dc = px(k, Vector2::new(k.x0 + k.dc[0], k.y0 + k.dc[1]));
            let _ = writeln!(
                s,
                "[[camera]]\nid = {:?}\nfocal_px = {:?}\npixel_um = {:?}\nwidth_px = {}\nheight_px = {}\nprincipal_point_px = {:?}\ndistortion_centre_px = {:?}\nk = {:?}\np = {:?}\nb = {:?}\nsigma_px = {:?}\nself_calibrate = {:?}\n",
                c.id, k.f / k.pixel, k.pixel * 1e6, k.width_px, k.height_px, pp, dc, k.k, k.p, k.b, c.sigma_px, c.self_calibrate
            );
        }
        let _ = writeln!(
            s,
            "[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\""
        );
        if !self.starts.is_empty() {
            let _ = writeln!(s, "start = \"start.csv\"");
        }
        if !self.ground.is_empty() {
            let _ = writeln!(s, "\n[ground]\nfile = \"ground_points.csv\"");
        }
        if self.free_datum {
            let _ = writeln!(s, "\n[datum]\nfree = true");
        }
        if !self.gnss.is_empty() {
            let drift = if self.gnss_navigation && !self.image_strips.is_empty() {
                "drift = \"strip\"\ndrift_model = \"offset\""
            } else if self.gnss_navigation {
                "drift = \"block\"\ndrift_model = \"offset\""
            } else {
                "drift = \"none\""
            };
            let _ = writeln!(s, "\n[gnss]\nantennas = \"antennas.csv\"\nlever_arm = [0.0, 0.0, 0.0]\nestimate_lever_arm = false\n{drift}");
        }
        s
    }

    /// Write the folder `dir` as a whole ([`common::atomic::StagedDir`]): into a staging folder
    /// beside it, swapped in at the end, so that `dir` holds an earlier run's project or this
    /// one, never a mix. An existing `dir` holding other files than [`FILES`] is refused.
    pub fn write_folder(&self, dir: &Path) -> Result<(), ImportError> {
        // Its messages name the folder already.
        let named = |e: common::atomic::Error| ImportError::Usage(e.to_string());
        let staged = common::atomic::StagedDir::new(dir, &FILES).map_err(named)?;
        self.write(staged.path())?;
        staged.commit().map_err(named)
    }

    /// Write the files into the folder `dir` (created); every file atomically.
    pub fn write(&self, dir: &Path) -> Result<(), ImportError> {
        std::fs::create_dir_all(dir)
            .map_err(|e| ferr(dir, None, format!("cannot create the folder: {e}")))?;
        let put = |name: &str, text: String| {
            let path = dir.join(name);
            write_atomic(&path, |w| w.write_all(text.as_bytes()))
                .map_err(|e| ferr(&path, None, format!("cannot write: {e}")))
        };
        put("project.toml", self.toml())?;
        let strips = self.image_strips.len() == self.images.len();
        let mut s = String::from(if strips {
            "image,camera,strip\n"
        } else {
            "image,camera\n"
        });
        for (k, (i, c)) in self.images.iter().enumerate() {
            match strips {
                true => writeln!(s, "{i},{c},{}", self.image_strips[k]),
                false => writeln!(s, "{i},{c}"),
            }
            .ok();
        }
        put("images.csv", s)?;
        let sigmas = self.measurement_sigmas.len() == self.measurements.len()
            && !self.measurements.is_empty();
        let mut s = String::from(match sigmas {
            true => "image,point,x_px,y_px,sigma_px\n",
            false => "image,point,x_px,y_px\n",
        });
        for (k, (i, p, x, y)) in self.measurements.iter().enumerate() {
            let _ = match sigmas {
                true => writeln!(s, "{i},{p},{x:.4},{y:.4},{:.4}", self.measurement_sigmas[k]),
                false => writeln!(s, "{i},{p},{x:.4},{y:.4}"),
            };
        }
        put("image_observations.csv", s)?;
        if !self.ground.is_empty() {
            let mut s = String::from("point,kind,x,y,z,sigma_e,sigma_n,sigma_u\n");
            for g in &self.ground {
                let p = g.pos.0;
                let _ = writeln!(
                    s,
                    "{},{},{:.7},{:.7},{:.7},{},{},{}",
                    g.id, g.kind, p.x, p.y, p.z, g.sigma[0], g.sigma[1], g.sigma[2]
                );
            }
            put("ground_points.csv", s)?;
        }
        if !self.gnss.is_empty() {
            let mut s = String::from("# times unknown to the source: sequence numbers\nid,week,tow,lat,lon,h,c_ee,c_en,c_eu,c_nn,c_nu,c_uu,segment,quality\n");
            for (k, (i, pos, sg)) in self.gnss.iter().enumerate() {
                let g = pos.to_geodetic();
                let _ = writeln!(
                    s,
                    "{i},0,{k},{:.10},{:.10},{:.4},{:e},0,0,{:e},0,{:e},0,1",
                    g.lat.to_degrees(),
                    g.lon.to_degrees(),
                    g.h,
                    sg[0] * sg[0],
                    sg[1] * sg[1],
                    sg[2] * sg[2]
                );
            }
            put("antennas.csv", s)?;
        }
        if !self.starts.is_empty() {
            let mut s = String::from("# start orientations: centre, omega/phi/kappa (deg) of R camera->ENU at the centre, R = Rw*Rp*Rk\nimage,lat,lon,h,omega,phi,kappa\n");
            for st in &self.starts {
                let g = st.pos.to_geodetic();
                let Angles::OmegaPhiKappa { omega, phi, kappa } =
                    Angles::omega_phi_kappa(&st.r_enu)
                else {
                    continue;
                };
                let _ = writeln!(
                    s,
                    "{},{:.10},{:.10},{:.4},{:.8},{:.8},{:.8}",
                    st.image,
                    g.lat.to_degrees(),
                    g.lon.to_degrees(),
                    g.h,
                    omega.to_degrees(),
                    phi.to_degrees(),
                    kappa.to_degrees()
                );
            }
            put("start.csv", s)?;
        }
        Ok(())
    }
}
