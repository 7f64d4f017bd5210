//! The truth files of a simulated flight, for tests and for `demo`: the antenna trajectory,
//! the exposures (projection centre, antenna, attitude), the ground points, the image
//! observations with the injected blunders, and the camera. Enters: the scenario, its flight
//! and exposures, ground points and image observations. Leaves: CSV and TOML files in the
//! simulation folder. Times are true GPST (week, seconds of week); positions ECEF metres or
//! the site's ENU frame; angles degrees.

use super::camera::{Exposure, GroundPoint, ImageObs, PointKind};
use super::error::SimError;
use super::flight::Flight;
use super::io::write;
use super::scenario::Scenario;
use super::site::SiteFrame;
use hifitime::{Duration, Epoch};
use std::fmt::Write as _;
use std::path::Path;

/// What the simulation knows beyond its GNSS files.
pub(super) struct Truth<'a> {
    /// The analytic flight.
    pub flight: &'a Flight,
    /// Its start, GPST.
    pub start: Epoch,
    /// The exposures.
    pub exposures: &'a [Exposure],
    /// The ground points.
    pub points: &'a [GroundPoint],
    /// The image observations (with their blunders).
    pub obs: &'a [ImageObs],
    /// The rover's clock: offset at the start (s) and drift (s/s), zero when not simulated.
    /// Its epoch tagged k/rate seconds after the start was measured at that minus the
    /// offset: the truth is written at those instants.
    pub rover_clock: (f64, f64),
}

/// Write every truth file of a run into `dir`.
pub(super) fn write_all(
    dir: &Path,
    s: &Scenario,
    site: &SiteFrame,
    truth: &Truth,
) -> Result<(), SimError> {
    write(
        dir,
        "truth_trajectory.csv",
        &trajectory(s, site, truth.flight, truth.start, truth.rover_clock),
    )?;
    write(
        dir,
        "truth_exposures.csv",
        &exposures(site, truth.start, truth.exposures),
    )?;
    write(
        dir,
        "ground_points.csv",
        &ground_points(s, site, truth.points),
    )?;
    let (io, bl) = image_observations(truth.obs);
    write(dir, "image_observations.csv", &io)?;
    write(dir, "truth_blunders.csv", &bl)?;
    write(dir, "camera.toml", &camera(s))?;
    Ok(())
}

/// The antenna at the true reception time of every rover epoch (its tag minus the clock
/// offset), from the start to one sample past the end (so that every observation epoch lies
/// inside the truth): ECEF position and velocity, NED attitude. A solution at its true
/// reception time (as `.pos` files give it) is then compared with the truth at the same
/// instant, not 0.2 ms away (1 cm at 55 m/s).
fn trajectory(
    s: &Scenario,
    site: &SiteFrame,
    flight: &Flight,
    start: Epoch,
    clock: (f64, f64),
) -> String {
    let mut traj = String::from("# antenna phase centre at the true reception time of each rover epoch (receiver tag − clock offset), GPST; ECEF metres; velocity m/s; attitude degrees (NED body)\nweek,tow,x,y,z,vx,vy,vz,roll,pitch,yaw\n");
    let n = (flight.duration() * s.flight.rate_hz).ceil() as usize + 1;
    let rot = gnss::frame::enu_rotation(&site.geo).transpose();
    for k in 0..=n {
        let tag = k as f64 / s.flight.rate_hz;
        let t = tag - (clock.0 + clock.1 * tag);
        let st = flight.at(t);
        let p = site.to_ecef(&st.pos);
        let v = rot * st.vel;
        let (w, tow) = gnss::time::week_tow(start + Duration::from_seconds(t));
        let _ = writeln!(
            traj,
            "{w},{tow:.9},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5}",
            p.0.x,
            p.0.y,
            p.0.z,
            v.x,
            v.y,
            v.z,
            st.roll.to_degrees(),
            st.pitch.to_degrees(),
            st.yaw.to_degrees()
        );
    }
    traj
}

/// Every exposure: projection centre and antenna (ECEF and ENU), NED attitude and ω-φ-κ.
fn exposures(site: &SiteFrame, start: Epoch, exps: &[Exposure]) -> String {
    let mut ex = String::from("# exposures, true GPST; projection centre S and antenna A in ECEF metres and local ENU (site origin); angles degrees; omega/phi/kappa: R = Rω·Rφ·Rκ camera→ENU\nid,strip,week,tow,xs,ys,zs,xa,ya,za,es,ns,us,roll,pitch,yaw,omega,phi,kappa\n");
    for e in exps {
        let (w, tow) = gnss::time::week_tow(start + Duration::from_seconds(e.t));
        let sx = site.to_ecef(&e.centre);
        let ax = site.to_ecef(&e.state.pos);
        let [om, ph, ka] = exposure::attitude::omega_phi_kappa(&e.r);
        let _ = writeln!(ex, "{},{},{w},{tow:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5},{:.6},{:.6},{:.6}", e.id, e.strip + 1, sx.0.x, sx.0.y, sx.0.z, ax.0.x, ax.0.y, ax.0.z, e.centre.x, e.centre.y, e.centre.z, e.state.roll.to_degrees(), e.state.pitch.to_degrees(), e.state.yaw.to_degrees(), om.to_degrees(), ph.to_degrees(), ka.to_degrees());
    }
    ex
}

/// Ground points in the site's ENU frame and geodetic, with the sigmas of control.
fn ground_points(s: &Scenario, site: &SiteFrame, points: &[GroundPoint]) -> String {
    let mut gp = format!("# ground points; local ENU at lat {} lon {} h {} (metres) and geodetic; sigmas of control in metres\npoint,kind,east,north,up,lat_deg,lon_deg,h,sigma_xy,sigma_z\n", s.site.lat_deg, s.site.lon_deg, s.site.ground_height);
    for p in points {
        let g = site.to_ecef(&p.enu).to_geodetic();
        // Control carries a σ; check and tie points are exact (σ 0).
        let (sxy, sz) = if p.kind == PointKind::Gcp {
            (0.02, 0.03)
        } else {
            (0.0, 0.0)
        };
        let _ = writeln!(
            gp,
            "{},{},{:.4},{:.4},{:.4},{:.9},{:.9},{:.4},{sxy},{sz}",
            p.id,
            p.kind.name(),
            p.enu.x,
            p.enu.y,
            p.enu.z,
            g.lat.to_degrees(),
            g.lon.to_degrees(),
            g.h
        );
    }
    gp
}

/// The image measurements (pixels) and, apart, the blunders injected into them.
fn image_observations(obs: &[ImageObs]) -> (String, String) {
    let mut io = String::from("# image measurements, pixels (x along track to the right, y down), with their sigma\nimage,point,x_px,y_px,sigma_px\n");
    let mut bl = String::from("# injected image blunders (truth)\nimage,point,dx_px\n");
    for o in obs {
        let _ = writeln!(
            io,
            "{},{},{:.3},{:.3},{}",
            o.image, o.point, o.x, o.y, o.sigma
        );
        if o.blunder != 0.0 {
            let _ = writeln!(bl, "{},{},{:.3}", o.image, o.point, o.blunder);
        }
    }
    (io, bl)
}

/// The camera as the scenario gives it (millimetres, micrometres, lever arm in metres).
fn camera(s: &Scenario) -> String {
    format!(
        "focal_mm = {}\nwidth_px = {}\nheight_px = {}\npixel_um = {}\nlever_arm = {:?}\n",
        s.camera.focal_mm,
        s.camera.width_px,
        s.camera.height_px,
        s.camera.pixel_um,
        s.camera.lever_arm
    )
}
